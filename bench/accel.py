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
import json
import pathlib
import re
import statistics
import struct
import subprocess
import sys
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent
BUILD = ROOT / "build"
CIERZO = BUILD / "cierzo"
EMBREE = BUILD / "bench" / "peers" / "embree" / "embree_pt"
# Embree's APIs (embree_pt --api) on its trees of build quality high and medium
EMBREE_TRACES = [(api, quality) for quality in ("high", "medium") for api in ("1", "16", "1M")]
GENERATED = ROOT / "scenes" / "generated"


def run(cmd):
    return subprocess.run([str(c) for c in cmd], check=True, capture_output=True, text=True).stdout


def keys(text):
    """key: value lines as a dict of strings."""
    return dict(m.groups() for m in re.finditer(r"^(\w+): (.*)$", text, re.M))


def pfm_mean(path):
    """Mean RGB of a PFM image."""
    data = pathlib.Path(path).read_bytes()
    header = data.split(b"\n", 3)
    w, h = map(int, header[1].split())
    scale = float(header[2])
    n = w * h * 3
    floats = struct.unpack(("<" if scale < 0 else ">") + f"{n}f", header[3][: 4 * n])
    return [sum(floats[c::3]) / (w * h) for c in range(3)]


def cierzo_render(tmp, scene, integrator, size, spp, binary=CIERZO):
    out, stats = pathlib.Path(tmp) / "img.pfm", pathlib.Path(tmp) / "stats.json"
    run([binary, "render", scene, "--width", size, "--height", size, "--spp", spp,
         "--threads", 1, "--integrator", integrator, "--quiet", "--out", out, "--stats", stats])
    s = json.loads(stats.read_text())
    return {"rays_per_s": s["rays_per_second_per_thread"], "mean": pfm_mean(out),
            "bvh": s.get("bvh")}


def embree_render(tmp, scene, size, spp):
    out = pathlib.Path(tmp) / "embree.pfm"
    k = keys(run([EMBREE, scene, "--width", size, "--height", size, "--spp", spp, "--out", out]))
    return {"rays_per_s": float(k["rays_per_second"]), "mean": [float(x) for x in k["mean_rgb"].split()]}


def median_ratio(a, b):
    return statistics.median(x / y for x, y in zip(a, b))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--out", type=pathlib.Path, default=BUILD / "bench-results")
    ap.add_argument("--baseline", type=pathlib.Path, help="an earlier cierzo, for part 5")
    a = ap.parse_args()
    if not (GENERATED / "spheres_10000.json").exists() or not (GENERATED / "mesh_1m.json").exists():
        run([sys.executable, ROOT / "scripts" / "make_scenes.py"])
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    flags = open("/proc/cpuinfo").read()
    isa = "AVX-512" if "avx512f" in flags else ("AVX2" if "avx2" in flags else "other")
    print(f"CPU: {cpu} ({isa}); best ISA as `cierzo isas` says; {a.rounds} interleaved rounds\n")
    have_embree = EMBREE.exists()
    spheres = {n: GENERATED / f"spheres_{n}.json" for n in (10, 10000)}
    triangles = {"box": ROOT / "scenes" / "box.json", "mesh_200k": GENERATED / "mesh_200k.json"}
    samples = {}

    def add(key, value):
        samples.setdefault(key, []).append(value)

    with tempfile.TemporaryDirectory() as tmp:
        rays = {}
        if have_embree:
            for name, scene in triangles.items():
                rays[name] = pathlib.Path(tmp) / f"{name}.rays"
                run([EMBREE, scene, "--dump-rays", rays[name], "--count", 1000000])
        for r in range(a.rounds):
            print(f"round {r + 1}/{a.rounds}", file=sys.stderr)
            for n, scene in spheres.items():
                add(("spheres", n, "wavefront"), cierzo_render(tmp, scene, "wavefront", 200, 8))
                add(("spheres", n, "scalar"), cierzo_render(tmp, scene, "scalar", 200, 2))
            for name, scene in triangles.items():
                spp = 16 if name == "box" else 8
                add(("render", name, "cierzo"), cierzo_render(tmp, scene, "wavefront", 300, spp))
                if have_embree:
                    add(("render", name, "embree"), embree_render(tmp, scene, 300, spp))
                    k = keys(run([CIERZO, "trace", scene, "--rays", rays[name]]))
                    add(("trace", name, "cierzo"), {"rays_per_s": float(k["rays_per_second"]),
                                                    "hits": int(k["hits"])})
                    k = keys(run([CIERZO, "trace", scene, "--rays", rays[name], "--stream", 1024,
                                  "--single-below", 16]))
                    add(("trace", name, "stream"), {"rays_per_s": float(k["rays_per_second"]),
                                                    "hits": int(k["hits"])})
                    for api, quality in EMBREE_TRACES:
                        k = keys(run([EMBREE, scene, "--trace-rays", rays[name], "--api", api,
                                      "--quality", quality]))
                        add(("trace", name, "embree", api, quality),
                            {"rays_per_s": float(k["rays_per_second"]), "hits": int(k["hits"])})
            if a.baseline:
                cornell = ROOT / "scenes" / "cornell.json"
                add(("cornell", "now"), cierzo_render(tmp, cornell, "wavefront", 250, 16))
                add(("cornell", "baseline"), cierzo_render(tmp, cornell, "wavefront", 250, 16, a.baseline))
        # Build: one 1M-triangle mesh, 2 threads
        mesh_1m = GENERATED / "mesh_1m.json"
        builds = []
        for _ in range(3):
            stats = pathlib.Path(tmp) / "build.json"
            run([CIERZO, "render", mesh_1m, "--width", 1, "--height", 1, "--spp", 1, "--threads", 2,
                 "--quiet", "--out", pathlib.Path(tmp) / "b.pfm", "--stats", stats])
            builds.append(json.loads(stats.read_text())["bvh"])
        embree_builds = []
        if have_embree:
            for _ in range(3):
                k = keys(run([EMBREE, mesh_1m, "--width", 1, "--height", 1, "--spp", 1,
                              "--embree-config", "threads=2"]))
                embree_builds.append(float(k["build_seconds"]))

    rays = lambda key: [s["rays_per_s"] for s in samples[key]]
    med = lambda key: statistics.median(rays(key)) / 1e6
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
            ratio_fastest = statistics.median(x / y for x, y in zip(rays(c), fastest))
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
    a.out.mkdir(parents=True, exist_ok=True)
    (a.out / "accel.json").write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
