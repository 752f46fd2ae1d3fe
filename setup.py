"""Builds the Python module `cierzo` with the project's CMake (see docs/python.md).

The C++ libraries and python/cierzo_module.cpp are configured and built in a folder of
setuptools' build tree, without the tests, benchmarks or MPI, and the module is copied to
where setuptools packs it. CMAKE_BUILD_PARALLEL_LEVEL sets the build's jobs (default: every
CPU), CMAKE_ARGS adds options to the configuration.
"""
import glob
import os
import shlex
import shutil
import subprocess
import sys

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

ROOT = os.path.dirname(os.path.abspath(__file__))


class CMakeExtension(Extension):
    def __init__(self, name):
        super().__init__(name, sources=[])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        build = os.path.join(os.path.abspath(self.build_temp), "cmake")
        configure = [
            "cmake", "-S", ROOT, "-B", build, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
            "-DCIERZO_BUILD_TESTS=OFF", "-DCIERZO_BUILD_BENCH=OFF", "-DCIERZO_MPI=OFF",
            "-DCIERZO_PYTHON=ON", f"-DPython_EXECUTABLE={sys.executable}",
            *shlex.split(os.environ.get("CMAKE_ARGS", "")),
        ]
        jobs = os.environ.get("CMAKE_BUILD_PARALLEL_LEVEL", str(os.cpu_count() or 1))
        subprocess.run(configure, check=True)
        subprocess.run(["cmake", "--build", build, "--target", "cierzo_python", "--parallel",
                        jobs], check=True)
        built = glob.glob(os.path.join(build, "python", "module", "cierzo*.so"))
        if len(built) != 1:
            sys.exit(f"setup.py: expected one module in {build}/python/module, found {built} "
                     "(are python3-dev and pybind11-dev installed?)")
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copyfile(built[0], target)


setup(
    packages=[],  # the module alone (no package discovery, which would take src/ for one)
    ext_modules=[CMakeExtension("cierzo")],
    cmdclass={"build_ext": CMakeBuild},
    options={"build": {"build_base": "build-pip"}},
    zip_safe=False,
)
