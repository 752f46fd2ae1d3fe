# Bad input raises cierzo.Error (a ValueError and an OSError) with the program's message.
import json
import os

import numpy as np
import pytest

from conftest import TONEMAP_BIN, run_cli, scene_path


def base_scene():
    with open(scene_path("cornell")) as f:
        return json.load(f)


def cli_message(tmp_path, scene_dict, *args):
    """The program's message for the same JSON, in a file named as the module names a dict."""
    (tmp_path / "<dict>").write_text(json.dumps(scene_dict))
    code, err = run_cli("render", "<dict>", "--quiet", *args, cwd=tmp_path)
    assert code == 1
    assert err.startswith("cierzo: ")
    return err[len("cierzo: "):].rstrip("\n")


@pytest.mark.parametrize("change", ["unknown key", "negative radius", "missing mesh", "not json"])
def test_bad_scene_has_the_programs_message(cierzo, tmp_path, monkeypatch, change):
    d = base_scene()
    if change == "unknown key":
        d["renderr"] = {}
    elif change == "negative radius":
        d["objects"].append({"type": "sphere", "center": [0, 0, 0], "radius": -1,
                             "material": "white"})
    elif change == "missing mesh":
        d["objects"].append({"type": "mesh", "file": "no_such.ply", "material": "white"})
    elif change == "not json":
        d["camera"] = float("nan")  # json.dumps writes NaN, which is not JSON
    expected = cli_message(tmp_path, d)
    monkeypatch.chdir(tmp_path)
    with pytest.raises(cierzo.Error) as e:
        cierzo.load_scene(d)
    assert str(e.value) == expected
    assert isinstance(e.value, ValueError) and isinstance(e.value, OSError)


def test_a_scenes_files_stay_in_its_folder_unless_allowed(cierzo, tmp_path):
    (tmp_path / "scene").mkdir()
    (tmp_path / "shared").mkdir()
    (tmp_path / "shared" / "tri.ply").write_text(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
        "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
        "end_header\n-1 -1 0\n1 -1 0\n0 1 0\n3 0 1 2\n")
    d = base_scene()
    d["objects"].append({"type": "mesh", "file": "../shared/tri.ply", "material": "white"})
    path = tmp_path / "scene" / "s.json"
    path.write_text(json.dumps(d))
    with pytest.raises(cierzo.Error, match="outside the scene's folder"):
        cierzo.load_scene(path)
    assert cierzo.load_scene(path, allow_paths=[tmp_path / "shared"]).width > 0
    # the images' budget, charged from their headers
    d["environment"] = {"emission": {"texture": "image", "file": "sky.png"}}
    path.write_text(json.dumps(d))
    cierzo.write_ldr(tmp_path / "scene" / "sky.png", np.full((4, 8, 3), 0.5, np.float32))
    with pytest.raises(cierzo.Error, match="over the budget of 100 bytes"):
        cierzo.load_scene(path, allow_paths=[tmp_path / "shared"], image_memory=100)
    assert cierzo.load_scene(path, allow_paths=[tmp_path / "shared"]).width > 0


def test_missing_scene_file(cierzo, tmp_path):
    with pytest.raises(cierzo.Error, match="no_such.json: cannot open scene file"):
        cierzo.load_scene(tmp_path / "no_such.json")
    with pytest.raises(OSError):
        cierzo.render(str(tmp_path / "no_such.json"))


def test_unwritable_path_has_the_programs_message(cierzo, tmp_path):
    out = tmp_path / "no_folder" / "x.exr"
    code, err = run_cli("render", scene_path("cornell"), "--out", out, "--quiet")
    assert code == 1
    with pytest.raises(cierzo.Error) as e:
        cierzo.write_exr(out, np.zeros((2, 2, 3), np.float32))
    assert "cierzo: " + str(e.value) + "\n" == err
    with pytest.raises(cierzo.Error, match="it is a folder"):
        cierzo.write_exr(tmp_path, np.zeros((2, 2, 3), np.float32))


def test_render_size_limit_has_the_programs_message(cierzo, tmp_path):
    code, err = run_cli("render", scene_path("cornell"), "--spp", 4294967295, "--quiet")
    assert code == 1
    with pytest.raises(cierzo.Error) as e:
        cierzo.render(scene_path("cornell"), spp=4294967295)
    assert "cierzo: " + str(e.value) + "\n" == err


@pytest.mark.parametrize("kw", [dict(integrator="fast"), dict(spp=0), dict(isa="mmx"),
                                dict(estimator="sppm"), dict(survival_cap=1.5), dict(width=0),
                                dict(pool=-16), dict(diffuse_sampling="gaussian"),
                                dict(roulette="russian"), dict(roulette_depth=-1),
                                dict(roulette_depth=1025), dict(triangle_sampling="cone"),
                                dict(sampler="halton"), dict(min_length=0),
                                dict(max_length=2000000), dict(guided_vertices=-1)])
