#!/usr/bin/python3
"""Measures the scene-scale acceleration targets side by side, in one interleaved run.

Every measurement is a separate process, one thread, and every round runs all of them in
turn, so a slow spell of a shared machine falls on all alike; ratios are the median of each
round's own ratio. Parts:

1. Log N: the sphere field with 10 and with 10,000 spheres (scripts/make_scenes.py), the
   wavefront and the scalar reference: rays/s per core and the 10,000/10 ratio.
2. Against Embree (bench/peers/embree/embree_pt, when built): the triangle-only open box
   (scenes/box.json) and the box with a 200k-triangle mesh: whole renders of the same
   scene and estimator, their rays/s and image means (equal means prove equal work).
3. The traversal alone: `cierzo trace` against `embree_pt --trace-rays` on the same file of
   incoherent rays (embree_pt --dump-rays: every ray after the camera's), through each of
   Embree's APIs (rtcIntersect1, rtcIntersect16, the stream API rtcIntersect1M) on trees of
   both of its better build qualities (high: spatial splits, medium: binned SAH); the
   ratios against rtcIntersect1 on the high-quality tree and against Embree's fastest
   combination, per round; and cierzo's ray streams (`cierzo trace --stream 1024
   --single-below 16`) against its single rays.
4. Build: a 1M-triangle mesh loaded and built on 2 threads (`--stats` bvh.build_seconds),
   bytes per triangle, and Embree's build of the same mesh on 2 threads.
5. With --baseline BIN (a cierzo built from an earlier commit): scenes/cornell.json's
   wavefront rays/s now and then, which has no bounded primitive and must not slow down.

Prints Markdown tables and writes them as JSON to OUT_DIR/accel.json.
Usage: /usr/bin/python3 bench/accel.py [--rounds N] [--out OUT_DIR] [--baseline BIN]
The CPU is named in the output; say which one a number came from.
"""
import argparse
import pathlib
import statistics
import sys
import tempfile

import benchlib

