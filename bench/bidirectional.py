#!/usr/bin/python3
"""Equal-time efficiency of the estimators on caustic scenes, and bdpt's wavefront speed-up.

1. Efficiency. For each scene, a long reference (`cierzo render --estimator bdpt` at
   --reference-spp, wavefront, 2 threads; or --reference FILE); then, in --rounds rounds,
   each estimator renders with --time-budget SECONDS on one thread (whole passes: every
   pixel has the same paths). The error is the relative MSE (x-r)^2/(r^2+0.01) averaged over
   pixels and channels, against the reference, over the whole image and over the region
   --region x0,y0,x1,y1 (fractions of the image; default: the floor under caustic.json's
   glass ball); efficiency = 1 / (relMSE x seconds), seconds the render's own. Each round
   runs every estimator in turn; the table gives the medians, and each estimator's
   efficiency over --base's (default mis; the median of the rounds' ratios). An estimator
   written vcm@R renders with --merge-radius R (vcm alone: the scene's rule), one written
   bdpt@cN (or vcm@R@cN) with --light-connections N (draws from the light vertex cache), one
   ending in @other with the build --other-binary names (two commits side by side, in the
   same interleaved rounds).
2. Speed. The wavefront's rays/s per core over the scalar reference's for bdpt, on every ISA
   this CPU runs (one thread, interleaved rounds; the median of the rounds' ratios). In each
   round every configuration renders --speed-repeat times in a row and keeps its fastest:
   these renders take milliseconds, and a shared machine now and then stalls one of them
   several times over.

Usage: /usr/bin/python3 bench/bidirectional.py [--scenes caustic,PATH.json,...] [--size 160]
       [--seconds 4] [--rounds 3] [--estimators report,mis,lt,bdpt,vcm,vcm@0.05] [--base mis]
       [--reference-spp 4096]
       [--speed-scenes caustic,cornell,...] [--speed-spp 8] [--speed-repeat 3]
The CPU is named in the output; say which one a number came from.
"""
import argparse
import pathlib
import statistics
import sys
import tempfile

import benchlib

CIERZO = benchlib.CIERZO
# (the cierzo module, for reading EXR images: not a sibling script)
sys.path.insert(0, str(benchlib.BUILD / "python" / "module"))


def render(scene, out, args, stats=None, binary=CIERZO):
    """`cierzo render scene --out out --quiet args`; its --stats when stats is given."""
    cmd = [binary, "render", scene, "--out", out, "--quiet"] + args
    if stats:
        cmd += ["--stats", stats]
    benchlib.run(cmd)
    return benchlib.read_stats(stats) if stats else None


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="caustic")
    ap.add_argument("--size", type=int, default=160)
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--estimators", default="report,mis,lt,bdpt,vcm")
    ap.add_argument("--base", default="mis", help="the estimator the ratios are against")
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--reference", default=None, help="reference EXR (one scene only)")
    ap.add_argument("--region", default="0.35,0.85,0.65,0.98")
    ap.add_argument("--other-binary", default=None,
                    help="another cierzo build: an estimator written NAME@...@other renders with it")
    ap.add_argument("--speed-scenes", default="")
    ap.add_argument("--speed-spp", type=int, default=8)
    ap.add_argument("--speed-repeat", type=int, default=3,
                    help="renders per configuration and round, the fastest kept")
    a = ap.parse_args()
    if a.speed_repeat < 1:
        ap.error("--speed-repeat: expected at least 1")
    import numpy  # noqa: F401  (benchlib.read_exr's: missing, fail now rather than after a render)
    import cierzo  # noqa: F401
    print(f"CPU: {benchlib.cpu_name()}")
    region = tuple(float(v) for v in a.region.split(","))
    estimators = a.estimators.split(",")
    size = ["--width", str(a.size), "--height", str(a.size)]
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        for name in [s for s in a.scenes.split(",") if s]:
            scene = benchlib.scene_path(name)
            ref_path = pathlib.Path(a.reference) if a.reference else tmp / "ref.exr"
            if not a.reference:
                render(scene, ref_path, size + ["--estimator", "bdpt", "--spp", str(a.reference_spp),
                                                "--threads", "2"])
            ref = benchlib.read_exr(ref_path)
            rows = {e: [] for e in estimators}
            for rnd in range(a.rounds):
                for e in estimators:
                    out, st = tmp / f"{e}.exr", tmp / f"{e}.json"
                    name_e, *knobs = e.split("@")
                    extra, binary = [], CIERZO
                    for k in knobs:
                        if k == "other":
                            if not a.other_binary:
                                ap.error(f"{e}: @other needs --other-binary")
                            binary = a.other_binary
                        else:
                            extra += (["--light-connections", k[1:]] if k.startswith("c")
                                      else ["--merge-radius", k])
                    s = render(scene, out, size + extra + ["--estimator", name_e, "--threads", "1", "--spp", "1000000",
                                                   "--time-budget", str(a.seconds),
                                                   "--seed", str(1000 + rnd)], st, binary)
                    img = benchlib.read_exr(out)
                    secs = s["seconds"]
                    whole, part = benchlib.rel_mse(img, ref), benchlib.rel_mse(img, ref, region)
                    rows[e].append((secs, s["spp_reached"], whole, part, 1 / (whole * secs), 1 / (part * secs)))
            print(f"\n{name} ({a.size}x{a.size}, {a.seconds:g} s per render, 1 thread, {a.rounds} rounds; "
                  f"reference bdpt {a.reference_spp} spp; region {a.region})")
            vs = "vs " + a.base
            print(f"{'estimator':10s} {'spp':>6s} {'relMSE':>10s} {'eff':>9s} {vs:>9s} "
                  f"{'relMSE reg':>10s} {'eff reg':>9s} {vs:>9s}")
            for e in estimators:
                r = rows[e]
                med = lambda k: statistics.median(x[k] for x in r)
                ratio = lambda k: (benchlib.median_ratio([x[k] for x in r],
                                                         [m[k] for m in rows[a.base]])
                                   if a.base in rows else float("nan"))
                print(f"{e:10s} {med(1):6.0f} {med(2):10.5f} {med(4):9.1f} {ratio(4):9.2f} "
                      f"{med(3):10.5f} {med(5):9.1f} {ratio(5):9.2f}")
        speed = [s for s in a.speed_scenes.split(",") if s]
        if speed:
            isas = benchlib.runnable_isas(CIERZO)
            print(f"\nbdpt wavefront over scalar, rays/s per core, 1 thread, {a.rounds} rounds "
                  f"of the fastest of {a.speed_repeat} ({a.size}x{a.size}, {a.speed_spp} spp)")
            print(f"{'scene':22s} {'scalar Mrays/s':>14s} " + " ".join(f"{i:>8s}" for i in isas))
            for name in speed:
                scene = benchlib.scene_path(name)
                per = {"scalar": []} | {i: [] for i in isas}
                for rnd in range(a.rounds):
                    for key in per:
                        args = size + ["--estimator", "bdpt", "--threads", "1", "--spp", str(a.speed_spp)]
                        args += ["--integrator", "scalar"] if key == "scalar" else ["--isa", key]
                        per[key].append(max(render(scene, tmp / "s.exr", args, tmp / "s.json")
                                            ["rays_per_second"] for _ in range(a.speed_repeat)))
                ratios = [benchlib.median_ratio(per[i], per["scalar"]) for i in isas]
                print(f"{name:22s} {statistics.median(per['scalar']) / 1e6:14.2f} " +
                      " ".join(f"{r:8.2f}" for r in ratios))


if __name__ == "__main__":
    main()