def test_bad_keywords(cierzo, kw):
    with pytest.raises(ValueError, match=next(iter(kw))):
        cierzo.render(scene_path("cornell"), **kw)


def test_throughput_roulette_with_report_has_the_programs_message(cierzo):
    code, err = run_cli("render", scene_path("cornell"), "--roulette", "throughput",
                        "--spp", 1, "--quiet")
    assert code == 1 and "throughput roulette" in err
    with pytest.raises(cierzo.Error) as e:
        cierzo.render(scene_path("cornell"), roulette="throughput", spp=1)
    assert "cierzo: " + str(e.value) + "\n" == err


def test_pool_not_a_multiple_of_16(cierzo):
    code, err = run_cli("render", scene_path("cornell"), "--pool", 20, "--spp", 1,
                        "--width", 16, "--height", 16, "--quiet", "--out", os.devnull + ".exr")
    with pytest.raises(cierzo.Error) as e:
        cierzo.render(scene_path("cornell"), pool=20, spp=1, width=16, height=16)
    assert code != 0 and str(e.value) in err


def test_bad_tonemap_value_has_the_programs_message(cierzo, tmp_path):
    exr = tmp_path / "a.exr"
    cierzo.write_exr(exr, np.ones((2, 3, 3), np.float32))
    code, err = run_cli(exr, tmp_path / "a.png", "--op", "gamma", "--gamma", "-1",
                        program=TONEMAP_BIN)
    assert code == 1
    with pytest.raises(cierzo.Error) as e:
        cierzo.tonemap(np.ones((2, 3, 3), np.float32), op="gamma", gamma=-1)
    assert "cierzo-tonemap: " + str(e.value) + "\n" == err


def copy_of_cornell(tmp_path):
    scene = tmp_path / "scene.json"
    with open(scene_path("cornell")) as f:
        scene.write_text(f.read())
    return scene


def test_an_output_over_an_input_has_the_programs_message(cierzo, tmp_path):
    scene = copy_of_cornell(tmp_path)
    before = scene.read_bytes()
    (tmp_path / "ck.exr").symlink_to("scene.json")
    code, err = run_cli("render", scene, "--quiet", "--spp", 1, "--out", tmp_path / "a.exr",
                        "--checkpoint", tmp_path / "ck.exr")
    assert code == 1 and "--checkpoint is the same file as the scene file" in err
    with pytest.raises(cierzo.Error) as e:
        cierzo.render(str(scene), spp=1, checkpoint=tmp_path / "ck.exr")
    assert "cierzo: " + str(e.value) + "\n" == err
    code, err = run_cli("converge", scene, "--spp", 1, "--reference-spp", 2, "--quiet",
                        "--out", scene)
    assert code == 1 and "--out is the same file as the scene file" in err
    with pytest.raises(cierzo.Error) as e:
        cierzo.converge(str(scene), spp=[1], reference_spp=2, out=scene)
    assert "cierzo: " + str(e.value) + "\n" == err
    assert scene.read_bytes() == before
    assert (tmp_path / "ck.exr").is_symlink()


def test_writers_write_through_links(cierzo, tmp_path):
    image = np.full((2, 3, 3), 0.5, np.float32)
    (tmp_path / "renders").mkdir()
    (tmp_path / "renders" / "r1.exr").write_bytes(b"old")
    (tmp_path / "latest.exr").symlink_to("renders/r1.exr")
    (tmp_path / "latest.png").symlink_to("renders/r1.png")  # dangling: created there
    cierzo.write_exr(tmp_path / "latest.exr", image)
    cierzo.write_ldr(tmp_path / "latest.png", image)
    assert (tmp_path / "latest.exr").is_symlink() and (tmp_path / "latest.png").is_symlink()
    assert np.array_equal(cierzo.read_exr(tmp_path / "renders" / "r1.exr"), image)
    assert (tmp_path / "renders" / "r1.png").read_bytes()[:4] == b"\x89PNG"
    assert sorted(p.name for p in (tmp_path / "renders").iterdir()) == ["r1.exr", "r1.png"]


def test_writers_fail_on_a_full_device_naming_it(cierzo, tmp_path):
    full = tmp_path / "full"
    try:
        os.mknod(full, 0o666 | 0o020000, os.makedev(1, 7))  # a character device, as /dev/full
    except PermissionError:
        pytest.skip("mknod needs root")
    (tmp_path / "full.exr").symlink_to("full")
    (tmp_path / "full.png").symlink_to("full")
    image = np.zeros((2, 2, 3), np.float32)
    for write, name in ((cierzo.write_exr, "full.exr"), (cierzo.write_ldr, "full.png")):
        with pytest.raises(cierzo.Error, match=name + ": cannot write: No space left on device"):
            write(tmp_path / name, image)
    assert (tmp_path / "full").is_char_device()
