#!/usr/bin/python3
"""Measures the downloaded-scene targets on the generated Sponza-like atrium, interleaved.

The atrium (scripts/make_atrium.py: about 270,000 triangles, 22 image textures, alpha-masked
leaves, an HDR sky) in three forms: `atrium` (textured), `atrium_flat` (every colour
texture replaced by its mean colour, the leaves' masks kept) and `atrium_plain` (no
texture, no mask). Every measurement is its own process on one thread; each round runs all
of them in turn, so a slow spell of the shared machine falls on all alike, and ratios are
the median of each round's own ratio.

1. Wavefront against the scalar reference, rays/s per core, on every ISA this CPU runs
   (the textured atrium; estimator `report` and `mis`).
2. What the textures cost: atrium against atrium_flat, and the masks: atrium_flat against
   atrium_plain (the wavefront on the widest ISA, and the scalar reference; `mis`).
3. Time to the first image: `cierzo render atrium.json --spp 1` on 2 threads, wall time,
   and `--stats` load.seconds, load.image_seconds, load.bvh_seconds.

Usage: /usr/bin/python3 bench/atrium.py [--rounds N] [--size W H] [--spp N]
(writes the scene with scripts/make_atrium.py into scenes/generated/atrium/ if missing).
The CPU is named in the output; say which one a number came from.
"""
import argparse
import pathlib
import subprocess
import sys
import tempfile
import time

import benchlib

ROOT, CIERZO, ATRIUM = benchlib.ROOT, benchlib.CIERZO, benchlib.ATRIUM


def render(tmp, scene, integrator, isa, estimator, size, spp, threads=1):
    """One render of the atrium: rays/s per thread, the whole process's wall time, and the
    --stats load and render seconds."""
    stats = pathlib.Path(tmp) / "stats.json"
    start = time.monotonic()
    benchlib.run([CIERZO, "render", ATRIUM / scene, "--spp", spp, "--width", size[0],
                  "--height", size[1], "--threads", threads, "--integrator", integrator,
                  "--isa", isa, "--estimator", estimator, "--quiet",
                  "--out", pathlib.Path(tmp) / "img.exr", "--stats", stats])
    wall = time.monotonic() - start
    s = benchlib.read_stats(stats)
    return {"rays_per_s": s["rays_per_second_per_thread"], "wall": wall, "load": s["load"],
            "render_seconds": s["seconds"]}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--size", type=int, nargs=2, default=[320, 180])
    p.add_argument("--spp", type=int, default=4)
    a = p.parse_args()
    if not (ATRIUM / "atrium.json").exists():
        subprocess.run([sys.executable, ROOT / "scripts" / "make_atrium.py"], check=True)
    have = benchlib.runnable_isas(CIERZO)
    print(f"CPU: {benchlib.cpu_name()}; ISAs run: {', '.join(have)}; {a.size[0]}x{a.size[1]}, "
          f"{a.spp} spp, one thread, {a.rounds} rounds\n")
    jobs = []
    for estimator in ("report", "mis"):
        jobs.append(("atrium.json", "scalar", "auto", estimator))
        for isa in have:
            jobs.append(("atrium.json", "wavefront", isa, estimator))
    for scene in ("atrium_flat.json", "atrium_plain.json"):
        jobs.append((scene, "scalar", "auto", "mis"))
        jobs.append((scene, "wavefront", have[0], "mis"))
    results = benchlib.Samples({j: [] for j in jobs})
    first = []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(a.rounds):
            for j in jobs:
                results[j].append(render(tmp, *j, a.size, a.spp))
            first.append(render(tmp, "atrium.json", "wavefront", "auto", "report",
                                [640, 360], 1, threads=2))

    rate, ratio = results.mrays, results.ratio

    print("| estimator | scalar Mrays/s/core | " + " | ".join(
        f"wavefront {i} Mrays/s/core (× scalar)" for i in have) + " |")
    print("|---|---|" + "---|" * len(have))
    for estimator in ("report", "mis"):
        s = ("atrium.json", "scalar", "auto", estimator)
        cells = [f"{rate(w):.2f} ({ratio(w, s):.2f}×)"
                 for w in [("atrium.json", "wavefront", i, estimator) for i in have]]
        print(f"| {estimator} | {rate(s):.2f} | " + " | ".join(cells) + " |")
    print("\n| integrator | textured | flat (masks kept) | plain | textured / flat | flat / plain |")
    print("|---|---|---|---|---|---|")
    for integrator, isa in (("scalar", "auto"), ("wavefront", have[0])):
        t = ("atrium.json", integrator, isa, "mis")
        f = ("atrium_flat.json", integrator, isa, "mis")
        pl = ("atrium_plain.json", integrator, isa, "mis")
        print(f"| {integrator} {isa} | {rate(t):.2f} | {rate(f):.2f} | {rate(pl):.2f} | "
              f"{ratio(t, f):.3f} | {ratio(f, pl):.3f} |")
    best = min(first, key=lambda x: x["wall"])
    worst = max(first, key=lambda x: x["wall"])
    print(f"\nTime to the first image (640x360, 1 spp, 2 threads, whole process): "
          f"{best['wall']:.2f}-{worst['wall']:.2f} s; load {best['load']['seconds']:.2f} s "
          f"(images {best['load']['image_seconds']:.3f} s for {best['load']['images']} images, "
          f"{best['load']['image_bytes'] / 1e6:.1f} MB; BVH {best['load']['bvh_seconds']:.2f} s "
          f"for {best['load']['triangles']} triangles), render {best['render_seconds']:.2f} s")


if __name__ == "__main__":
    main()
