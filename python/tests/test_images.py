# Images: EXR round trips, tone mapping as cierzo-tonemap does it, and the sweep of
# `cierzo converge`.
import csv

import numpy as np
import pytest

from conftest import TONEMAP_BIN, run_cli, scene_path


def test_exr_round_trip_is_exact(cierzo, tmp_path):
    rng = np.random.default_rng(1)
    image = rng.standard_normal((5, 7, 3)).astype(np.float32) * 1e3
    image[0, 0] = [np.inf, -np.inf, 0.0]
    cierzo.write_exr(tmp_path / "a.exr", image, {"note": "round trip"})
    back, meta = cierzo.read_exr(tmp_path / "a.exr", metadata=True)
    assert back.dtype == np.float32 and back.shape == (5, 7, 3)
    assert np.array_equal(back.view(np.uint32), image.view(np.uint32))
    assert meta["note"] == "round trip"
    # Any array that converts to float32 (height, width, 3) is accepted
    cierzo.write_exr(tmp_path / "b.exr", image.astype(np.float64))
    assert np.array_equal(cierzo.read_exr(tmp_path / "b.exr"), image)
    variance = np.abs(image) + 1
    cierzo.write_exr(tmp_path / "v.exr", image, variance=variance)
    back, back_variance, meta = cierzo.read_exr(tmp_path / "v.exr", variance=True, metadata=True)
    assert np.array_equal(back, image) and np.array_equal(back_variance, variance)
    with pytest.raises(cierzo.Error, match="variance.R"):
        cierzo.read_exr(tmp_path / "a.exr", variance=True)
    with pytest.raises(ValueError, match="shape"):
        cierzo.write_exr(tmp_path / "c.exr", np.zeros((4, 4), np.float32))
    with pytest.raises(cierzo.Error, match="cannot read"):
        cierzo.read_exr(tmp_path / "missing.exr")


@pytest.mark.parametrize("op,extra", [("clamp-gamma", ["--exposure", "1"]),
                                      ("reinhard", []), ("equalize-clamp", ["--clamp", "0.5"]),
                                      ("gamma", ["--gamma", "1.8"])])
def test_tonemap_equals_the_program(cierzo, tmp_path, op, extra):
    image, _ = cierzo.render(scene_path("cornell"), width=20, height=12, spp=2, threads=2)
    cierzo.write_exr(tmp_path / "in.exr", image)
    code, err = run_cli(tmp_path / "in.exr", tmp_path / "cli.png", "--op", op, *extra,
                        program=TONEMAP_BIN)
    assert code == 0, err
    kw = {extra[i].lstrip("-"): float(extra[i + 1]) for i in range(0, len(extra), 2)}
    mapped = cierzo.tonemap(image, op=op, **kw)
    assert mapped.shape == image.shape and 0 <= mapped.min() and mapped.max() <= 1
    cierzo.write_ldr(tmp_path / "py.png", mapped)
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    assert op in cierzo.tonemap_operators()


def test_converge_rows_equal_the_programs_csv(cierzo, tmp_path):
    args = dict(width=16, height=16, reference_spp=16, spp=[1, 4], integrator=["wavefront"],
                estimator=["report", "mis"], threads=2)
    code, err = run_cli("converge", scene_path("cornell"), "--width", 16, "--height", 16,
                        "--reference-spp", 16, "--spp", "1,4", "--integrator", "wavefront",
                        "--estimator", "report,mis", "--threads", 2, "--quiet", "--out",
                        tmp_path / "c.csv")
    assert code == 0, err
    with open(tmp_path / "c.csv") as f:
        expected = list(csv.DictReader(f))
    rows = cierzo.converge(scene_path("cornell"), out=tmp_path / "py.csv", **args)
    assert len(rows) == len(expected) == 4
    timing = {"seconds", "rays_per_second", "efficiency"}
    for row, cli in zip(rows, expected):
        assert list(row) == list(cli)
        for k, v in cli.items():
            if k not in timing:
                assert str(row[k]) == v or row[k] == float(v), k
    assert (tmp_path / "py.csv").read_text().splitlines()[0] == ",".join(expected[0])


def test_help_documents_every_function(cierzo):
    for name in ("load_scene", "render", "converge", "read_exr", "write_exr", "write_ldr",
                 "tonemap", "tonemap_operators", "isas"):
        assert len(getattr(cierzo, name).__doc__) > 80, name
    assert "time_budget" in cierzo.render.__doc__ and "KeyboardInterrupt" in cierzo.render.__doc__
    assert any(i["auto"] for i in cierzo.isas())
