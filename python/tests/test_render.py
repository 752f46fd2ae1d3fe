# Renders through the module against the `cierzo` program: the same image bit for bit, the
# same statistics, scenes from dicts, and stopping a render.
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from conftest import CIERZO_BIN, SCENES, run_cli, scene_path

SMALL = dict(width=24, height=16, spp=4, seed=7, threads=2)


def cli_render(tmp_path, scene, name="cli", extra=()):
    out, stats = tmp_path / (name + ".exr"), tmp_path / (name + ".json")
    code, err = run_cli("render", scene, "--width", SMALL["width"], "--height", SMALL["height"],
                        "--spp", SMALL["spp"], "--seed", SMALL["seed"], "--threads",
                        SMALL["threads"], "--out", out, "--stats", stats, "--quiet", *extra)
    assert code == 0, err
    with open(stats) as f:
        return out, json.load(f)


def same_bits(a, b):
    return a.dtype == b.dtype == np.float32 and a.shape == b.shape and \
        np.array_equal(a.view(np.uint32), b.view(np.uint32))


def keys(d, prefix=""):
    """Every key of a nested dict, as dotted paths."""
    out = set()
    for k, v in d.items():
        out.add(prefix + k)
        if isinstance(v, dict):
            out |= keys(v, prefix + k + ".")
    return out


@pytest.mark.parametrize("scene,integrator", [("cornell", "wavefront"), ("cornell", "scalar"),
                                              ("four_lobes", "wavefront"),
                                              ("smooth_normals", "wavefront"),
                                              ("smooth_normals", "scalar")])
def test_image_equals_the_programs_exr(cierzo, tmp_path, scene, integrator):
    exr, cli_stats = cli_render(tmp_path, scene_path(scene), extra=("--integrator", integrator))
    image, stats = cierzo.render(scene_path(scene), integrator=integrator, **SMALL)
    assert image.shape == (16, 24, 3)
    assert same_bits(image, cierzo.read_exr(exr))
    assert keys(stats) == keys(cli_stats)
    for k in ("scene", "integrator", "isa", "width", "height", "spp", "spp_reached", "seed",
              "estimator", "paths", "rays", "emitters", "stopped_by", "nonfinite_samples"):
        assert stats[k] == cli_stats[k], k


def test_variance_and_overrides(cierzo, tmp_path):
    exr, _ = cli_render(tmp_path, scene_path("cornell"),
                        extra=("--estimator", "mis", "--diffuse-sampling", "cosine",
                               "--survival-cap", "0.5", "--roulette", "throughput",
                               "--roulette-depth", "2", "--triangle-sampling", "solid-angle",
                               "--variance"))
    image, variance, stats = cierzo.render(scene_path("cornell"), estimator="mis",
                                           diffuse_sampling="cosine", survival_cap=0.5,
                                           roulette="throughput", roulette_depth=2,
                                           triangle_sampling="solid-angle",
                                           variance=True, **SMALL)
    cli_image, cli_variance = cierzo.read_exr(exr, variance=True)
    assert same_bits(image, cli_image) and same_bits(variance, cli_variance)
    assert (variance >= 0).all() and variance.max() > 0
    assert stats["estimator"] == "mis"
    _, meta = cierzo.read_exr(exr, metadata=True)
    assert meta["cierzo:estimator"] == "mis" and meta["cierzo:spp"] == "4"


@pytest.mark.parametrize("sampler", ["sobol", "zsobol", "pmj02"])
def test_sampler_and_lengths_as_the_program(cierzo, tmp_path, sampler):
    exr, _ = cli_render(tmp_path, scene_path("box"),
                        extra=("--estimator", "lt", "--sampler", sampler, "--min-length", "2",
                               "--max-length", "3"))
    image, _ = cierzo.render(scene_path("box"), estimator="lt", sampler=sampler,
                             min_length=2, max_length=3, **SMALL)
    assert same_bits(image, cierzo.read_exr(exr))
    _, meta = cierzo.read_exr(exr, metadata=True)
    assert meta["cierzo:estimator"] == "lt"
    # the lengths split the image: 1..1 + 2..3 + 4.. is the whole, up to the film's rounding
    whole, _ = cierzo.render(scene_path("box"), estimator="lt", sampler=sampler, **SMALL)
    first, _ = cierzo.render(scene_path("box"), estimator="lt", sampler=sampler,
                             max_length=1, **SMALL)
    rest, _ = cierzo.render(scene_path("box"), estimator="lt", sampler=sampler,
                            min_length=4, **SMALL)
    total = first.astype("float64") + image + rest
    assert abs(total - whole).max() <= 1e-5 * whole.max() + 1e-6
    assert image.max() > 0 and rest.max() > 0


def test_isa_this_cpu_lacks_has_the_programs_message(cierzo):
    lacking = [i["name"] for i in cierzo.isas() if not i["supported"]]
    if not lacking:
        pytest.skip("this CPU runs every instruction set of the build")
    code, err = run_cli("render", scene_path("cornell"), "--isa", lacking[0], "--quiet")
    assert code == 1
    with pytest.raises(cierzo.Error) as e:
        cierzo.render(scene_path("cornell"), isa=lacking[0])
    assert "cierzo: " + str(e.value) + "\n" == err


