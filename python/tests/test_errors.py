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
                                dict(estimator="bdpt"), dict(survival_cap=1.5), dict(width=0),
                                dict(pool=-16), dict(diffuse_sampling="gaussian")])
def test_bad_keywords(cierzo, kw):
    with pytest.raises(ValueError, match=next(iter(kw))):
        cierzo.render(scene_path("cornell"), **kw)


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
