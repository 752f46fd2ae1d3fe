#!/usr/bin/python3
"""Many rays in flight per thread: the interleaved traversal's targets, in one interleaved run.

Every measurement is a separate process on one thread, and every round runs all of them in
turn, so a slow spell of the shared machine falls on all alike; ratios are the median of
each round's own ratio. Parts (each can be left out with --skip):

  groups   `cierzo trace` of mesh_200k's incoherent rays with 1, 2, 4, ..., 64 rays in
           flight (--ray-group): rays/s, and the ratio to one ray at a time.
  trace    the traversal alone, 1M incoherent rays (embree_pt --dump-rays: every ray after
           the camera's) of each big scene: cierzo one ray at a time (the default) and with
           --group rays in flight, against Embree's APIs (rtcIntersect1, rtcIntersect16, the stream API
           rtcIntersect1M) on its trees of build quality high and medium.
  render   whole path-traced renders of each big scene, the same estimator: cierzo's
           wavefront (the default, and --ray-group of --group) against the minimal Embree path tracer
           (bench/peers/embree), with the image means that show equal work; and the cost per
           ray from 10k to 10M triangles (the knot scenes mesh_N) for both.
  spheres  the sphere field with 10 and with 10,000 spheres: wavefront and scalar rays/s.
  atrium   the Sponza-like atrium (scripts/make_atrium.py): wavefront on every ISA against
           the scalar reference.

Scenes come from scripts/make_scenes.py (mesh_10k, mesh_200k, sticks_100k, mesh_1m,
mesh_10m, spheres_10, spheres_10000: written if missing) and scripts/make_atrium.py.
Prints Markdown tables and writes them as JSON to OUT_DIR/in_flight.json.

Usage: /usr/bin/python3 bench/in_flight.py [--rounds N] [--skip PART,...] [--out OUT_DIR]
         [--scenes NAME,...] [--group G] [--size S] [--spp N] [--baseline BIN]
The CPU is named in the output; say which one a number came from.
"""
import argparse
import pathlib
import statistics
import sys
import tempfile

import benchlib

CIERZO, EMBREE, EMBREE_TRACES = benchlib.CIERZO, benchlib.EMBREE, benchlib.EMBREE_TRACES
ROOT = benchlib.ROOT
scene_path = benchlib.generated_scene
BIG = ["mesh_200k", "sticks_100k", "mesh_1m", "mesh_10m"]
LADDER = ["mesh_10k", "mesh_200k", "mesh_1m", "mesh_10m"]
GROUPS = [1, 2, 4, 8, 16, 32, 64]