EMBREE, EMBREE_TRACES = benchlib.EMBREE, benchlib.EMBREE_TRACES
GENERATED, ROOT = benchlib.GENERATED, benchlib.ROOT
cierzo_render, median_ratio = benchlib.cierzo_render, benchlib.median_ratio


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", type=pathlib.Path, default=benchlib.BUILD / "bench-results")
    ap.add_argument("--baseline", type=pathlib.Path, help="an earlier cierzo, for part 5")
    a = ap.parse_args()
    if not (GENERATED / "spheres_10000.json").exists() or not (GENERATED / "mesh_1m.json").exists():
        benchlib.run([sys.executable, ROOT / "scripts" / "make_scenes.py"])
    cpu, isa = benchlib.cpu_name("?"), benchlib.cpu_isa()
    print(f"CPU: {cpu} ({isa}); best ISA as `cierzo isas` says; {a.rounds} interleaved rounds\n")
    have_embree = EMBREE.exists()
    spheres = {n: GENERATED / f"spheres_{n}.json" for n in (10, 10000)}
    triangles = {"box": ROOT / "scenes" / "box.json", "mesh_200k": GENERATED / "mesh_200k.json"}
    samples = benchlib.Samples()
    add = samples.add

    with tempfile.TemporaryDirectory() as tmp:
        rays = {}
        if have_embree:
            for name, scene in triangles.items():
                rays[name] = pathlib.Path(tmp) / f"{name}.rays"
                benchlib.dump_rays(scene, rays[name], 1000000)
        for r in benchlib.rounds(a.rounds):
            for n, scene in spheres.items():
                add(("spheres", n, "wavefront"), cierzo_render(tmp, scene, "wavefront", 200, 8))
                add(("spheres", n, "scalar"), cierzo_render(tmp, scene, "scalar", 200, 2))
            for name, scene in triangles.items():
                spp = 16 if name == "box" else 8
                add(("render", name, "cierzo"), cierzo_render(tmp, scene, "wavefront", 300, spp))
                if have_embree:
                    add(("render", name, "embree"), benchlib.embree_render(tmp, scene, 300, spp))
                    add(("trace", name, "cierzo"), benchlib.cierzo_trace(scene, rays[name]))
                    add(("trace", name, "stream"), benchlib.cierzo_trace(
                        scene, rays[name], ["--stream", 1024, "--single-below", 16]))
                    for api, quality in EMBREE_TRACES:
                        add(("trace", name, "embree", api, quality),
                            benchlib.embree_trace(scene, rays[name], api, quality))
            if a.baseline:
                cornell = ROOT / "scenes" / "cornell.json"
                add(("cornell", "now"), cierzo_render(tmp, cornell, "wavefront", 250, 16))
                add(("cornell", "baseline"), cierzo_render(tmp, cornell, "wavefront", 250, 16, a.baseline))
        # Build: one 1M-triangle mesh, 2 threads
        mesh_1m = GENERATED / "mesh_1m.json"
        builds = [benchlib.cierzo_build(tmp, mesh_1m) for _ in range(3)]
        embree_builds = []
        if have_embree:
            for _ in range(3):
                k = benchlib.keys(benchlib.run([EMBREE, mesh_1m, "--width", 1, "--height", 1,
                                                "--spp", 1, "--embree-config", "threads=2"]))
                embree_builds.append(float(k["build_seconds"]))

    rays, med = samples.rates, samples.mrays
    result = {"cpu": cpu, "isa": isa, "rounds": a.rounds}
    print("| sphere field | 10 spheres, M rays/s | 10,000 spheres | 10,000 / 10 (median of rounds) |")
    print("|---|---|---|---|")
    for integ in ("wavefront", "scalar"):
        ratio = median_ratio(rays(("spheres", 10000, integ)), rays(("spheres", 10, integ)))
        result[f"spheres_{integ}"] = {"10": med(("spheres", 10, integ)), "10000": med(("spheres", 10000, integ)), "ratio": ratio}
        print(f"| {integ} | {med(('spheres', 10, integ)):.2f} | {med(('spheres', 10000, integ)):.2f} | {ratio:.2f} |")
    if have_embree:
        print("\n| scene | cierzo wavefront, M rays/s | Embree path tracer | cierzo / Embree | image means (R) cierzo, Embree |")
        print("|---|---|---|---|---|")
        for name in triangles:
            c, e = ("render", name, "cierzo"), ("render", name, "embree")
            ratio = median_ratio(rays(c), rays(e))
            mc, me = samples[c][-1]["mean"][0], samples[e][-1]["mean"][0]
            result[f"render_{name}"] = {"cierzo": med(c), "embree": med(e), "ratio": ratio, "mean_cierzo": mc, "mean_embree": me}
            print(f"| {name} | {med(c):.2f} | {med(e):.2f} | {ratio:.2f} | {mc:.4f}, {me:.4f} ({100 * (mc / me - 1):+.2f}%) |")
        print("\n| traversal alone, 1M incoherent rays | cierzo trace, M rays/s | rtcIntersect1 (high) | cierzo / rtcIntersect1 | Embree's fastest | cierzo / fastest | hits cierzo, Embree |")
        print("|---|---|---|---|---|---|---|")
        for name in triangles:
            c, e = ("trace", name, "cierzo"), ("trace", name, "embree", "1", "high")
            ratio = median_ratio(rays(c), rays(e))
            # Embree's fastest: the best of its combinations in each round
            fastest = [max(samples[("trace", name, "embree") + t][r]["rays_per_s"] for t in EMBREE_TRACES)
                       for r in range(a.rounds)]
            best = max(EMBREE_TRACES, key=lambda t: statistics.median(rays(("trace", name, "embree") + t)))
            ratio_fastest = median_ratio(rays(c), fastest)
            result[f"trace_{name}"] = {"cierzo": med(c), "embree": med(e), "ratio": ratio,
                                       "embree_fastest": statistics.median(fastest) / 1e6,
                                       "embree_best_median": "rtcIntersect%s, %s" % best,
                                       "ratio_fastest": ratio_fastest,
                                       "embree_all": {"rtcIntersect%s, %s" % t: med(("trace", name, "embree") + t)
                                                      for t in EMBREE_TRACES}}
            print(f"| {name} | {med(c):.2f} | {med(e):.2f} | {ratio:.2f} | {statistics.median(fastest) / 1e6:.2f} "
                  f"(best median: rtcIntersect{best[0]}, {best[1]}) | {ratio_fastest:.2f} | {samples[c][0]['hits']}, {samples[e][0]['hits']} |")
        for name in triangles:  # every API finds the same hits, or the comparison is void
            found = {t: samples[("trace", name, "embree") + t][0]["hits"] for t in EMBREE_TRACES}
            if len(set(found.values())) != 1:
                print(f"\nwarning: Embree's APIs disagree on {name}'s hits: {found}")
        print("\n| Embree on the same rays, M rays/s | " + " | ".join(f"rtcIntersect{t[0]}, {t[1]}" for t in EMBREE_TRACES) + " |")
        print("|---|" + "---|" * len(EMBREE_TRACES))
        for name in triangles:
            print(f"| {name} | " + " | ".join(f"{med(('trace', name, 'embree') + t):.2f}" for t in EMBREE_TRACES) + " |")
        print("\n| ray streams (cierzo trace --stream 1024 --single-below 16) | M rays/s | streams / single rays | hits |")
        print("|---|---|---|---|")
        for name in triangles:
            c, s = ("trace", name, "cierzo"), ("trace", name, "stream")
            ratio = median_ratio(rays(s), rays(c))
            result[f"stream_{name}"] = {"stream": med(s), "single": med(c), "ratio": ratio}
            print(f"| {name} | {med(s):.2f} | {ratio:.2f} | {samples[s][0]['hits']} |")
    b = min(builds, key=lambda x: x["build_seconds"])
    result["build_1m"] = {"seconds": b["build_seconds"], "bytes_per_triangle": b["bytes"] / b["primitives"],
                          "embree_seconds": min(embree_builds) if embree_builds else None}
    print(f"\nBuild of 1,000,010 triangles on 2 threads (best of 3): cierzo {b['build_seconds']:.3f} s, "
          f"{b['bytes'] / b['primitives']:.1f} bytes per triangle in the tree"
          + (f"; Embree {min(embree_builds):.3f} s" if embree_builds else ""))
    if a.baseline:
        ratio = median_ratio(rays(("cornell", "now")), rays(("cornell", "baseline")))
        result["cornell"] = {"now": med(("cornell", "now")), "baseline": med(("cornell", "baseline")), "ratio": ratio}
        print(f"\ncornell.json wavefront: now {med(('cornell', 'now')):.2f} M rays/s, baseline "
              f"{med(('cornell', 'baseline')):.2f}, now / baseline {ratio:.2f}")
    benchlib.write_json(a.out / "accel.json", result)


if __name__ == "__main__":
    main()
