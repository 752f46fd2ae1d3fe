# The Python module's tests: where the module, the programs and the scenes are. ctest runs
# them with PYTHONPATH at the built module, CIERZO_BIN at the `cierzo` program of the same
# build and CIERZO_SOURCE_DIR at the checkout.
import os
import subprocess

import pytest

SOURCE_DIR = os.environ.get(
    "CIERZO_SOURCE_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
CIERZO_BIN = os.environ.get("CIERZO_BIN", os.path.join(SOURCE_DIR, "build", "cierzo"))
TONEMAP_BIN = os.path.join(os.path.dirname(CIERZO_BIN), "cierzo-tonemap")
SCENES = os.path.join(SOURCE_DIR, "scenes")


def scene_path(name):
    return os.path.join(SCENES, name + ".json")


def run_cli(*args, cwd=None, program=CIERZO_BIN):
    """Runs a program of the build; returns (exit status, stderr)."""
    p = subprocess.run([program, *map(str, args)], cwd=cwd, capture_output=True, text=True,
                       timeout=120)
    return p.returncode, p.stderr


@pytest.fixture(scope="session")
def cierzo():
    import cierzo as module
    return module
