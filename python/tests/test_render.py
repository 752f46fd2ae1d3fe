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


def test_guiding_as_the_program_and_checked(cierzo, tmp_path):
    # (48 paths: the guide is trained after 16 and 32 and sampled after)
    kw = dict(SMALL, spp=48)
    out, stats_path = tmp_path / "guided.exr", tmp_path / "guided.json"
    code, err = run_cli("render", scene_path("small_emitter"), "--width", kw["width"], "--height",
                        kw["height"], "--spp", kw["spp"], "--seed", kw["seed"], "--threads",
                        kw["threads"], "--estimator", "mis", "--integrator", "scalar",
                        "--guiding", "sdtree", "--guided-vertices", 2, "--out", out, "--stats",
                        stats_path, "--quiet")
    assert code == 0, err
    with open(stats_path) as f:
        stats = json.load(f)
    image, st = cierzo.render(scene_path("small_emitter"), estimator="mis", integrator="scalar",
                              guiding="sdtree", guided_vertices=2, **kw)
    assert same_bits(image, cierzo.read_exr(out))
    assert st["guiding"]["trainings"] == stats["guiding"]["trainings"] >= 2
    assert st["guiding"]["cells"] == stats["guiding"]["cells"] >= 1
    assert st["guiding"]["guided_vertices"] == stats["guiding"]["guided_vertices"] == 2
    with pytest.raises(cierzo.Error, match="guiding"):
        cierzo.render(scene_path("small_emitter"), estimator="lt", guiding="sdtree", **SMALL)
    with pytest.raises(ValueError, match="guiding"):
        cierzo.render(scene_path("small_emitter"), guiding="sometimes", **SMALL)


def test_bdpt_strategy_images_as_the_program_and_adding_up(cierzo, tmp_path):
    exr, _ = cli_render(tmp_path, scene_path("caustic"),
                        extra=("--estimator", "bdpt", "--max-length", "3", "--min-length", "3",
                               "--strategy", "2,2"))
    image, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", min_length=3, max_length=3,
                             strategy=(2, 2), **SMALL)
    assert same_bits(image, cierzo.read_exr(exr))
    # the weighted images of one length's strategies add up to that length's image
    whole, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", min_length=3, max_length=3,
                             **SMALL)
    parts = [cierzo.render(scene_path("caustic"), estimator="bdpt", min_length=3, max_length=3,
                           strategy=(s, 4 - s), **SMALL)[0].astype("float64") for s in range(4)]
    assert abs(sum(parts) - whole).max() <= 1e-4 * whole.max() + 1e-6
    assert all(p.max() > 0 for p in parts)
    unweighted, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", min_length=3,
                                  max_length=3, strategy=(2, 2), unweighted=True, **SMALL)
    assert unweighted.sum() > image.sum()
    with pytest.raises(ValueError, match="strategy"):
        cierzo.render(scene_path("caustic"), estimator="mis", strategy=(1, 2), **SMALL)
    with pytest.raises(ValueError, match="unweighted"):
        cierzo.render(scene_path("caustic"), estimator="bdpt", unweighted=True, **SMALL)


def test_bdpt_every_strategy_image_of_one_render_as_arrays_and_files(cierzo, tmp_path):
    image, stats, strategies = cierzo.render(scene_path("caustic"), estimator="bdpt",
                                             max_length=3, strategies=True, **SMALL)
    assert stats["integrator"] == "scalar"
    assert sorted(strategies) == sorted((s, k + 1 - s) for k in (1, 2, 3) for s in range(k + 1))
    plain, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", max_length=3,
                             integrator="scalar", **SMALL)
    assert same_bits(image, plain)
    for (s, t), pair in strategies.items():
        assert pair["weighted"].shape == image.shape and pair["weighted"].dtype == np.float32
        one, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", max_length=3,
                               integrator="scalar", strategy=(s, t), **SMALL)
        assert abs(pair["weighted"] - one).max() <= 1e-5 * (one.max() + 1e-6)
    total = sum(p["weighted"].astype("float64") for p in strategies.values())
    assert abs(total - image).max() <= 1e-4 * image.max() + 1e-6
    # the program's files hold the same images
    exr, _ = cli_render(tmp_path, scene_path("caustic"),
                        extra=("--estimator", "bdpt", "--max-length", "3", "--strategies",
                               tmp_path / "strategies"))
    for (s, t), pair in strategies.items():
        for kind, suffix in (("weighted", ""), ("unweighted", "_unweighted")):
            name = tmp_path / "strategies" / f"length{s + t - 1}_s{s}_t{t}{suffix}.exr"
            assert same_bits(pair[kind], cierzo.read_exr(name)), name
    with pytest.raises(ValueError, match="strategies"):
        cierzo.render(scene_path("caustic"), estimator="vcm", strategies=True, **SMALL)