def render(tmp, scene, size, spp, integrator="wavefront", isa="auto", extra=(), binary=CIERZO):
    """benchlib.cierzo_render, always naming the ISA."""
    return benchlib.cierzo_render(tmp, scene, integrator, size, spp, binary, isa, extra)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--skip", default="", help="parts to leave out: groups,trace,render,spheres,atrium")
    ap.add_argument("--scenes", default=",".join(BIG), help="the big scenes of trace and render")
    ap.add_argument("--size", type=int, default=200, help="render width and height")
    ap.add_argument("--spp", type=int, default=4)
    ap.add_argument("--group", type=int, default=16, help="the rays in flight set beside one at a time")
    ap.add_argument("--baseline", type=pathlib.Path,
                    help="an earlier cierzo: its wavefront renders of the big scenes beside today's")
    ap.add_argument("--out", type=pathlib.Path, default=benchlib.BUILD / "bench-results")
    a = ap.parse_args()
    skip = set(filter(None, a.skip.split(",")))
    big = [s for s in a.scenes.split(",") if s]
    have_embree = EMBREE.exists()
    if not have_embree:
        # (the incoherent rays are Embree's path tracer's: embree_pt --dump-rays)
        print(f"(no {EMBREE}: the Embree columns and the parts that trace its rays, groups and "
              "trace, are left out; bench/peers/README.md builds it)")
        skip |= {"groups", "trace"}
    benchlib.ensure_scenes(sorted(set(big + (LADDER if "render" not in skip else [])
                                      + ["mesh_200k", "spheres_10", "spheres_10000"])))
    name, isa = benchlib.cpu_name("?"), benchlib.cpu_isa()
    print(f"CPU: {name} ({isa}); {a.rounds} interleaved rounds, 1 thread\n")
    samples = benchlib.Samples()
    add = samples.add
    trace, embree_trace = benchlib.cierzo_trace, benchlib.embree_trace

    with tempfile.TemporaryDirectory() as tmp:
        rays = {}
        trace_scenes = ["mesh_200k"] if "groups" not in skip else []
        trace_scenes += big if "trace" not in skip else []
        for s in dict.fromkeys(trace_scenes):
            rays[s] = pathlib.Path(tmp) / f"{s}.rays"
            benchlib.dump_rays(scene_path(s), rays[s], 1000000)
        atrium = benchlib.ATRIUM / "atrium.json"
        if "atrium" not in skip and not atrium.exists():
            benchlib.run([sys.executable, ROOT / "scripts" / "make_atrium.py"])
        widths = benchlib.runnable_isas(CIERZO)
        for r in benchlib.rounds(a.rounds):
            if "groups" not in skip:
                for g in GROUPS:
                    add(("groups", g), trace(scene_path("mesh_200k"), rays["mesh_200k"],
                                             ["--ray-group", g]))
            if "trace" not in skip:
                for s in big:
                    add(("trace", s, "cierzo"), trace(scene_path(s), rays[s]))
                    add(("trace", s, "group"), trace(scene_path(s), rays[s], ["--ray-group", a.group]))
                    if have_embree:
                        for api, quality in EMBREE_TRACES:
                            add(("trace", s, "embree", api, quality),
                                embree_trace(scene_path(s), rays[s], api, quality))
            if "render" not in skip:
                for s in dict.fromkeys(big + LADDER):
                    p = scene_path(s)
                    add(("render", s, "cierzo"), render(tmp, p, a.size, a.spp))
                    add(("render", s, "group"), render(tmp, p, a.size, a.spp, extra=["--ray-group", a.group]))
                    if a.baseline:
                        add(("render", s, "baseline"), render(tmp, p, a.size, a.spp, binary=a.baseline))
                    if have_embree:
                        add(("render", s, "embree"), benchlib.embree_render(tmp, p, a.size, a.spp))
            if "spheres" not in skip:
                for n in (10, 10000):
                    p = scene_path(f"spheres_{n}")
                    add(("spheres", n, "wavefront"), render(tmp, p, 200, 8))
                    add(("spheres", n, "scalar"), render(tmp, p, 200, 2, "scalar"))
            if "atrium" not in skip:
                add(("atrium", "scalar"), render(tmp, atrium, 160, 2, "scalar", extra=["--estimator", "mis"]))
                for w in widths:
                    add(("atrium", w), render(tmp, atrium, 160, 8, "wavefront", w,
                                              extra=["--estimator", "mis"]))

    rate, med, ratio = samples.rates, samples.mrays, samples.ratio
    result = {"cpu": name, "isa": isa, "rounds": a.rounds}
    if "groups" not in skip:
        print("| rays in flight (mesh_200k, cierzo trace) | M rays/s | / one at a time |")
        print("|---|---|---|")
        result["groups"] = {}
        for g in GROUPS:
            k = ("groups", g)
            result["groups"][g] = {"mrays": med(k), "ratio": ratio(k, ("groups", 1))}
            print(f"| {g} | {med(k):.2f} | {ratio(k, ('groups', 1)):.2f} |")
        sums = {samples[("groups", g)][0]["sum_t"] for g in GROUPS}
        print(f"\n(the same hits and sum of distances for every group: {len(sums) == 1})\n")
    if "trace" not in skip:
        print(f"| traversal alone, 1M incoherent rays | cierzo, M rays/s | {a.group} in flight | "
              "group / one | rtcIntersect1 (high) | cierzo / rtcIntersect1 | Embree's fastest | "
              "cierzo / fastest |")
        print("|---|---|---|---|---|---|---|---|")
        for s in big:
            c, grp = ("trace", s, "cierzo"), ("trace", s, "group")
            row = {"cierzo": med(c), "group": med(grp), "group_ratio": ratio(grp, c)}
            line = f"| {s} | {med(c):.2f} | {med(grp):.2f} | {ratio(grp, c):.2f} |"
            if have_embree:
                e1 = ("trace", s, "embree", "1", "high")
                fastest = [max(samples[("trace", s, "embree") + t][r]["rays_per_s"]
                               for t in EMBREE_TRACES) for r in range(a.rounds)]
                vs_fastest = benchlib.median_ratio(rate(c), fastest)
                row.update({"rtcIntersect1": med(e1), "ratio_1": ratio(c, e1),
                            "fastest": statistics.median(fastest) / 1e6, "ratio_fastest": vs_fastest,
                            "embree_all": {"rtcIntersect%s, %s" % t: med(("trace", s, "embree") + t)
                                           for t in EMBREE_TRACES}})
                line += (f" {med(e1):.2f} | {ratio(c, e1):.2f} | {statistics.median(fastest) / 1e6:.2f} |"
                         f" {vs_fastest:.2f} |")
                hits = {samples[c][0]["hits"], samples[grp][0]["hits"]}
                hits |= {samples[("trace", s, "embree") + t][0]["hits"] for t in EMBREE_TRACES}
                row["hits"] = sorted(hits)
            print(line)
            result[f"trace_{s}"] = row
    if "render" not in skip:
        print(f"\n| whole render, 1 thread | cierzo, M rays/s | {a.group} in flight | group / one |"
              + (" baseline | / baseline |" if a.baseline else "")
              + (" Embree path tracer | cierzo / Embree | image means (R) cierzo, Embree |" if have_embree else ""))
        print("|---|---|---|---|" + ("---|---|" if a.baseline else "") + ("---|---|---|" if have_embree else ""))
        for s in dict.fromkeys(big + LADDER):
            c, grp = ("render", s, "cierzo"), ("render", s, "group")
            row = {"cierzo": med(c), "group": med(grp), "group_ratio": ratio(grp, c)}
            line = f"| {s} | {med(c):.2f} | {med(grp):.2f} | {ratio(grp, c):.2f} |"
            if a.baseline:
                b = ("render", s, "baseline")
                row.update({"baseline": med(b), "ratio_baseline": ratio(c, b)})
                line += f" {med(b):.2f} | {ratio(c, b):.2f} |"
            if have_embree:
                e = ("render", s, "embree")
                mc, me = samples[c][-1]["mean"][0], samples[e][-1]["mean"][0]
                row.update({"embree": med(e), "ratio_embree": ratio(c, e), "mean_cierzo": mc,
                            "mean_embree": me})
                line += f" {med(e):.2f} | {ratio(c, e):.2f} | {mc:.4f}, {me:.4f} ({100 * (mc / me - 1):+.2f}%) |"
            print(line)
            result[f"render_{s}"] = row
        print("\n| cost per ray, ns (1 / rays/s) | " + " | ".join(LADDER) + " | 10M / 10k |")
        print("|---|" + "---|" * (len(LADDER) + 1))
        for who in ["cierzo", "group"] + (["embree"] if have_embree else []):
            ns = [1e3 / med(("render", s, who)) for s in LADDER]
            result[f"cost_per_ray_{who}"] = dict(zip(LADDER, ns))
            print(f"| {who} | " + " | ".join(f"{x:.0f}" for x in ns) + f" | {ns[-1] / ns[0]:.2f} |")
    if "spheres" not in skip:
        print("\n| sphere field | 10 spheres, M rays/s | 10,000 spheres | 10,000 / 10 |")
        print("|---|---|---|---|")
        for integ in ("wavefront", "scalar"):
            k10, k10k = ("spheres", 10, integ), ("spheres", 10000, integ)
            result[f"spheres_{integ}"] = {"10": med(k10), "10000": med(k10k), "ratio": ratio(k10k, k10)}
            print(f"| {integ} | {med(k10):.2f} | {med(k10k):.2f} | {ratio(k10k, k10):.2f} |")
    if "atrium" not in skip:
        print("\n| atrium (mis) | M rays/s | / scalar |")
        print("|---|---|---|")
        print(f"| scalar | {med(('atrium', 'scalar')):.2f} | 1 |")
        for w in widths:
            result[f"atrium_{w}"] = {"mrays": med(("atrium", w)), "ratio": ratio(("atrium", w), ("atrium", "scalar"))}
            print(f"| wavefront {w} | {med(('atrium', w)):.2f} | {ratio(('atrium', w), ('atrium', 'scalar')):.2f} |")
    benchlib.write_json(a.out / "in_flight.json", result)


if __name__ == "__main__":
    main()