def test_dict_equals_the_file(cierzo):
    with open(scene_path("vertex_colors")) as f:
        d = json.load(f)
    from_file = cierzo.load_scene(scene_path("vertex_colors"))
    from_dict = cierzo.load_scene(d, base=SCENES)
    assert from_dict.source == os.path.join(SCENES, "<dict>")
    a, _ = cierzo.render(from_file, **SMALL)
    b, _ = cierzo.render(from_dict, **SMALL)
    assert same_bits(a, b)
    # The scene keeps its own settings; keywords only override one render
    assert from_dict.width == 500 and from_dict.spp == 64


def test_dict_paths_resolve_against_the_current_folder(cierzo, monkeypatch):
    with open(scene_path("vertex_colors")) as f:
        d = json.load(f)
    monkeypatch.chdir(SCENES)
    a, _ = cierzo.render(d, **SMALL)
    b, _ = cierzo.render(scene_path("vertex_colors"), **SMALL)
    assert same_bits(a, b)


def test_cancel_from_another_thread(cierzo):
    scene = cierzo.load_scene(scene_path("cornell"))
    for cancel in (cierzo.Cancel(), threading.Event()):
        timer = threading.Timer(0.3, cancel.set if isinstance(cancel, threading.Event)
                                else cancel.cancel)
        start = time.monotonic()
        timer.start()
        image, stats = cierzo.render(scene, width=64, height=64, spp=1 << 20, threads=2,
                                     cancel=cancel)
        elapsed = time.monotonic() - start
        assert elapsed < 10
        assert stats["stopped_by"] == "interrupted"
        assert 1 <= stats["spp_reached"] < 1 << 20
        assert np.isfinite(image).all() and image.mean() > 0


def test_other_threads_run_while_rendering(cierzo):
    # The GIL is released: a Python thread counts to 50 while the render runs, then stops it
    # (the time budget only keeps a failure from hanging the suite)
    cancel = cierzo.Cancel()
    count = [0]

    def counter():
        while count[0] < 50:
            count[0] += 1
            time.sleep(0.001)
        cancel.cancel()

    t = threading.Thread(target=counter)
    t.start()
    _, stats = cierzo.render(scene_path("cornell"), width=64, height=64, spp=1 << 20, threads=2,
                             time_budget=60, cancel=cancel)
    t.join()
    assert count[0] == 50 and stats["stopped_by"] == "interrupted"


def test_ctrl_c_raises_keyboard_interrupt(tmp_path):
    # In a child process, which sends itself SIGINT while rendering
    script = tmp_path / "interrupt.py"
    script.write_text(f"""
import os, signal, threading, time, cierzo
threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT)).start()
start = time.monotonic()
try:
    cierzo.render({scene_path("cornell")!r}, width=64, height=64, spp=1 << 20, threads=2)
    print("finished")
except KeyboardInterrupt:
    print("interrupted", time.monotonic() - start)
""")
    p = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                       timeout=60, env=os.environ)
    assert p.returncode == 0, p.stderr
    word, seconds = p.stdout.split()
    assert word == "interrupted" and float(seconds) < 10


def test_checkpoint_and_resume_give_the_uninterrupted_image(cierzo, tmp_path):
    kw = dict(width=16, height=16, spp=1 << 16, seed=3, threads=2)
    whole, _ = cierzo.render(scene_path("cornell"), **kw)
    # (cancelled before it starts: the render stops at the first pass end after the module's
    # first look at `cancel`, 20 ms in, far from the 16.7 million paths, and writes the
    # checkpoint)
    cancel = threading.Event()
    cancel.set()
    part, stats = cierzo.render(scene_path("cornell"), checkpoint=tmp_path / "c.exr",
                                cancel=cancel, **kw)
    assert stats["stopped_by"] == "interrupted" and 1 <= stats["spp_reached"] < 1 << 16
    assert stats["checkpoint"]["writes"] >= 1 and os.path.exists(tmp_path / "c.exr")
    resumed, stats = cierzo.render(scene_path("cornell"), resume=tmp_path / "c.exr", **kw)
    assert same_bits(resumed, whole) and stats["stopped_by"] == ""
    with pytest.raises(cierzo.Error, match="seed"):
        cierzo.render(scene_path("cornell"), resume=tmp_path / "c.exr", **dict(kw, seed=4))
    with pytest.raises(cierzo.Error, match="--checkpoint-every needs --checkpoint"):
        cierzo.render(scene_path("cornell"), checkpoint_every=1, **kw)


def test_stopping_rules(cierzo):
    _, stats = cierzo.render(scene_path("cornell"), width=32, height=32, spp=1 << 20,
                             time_budget=0.2, threads=2)
    assert stats["stopped_by"] == "time budget" and stats["spp_reached"] < 1 << 20
