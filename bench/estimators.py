#!/usr/bin/python3
"""Rays per second of each estimator on every scene of scenes/, one thread, interleaved.

Two measurements, each a ratio taken within one run (the machine's speed drifts by a third
from minute to minute, so only ratios of runs interleaved round by round are compared):

  --baseline OLD_CIERZO   this build's `cierzo` against another build's (e.g. the commit
                          before a change), for the estimators given (default report, nee,
                          mis) on both integrators: the median over rounds of new/old rays/s.
  (always)                the wavefront's rays/s per core against the scalar reference's for
                          the estimators given (default: lt), and both medians.

Each render is `cierzo render SCENE --width W --height H --spp S --threads 1 --quiet` with
--stats; rays/s is the render's own (scene loading excluded). Prints Markdown tables and
writes JSON to --out.
Usage: /usr/bin/python3 bench/estimators.py [--baseline OLD] [--estimators lt]
       [--rounds 5] [--size 64] [--spp 16] [--scene-filter REGEX] [--out FILE.json]
"""
import argparse
import json
import pathlib
import re
import statistics
import tempfile

import benchlib

CIERZO = benchlib.CIERZO


def rays_per_second(program, scene, estimator, integrator, size, spp):
    """One render's rays/s (its --stats), one thread."""
    with tempfile.TemporaryDirectory() as tmp:
        stats = pathlib.Path(tmp) / "stats.json"
        return benchlib.render_stats(
            [program, "render", scene, "--width", size, "--height", size, "--spp", spp,
             "--threads", "1", "--quiet", "--estimator", estimator, "--integrator", integrator,
             "--out", pathlib.Path(tmp) / "image.exr", "--stats", stats],
            stats)["rays_per_second"]


def scenes(pattern):
    """The scenes of scenes/ whose names match pattern, bunny's left out."""
    out = []
    for p in sorted(benchlib.SCENES.glob("*.json")):
        if re.search(pattern, p.stem) and "bunny" not in p.stem:
            out.append(p)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--baseline", help="another build's cierzo to compare this one against")
    ap.add_argument("--estimators", default=None,
                    help="comma-separated (default: report,nee,mis with --baseline, else lt)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--scene-filter", default=".")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    estimators = (a.estimators or ("report,nee,mis" if a.baseline else "lt")).split(",")
    rows = []
    for scene in scenes(a.scene_filter):
        for est in estimators:
            runs = {}
            for _ in range(a.rounds):
                for integrator in ("scalar", "wavefront"):
                    for name, program in [("new", CIERZO)] + ([("old", a.baseline)] if a.baseline else []):
                        runs.setdefault((integrator, name), []).append(
                            rays_per_second(program, scene, est, integrator, a.size, a.spp))
            row = {"scene": scene.stem, "estimator": est}
            for integrator in ("scalar", "wavefront"):
                row[integrator] = statistics.median(runs[(integrator, "new")])
                if a.baseline:
                    row[integrator + "_vs_old"] = benchlib.median_ratio(
                        runs[(integrator, "new")], runs[(integrator, "old")])
            row["wavefront_vs_scalar"] = benchlib.median_ratio(
                runs[("wavefront", "new")], runs[("scalar", "new")])
            rows.append(row)
            print(json.dumps(row), flush=True)
    head = "| scene | estimator | scalar Mrays/s | wavefront Mrays/s | wavefront/scalar |"
    if a.baseline:
        head += " scalar new/old | wavefront new/old |"
    print("\n" + head)
    print("|" + "---|" * (head.count("|") - 1))
    for r in rows:
        line = (f"| {r['scene']} | {r['estimator']} | {r['scalar'] / 1e6:.2f} | "
                f"{r['wavefront'] / 1e6:.2f} | {r['wavefront_vs_scalar']:.2f} |")
        if a.baseline:
            line += f" {r['scalar_vs_old']:.3f} | {r['wavefront_vs_old']:.3f} |"
        print(line)
    if a.out:
        benchlib.write_json(a.out, rows, indent=1)


if __name__ == "__main__":
    main()
