#!/usr/bin/python3
"""Traversal alone, interleaved: `cierzo trace` builds (this one, and optionally an older
one) against Embree's rtcIntersect1 (`embree_pt --trace-rays --api 1`, build quality high)
on the same ray file, one thread each, every round running all in turn; ratios are the
medians of each round's own ratios (a shared machine's slow spells fall on all alike).
With --render SPP, whole renders instead: `cierzo render` (wavefront, the scene's
estimator) against the Embree path tracer (`embree_pt --spp`), 300 x 300, one thread, rays/s
and image means (equal means: equal work).

Usage: /usr/bin/python3 bench/traversal_ratio.py SCENE.json RAYS [--rounds 7] [--repeat 3]
    [--cierzo build/cierzo] [--baseline OLD/cierzo] [--embree build/.../embree_pt]
    [--isa auto avx2 ...] [--render SPP] [--json OUT]
RAYS: a ray file (embree_pt --dump-rays; ignored with --render). Prints M rays/s (median)
and the ratios; names the CPU, which every number depends on.
"""
import argparse
import pathlib
import statistics
import tempfile

import benchlib


def rays_per_second(cmd):
    """Runs cmd (a trace, or a render of cierzo's or Embree's): its rays/s, and its hits
    (trace) or image mean as text (render)."""
    keys = benchlib.keys(benchlib.run(cmd))
    if "hits" in keys:
        return float(keys["rays_per_second"]), int(keys["hits"])
    if "mean_rgb" in keys:  # embree_pt rendering
        return float(keys["rays_per_second"]), keys["mean_rgb"]
    stats = benchlib.read_stats(cmd[cmd.index("--stats") + 1])
    mean = benchlib.pfm_mean(cmd[cmd.index("--out") + 1])
    return stats["rays_per_second_per_thread"], " ".join(f"{m:.5f}" for m in mean)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene")
    p.add_argument("rays")
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--cierzo", default=str(benchlib.CIERZO))
    p.add_argument("--baseline")
    p.add_argument("--embree", default=str(benchlib.EMBREE))
    p.add_argument("--isa", nargs="+", default=["auto"])
    p.add_argument("--render", type=int, metavar="SPP",
                   help="whole renders of SPP samples a pixel instead of the traversal alone")
    p.add_argument("--json")
    a = p.parse_args()
    tmp = pathlib.Path(tempfile.mkdtemp())
    runs = {}
    for isa in a.isa:
        for who, binary in (("cierzo", a.cierzo), ("baseline", a.baseline)):
            if not binary:
                continue
            if a.render:
                out, stats = tmp / f"{who}_{isa}.pfm", tmp / f"{who}_{isa}.json"
                runs[f"{who} {isa}"] = [binary, "render", a.scene, "--width", 300, "--height",
                                        300, "--spp", a.render, "--threads", 1, "--isa", isa,
                                        "--quiet", "--out", out, "--stats", stats]
            else:
                runs[f"{who} {isa}"] = [binary, "trace", a.scene, "--rays", a.rays, "--isa", isa,
                                        "--repeat", a.repeat]
    if a.render:
        runs["embree rtcIntersect1"] = [a.embree, a.scene, "--width", 300, "--height", 300,
                                        "--spp", a.render, "--out", tmp / "embree.pfm"]
    else:
        runs["embree rtcIntersect1"] = [a.embree, a.scene, "--trace-rays", a.rays, "--api", "1",
                                        "--repeat", a.repeat]
    samples = {k: [] for k in runs}
    hits = {}
    for _ in range(a.rounds):
        for name, cmd in runs.items():
            r, h = rays_per_second(cmd)
            samples[name].append(r)
            hits[name] = h
    cpu = benchlib.cpu_name("unknown")
    print(f"{a.scene}, {a.rays}: {a.rounds} interleaved rounds, --repeat {a.repeat}; CPU: {cpu}")
    print("| program | M rays/s (median) | hits (trace) or image mean (render) | / Embree (median of rounds) |")
    print("|---|---|---|---|")
    e = samples["embree rtcIntersect1"]
    result = {"cpu": cpu, "scene": a.scene, "rays": a.rays, "rounds": a.rounds, "runs": {}}
    for name, s in samples.items():
        ratio = benchlib.median_ratio(s, e)
        print(f"| {name} | {statistics.median(s) / 1e6:.2f} | {hits[name]} | {ratio:.3f} |")
        result["runs"][name] = {"rays_per_s": s, "hits": hits[name], "vs_embree": ratio}
    if a.baseline:
        for isa in a.isa:
            ratio = benchlib.median_ratio(samples[f"cierzo {isa}"], samples[f"baseline {isa}"])
            print(f"cierzo / baseline, {isa}: {ratio:.3f}")
            result[f"vs_baseline_{isa}"] = ratio
    if a.json:
        benchlib.write_json(a.json, result)


if __name__ == "__main__":
    main()
