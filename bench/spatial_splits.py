#!/usr/bin/python3
"""Measures the BVH's spatial splits (render.spatial_splits) against none and against Embree.

For each scene (default: sticks_100k, 100,000 long thin triangles of random direction, and
mesh_200k, a compact 200,000-triangle knot; both from scripts/make_scenes.py) and each
split budget (default 0, 0.25, 1), in one interleaved run, one thread:

- the traversal alone: `cierzo trace` on 1M incoherent rays of the scene
  (`embree_pt --dump-rays`), and Embree's rtcIntersect1 on its medium (binned SAH) and
  high (spatial splits) trees on the same rays;
- whole renders (wavefront, 200x200, 4 paths per pixel) and the Embree path tracer's (its
  default, high-quality tree), with the image means, which must agree;
- the build: references, bytes per triangle and seconds on 2 threads (`--stats`).

Ratios are the median of each round's own ratio. The scene variants are written next to
the generated scenes as NAME.splits-B.json.
Usage: /usr/bin/python3 bench/spatial_splits.py [--rounds N] [--scenes a,b] [--budgets 0,1]
The CPU is named in the output; say which one a number came from.
"""
import argparse
import pathlib
import statistics
import tempfile

import benchlib

EMBREE = benchlib.EMBREE


def variant(scene, budget):
    """The scene with render.spatial_splits set, beside it (its mesh paths are relative)."""
    text = scene.read_text()
    key = '"render": {'
    if key not in text:
        raise SystemExit(f"{scene}: no one-line 'render' object to add spatial_splits to")
    out = scene.with_name(f"{scene.stem}.splits-{budget}.json")
    out.write_text(text.replace(key, f'{key}"spatial_splits": {budget}, ', 1))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--scenes", default="sticks_100k,mesh_200k")
    ap.add_argument("--budgets", default="0,0.25,1")
    a = ap.parse_args()
    names = [n for n in a.scenes.split(",") if n]
    budgets = [b for b in a.budgets.split(",") if b]
    benchlib.ensure_scenes(names)
    benchlib.require(EMBREE, f"{EMBREE} is not built: apt-get install libembree-dev, then "
                     "ninja -C build embree_pt")
    print(f"CPU: {benchlib.cpu_name('?')}; {a.rounds} interleaved rounds, one thread\n")
    samples = benchlib.Samples()
    add = samples.add

    with tempfile.TemporaryDirectory() as tmp:
        scenes = {n: benchlib.generated_scene(n) for n in names}
        variants = {(n, b): variant(s, b) for n, s in scenes.items() for b in budgets}
        rays = {}
        for n, s in scenes.items():
            rays[n] = pathlib.Path(tmp) / f"{n}.rays"
            benchlib.dump_rays(s, rays[n], 1000000)
        builds = {(n, b): benchlib.cierzo_build(tmp, s) for (n, b), s in variants.items()}
        for n, s in scenes.items():
            for q in ("medium", "high"):
                k = benchlib.keys(benchlib.run([EMBREE, s, "--width", 1, "--height", 1, "--spp", 1,
                                                "--quality", q, "--embree-config", "threads=2"]))
                builds[(n, "embree-" + q)] = float(k["build_seconds"])
        for r in benchlib.rounds(a.rounds):
            for n, s in scenes.items():
                for b in budgets:
                    v = variants[(n, b)]
                    add(("trace", n, b), benchlib.cierzo_trace(v, rays[n]))
                    add(("render", n, b), benchlib.cierzo_render(tmp, v, "wavefront", 200, 4))
                for q in ("medium", "high"):
                    add(("trace", n, "embree-" + q), benchlib.embree_trace(s, rays[n], "1", q))
                add(("render", n, "embree"), benchlib.embree_render(tmp, s, 200, 4))

    med = lambda xs: statistics.median(xs) / 1e6
    ratio = benchlib.median_ratio
    print("| scene | spatial_splits | references | bytes/triangle | build, 2 threads (s) | "
          "trace, M rays/s | / no splits | / Embree high | / Embree medium | "
          "render, M rays/s | / Embree | R mean (Embree) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in names:
        eh = samples.rates(("trace", n, "embree-high"))
        em = samples.rates(("trace", n, "embree-medium"))
        er = samples.rates(("render", n, "embree"))
        for b in budgets:
            t = samples.rates(("trace", n, b))
            rr = samples.rates(("render", n, b))
            bs = builds[(n, b)]
            print(f"| {n} | {b} | {bs['references']:,} | {bs['bytes'] / bs['primitives']:.1f} | "
                  f"{bs['build_seconds']:.3f} | {med(t):.2f} | "
                  f"{ratio(t, samples.rates(('trace', n, budgets[0]))):.2f} | "
                  f"{ratio(t, eh):.2f} | {ratio(t, em):.2f} | "
                  f"{med(rr):.2f} | {ratio(rr, er):.2f} | "
                  f"{samples[('render', n, b)][-1]['mean'][0]:.4f} "
                  f"({samples[('render', n, 'embree')][-1]['mean'][0]:.4f}) |")
        print(f"| {n} | Embree | | | high {builds[(n, 'embree-high')]:.3f}, medium "
              f"{builds[(n, 'embree-medium')]:.3f} | "
              f"high {med(eh):.2f}, medium {med(em):.2f} | | | | "
              f"{med(er):.2f} | | |")


if __name__ == "__main__":
    main()