def test_vcm_as_the_program_and_its_options_checked(cierzo, tmp_path):
    exr, _ = cli_render(tmp_path, scene_path("caustic"),
                        extra=("--estimator", "vcm", "--merge-radius", "0.08",
                               "--merge-alpha", "0.6"))
    image, stats = cierzo.render(scene_path("caustic"), estimator="vcm", merge_radius=0.08,
                                 merge_alpha=0.6, **SMALL)
    assert same_bits(image, cierzo.read_exr(exr))
    assert stats["estimator"] == "vcm"
    # another radius is another image
    other, _ = cierzo.render(scene_path("caustic"), estimator="vcm", merge_radius=0.3, **SMALL)
    assert not same_bits(image, other)
    with pytest.raises(ValueError, match="merge-radius"):
        cierzo.render(scene_path("caustic"), estimator="vcm", merge_radius=-1.0, **SMALL)
    with pytest.raises(ValueError, match="merge-alpha"):
        cierzo.render(scene_path("caustic"), estimator="vcm", merge_alpha=1.0, **SMALL)
    with pytest.raises(ValueError, match="vcm"):
        cierzo.render(scene_path("caustic"), estimator="bdpt", merge_radius=0.1, **SMALL)


def test_light_connections_as_the_program_and_checked(cierzo, tmp_path):
    exr, _ = cli_render(tmp_path, scene_path("caustic"),
                        extra=("--estimator", "bdpt", "--light-connections", "3"))
    image, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", light_connections=3, **SMALL)
    assert same_bits(image, cierzo.read_exr(exr))
    # the pairing (0) and the default draws are other images
    pairing, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", light_connections=0, **SMALL)
    default, _ = cierzo.render(scene_path("caustic"), estimator="bdpt", **SMALL)
    assert not same_bits(image, pairing) and not same_bits(image, default)
    with pytest.raises(ValueError, match="light-connections"):
        cierzo.render(scene_path("caustic"), estimator="bdpt", light_connections=65, **SMALL)
    with pytest.raises(ValueError, match="bdpt's and vcm's"):
        cierzo.render(scene_path("caustic"), estimator="mis", light_connections=1, **SMALL)


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


def png_bytes(width, height, channels, texel):
    """An 8-bit PNG written here (zlib only): texel(x, y) gives the channels' bytes."""
    import struct
    import zlib

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    rows = b"".join(b"\0" + bytes(c for x in range(width) for c in texel(x, y))
                    for y in range(height))
    colour = {3: 2, 4: 6}[channels]
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, colour, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def test_downloaded_model_renders_as_in_the_program(cierzo, tmp_path):
    """An OBJ with its MTL (a colour map, an alpha mask with holes), wrapped by a scene with an
    environment light: the module's image is the program's bit for bit, the holes show the
    sky, and the model file alone renders as `cierzo render model.obj` does."""
    (tmp_path / "wood.png").write_bytes(
        png_bytes(8, 8, 3, lambda x, y: (200, 120 + 10 * x, 40 + 20 * y)))
    (tmp_path / "mask.png").write_bytes(
        png_bytes(8, 8, 4, lambda x, y: (255, 255, 255, 0 if (x // 2 + y // 2) % 2 else 255)))
    (tmp_path / "model.obj").write_text(
        "mtllib model.mtl\nv -3 -3 0\nv 3 -3 0\nv 3 3 0\nv -3 3 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl board\nf 1/1 2/2 3/3 4/4\n")
    (tmp_path / "model.mtl").write_text(
        "newmtl board\nKd 1 1 1\nKs 0.2 0.2 0.2\nNs 20\nmap_Kd wood.png\nmap_d mask.png\n")
    scene = tmp_path / "scene.json"
    scene.write_text(json.dumps({
        "camera": {"position": [0, 0, 2.5], "look_at": [0, 0, 0], "vfov": 50,
                   "handedness": "right"},
        "environment": {"emission": 0.5},
        "lights": [{"position": [1, 2, 3], "intensity": 5}],
        "objects": [{"type": "mesh", "file": "model.obj"}]}))
    exr, cli_stats = cli_render(tmp_path, scene, extra=("--estimator", "mis"))
    image, stats = cierzo.render(str(scene), estimator="mis", **SMALL)
    assert same_bits(image, cierzo.read_exr(exr))
    assert stats["load"]["images"] == cli_stats["load"]["images"] == 2
    # The board fills the view: through its holes (and only there) the camera sees the grey
    # sky, 0.5 exactly; on the board, lit by it
    # and the light, the wood's red exceeds its blue
    sky = np.all(image == np.float32(0.5), axis=2)
    assert 0.1 * sky.size < sky.sum() < 0.9 * sky.size
    board = ~sky
    assert (image[board][:, 0] > image[board][:, 2]).mean() > 0.9
    # The model alone, as the program renders it
    out = tmp_path / "alone.exr"
    code, err = run_cli("render", tmp_path / "model.obj", "--width", 24, "--height", 16,
                        "--spp", 4, "--seed", 7, "--threads", 2, "--out", out, "--quiet")
    assert code == 0, err
    alone, _ = cierzo.render(str(tmp_path / "model.obj"), **SMALL)
    assert same_bits(alone, cierzo.read_exr(out))
