#!/usr/bin/python3
"""Measures the wavefront integrator's throughput targets side by side, in one run.

1. Every scene of scenes/ at 1 thread (bench_render: 128x128, 8 paths per pixel): the scalar
   reference against the wavefront on the best ISA, medians of --repetitions runs taken in
   random interleaved order, their ratio, and the wavefront's shading lane utilisation.
2. The default scene at its own settings (scenes/cornell.json, 500x500, 64 paths per
   pixel): the scalar reference at 1 thread, the wavefront at 1 thread on every ISA this
   CPU runs (`cierzo isas`) and at 2 threads on the best, run in alternation --rounds
   times; medians of rays/s per thread, the median of each round's own wavefront/scalar
   ratio per ISA, and the 2-thread speed-up.

Prints Markdown tables and writes them as JSON to OUT_DIR/targets.json.
Usage: /usr/bin/python3 bench/targets.py [--out OUT_DIR] [--repetitions N] [--rounds N]
       [--scene-filter REGEX]
Run it on an otherwise idle machine: both parts compare timings taken minutes apart.
"""
import argparse
import json
import pathlib
import re
import statistics
import sys
import tempfile

import benchlib

ROOT, BUILD, CIERZO = benchlib.ROOT, benchlib.BUILD, benchlib.CIERZO


def bench_scenes(repetitions, scene_filter):
    """Part 1: per scene, scalar and best-ISA wavefront medians from bench_render."""
    program = BUILD / "bench" / "bench_render"
    listing = benchlib.run([program, "--benchmark_list_tests=true"]).split()
    isas = [n.split("/")[2] for n in listing if n.startswith("render/")]
    best = next(i for i in ("wavefront_avx512", "wavefront_avx2", "wavefront_sse4.2") if i in isas)
    pattern = f"^render/({scene_filter})/(scalar|{re.escape(best)})$"
    out = benchlib.run(
        [program, f"--benchmark_filter={pattern}", f"--benchmark_repetitions={repetitions}",
         # repetitions of every benchmark interleaved in random order, so a slow spell of
         # a shared machine falls on both integrators alike
         "--benchmark_enable_random_interleaving=true",
         "--benchmark_report_aggregates_only=true", "--benchmark_format=json"])
    medians = {}
    for b in json.loads(out)["benchmarks"]:
        # (one repetition reports the run itself, several their aggregates)
        wanted = "iteration" if repetitions == 1 else "aggregate"
        if b.get("run_type") != wanted or (wanted == "aggregate" and b["aggregate_name"] != "median"):
            continue
        _, scene, variant = b["run_name"].split("/")
        medians.setdefault(scene, {})[variant] = b
    rows = []
    for scene, v in medians.items():
        if "scalar" not in v or best not in v:
            continue
        s, w = v["scalar"]["rays_per_s"], v[best]["rays_per_s"]
        rows.append({"scene": scene, "scalar_rays_per_s": s, "wavefront_rays_per_s": w,
                     "ratio": w / s, "shade_lane_util": v[best].get("shade_lane_util")})
    return best.removeprefix("wavefront_"), rows


def render_rate(integrator, threads, stats, isa="auto"):
    """One render of the default scene; returns its rays/s per thread."""
    return benchlib.render_stats([CIERZO, "render", benchlib.SCENES / "cornell.json",
                                  "--integrator", integrator, "--threads", threads, "--isa", isa,
                                  "--quiet", "--out", stats.with_suffix(".exr"), "--stats", stats],
                                 stats)["rays_per_second_per_thread"]


def default_scene(rounds):
    """Part 2: alternating whole renders of cornell.json; medians of rays/s per thread."""
    isas = benchlib.runnable_isas(CIERZO)
    runs = {"scalar_1": [], "wavefront_2": []}
    runs.update({f"wavefront_{isa}_1": [] for isa in isas})
    with tempfile.TemporaryDirectory() as tmp:
        stats = pathlib.Path(tmp) / "stats.json"
        for _ in range(rounds):
            runs["scalar_1"].append(render_rate("scalar", 1, stats))
            for isa in isas:
                runs[f"wavefront_{isa}_1"].append(render_rate("wavefront", 1, stats, isa))
            runs["wavefront_2"].append(render_rate("wavefront", 2, stats))
    med = {k: statistics.median(v) for k, v in runs.items()}
    ratios = {isa: benchlib.median_ratio(runs[f"wavefront_{isa}_1"], runs["scalar_1"])
              for isa in isas}
    best = med[f"wavefront_{isas[0]}_1"]
    return {"isas": isas, "runs": runs, "median_rays_per_s_per_thread": med,
            "median_round_ratio_over_scalar": ratios,
            "wavefront_over_scalar_1_thread": best / med["scalar_1"],
            "two_threads_over_one": 2 * med["wavefront_2"] / best}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(ROOT / "out" / "targets"))
    ap.add_argument("--repetitions", type=int, default=5)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--scene-filter", default="[a-z_]+",
                    help="regular expression of the scene names of part 1")
    args = ap.parse_args()
    if args.repetitions < 1 or args.rounds < 1:
        sys.exit("targets.py: --repetitions and --rounds must be at least 1")
    for program in (CIERZO, BUILD / "bench" / "bench_render"):
        benchlib.require(program, f"targets.py: {program} is missing; build with "
                         "scripts/build.sh build -DCIERZO_BUILD_BENCH=ON")

    isa, rows = bench_scenes(args.repetitions, args.scene_filter)
    print(f"Every scene, 1 thread, 128x128 at 8 spp (bench_render, medians of "
          f"{args.repetitions}):\n")
    print(f"| scene | scalar | wavefront {isa} | ratio | shading lanes |")
    print("|---|---|---|---|---|")
    for r in rows:
        util = r["shade_lane_util"]
        print(f"| {r['scene']} | {r['scalar_rays_per_s'] / 1e6:.2f} M | "
              f"{r['wavefront_rays_per_s'] / 1e6:.1f} M | {r['ratio']:.1f}x | "
              f"{'' if util is None else f'{100 * util:.0f}%'} |")
    d = default_scene(args.rounds)
    m = d["median_rays_per_s_per_thread"]
    print(f"\nscenes/cornell.json, 500x500 at 64 spp, medians of {args.rounds} alternating runs "
          "(rays/s per thread):\n")
    print("| scalar, 1 thread | wavefront, 1 thread | wavefront, 2 threads | wavefront / scalar "
          "| 2 threads / 1 |")
    print("|---|---|---|---|---|")
    best = m["wavefront_" + d["isas"][0] + "_1"]
    print(f"| {m['scalar_1'] / 1e6:.2f} M | {best / 1e6:.1f} M | "
          f"{m['wavefront_2'] / 1e6:.1f} M | {d['wavefront_over_scalar_1_thread']:.1f}x | "
          f"{d['two_threads_over_one']:.2f}x |")
    print("\nPer ISA, 1 thread, same rounds (ratio: the median of each round's own ratio):\n")
    print("| ISA | rays/s per thread | wavefront / scalar |")
    print("|---|---|---|")
    for isa in d["isas"]:
        print(f"| {isa} | {m[f'wavefront_{isa}_1'] / 1e6:.1f} M | "
              f"{d['median_round_ratio_over_scalar'][isa]:.1f}x |")
    out = pathlib.Path(args.out)
    benchlib.write_json(out / "targets.json", {"isa": isa, "scenes": rows, "default_scene": d})
    print(f"\nwrote {out / 'targets.json'}")


if __name__ == "__main__":
    main()
