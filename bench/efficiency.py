#!/usr/bin/python3
"""Efficiency at equal error of the sampling knobs of nee and mis against their defaults.

For each scene: one reference (`converge --save-reference`, mis, REF_SPP paths per pixel),
then `cierzo converge` with --estimator mis (or --estimator) for each configuration below,
1 thread, wavefront, at --spp, --repeats renders per point (median time, mean error). The
efficiency is 1 / (relMSE x seconds) (the reference's noise removed); the table gives each
configuration's efficiency over the lobe roulette's (uniform diffuse) at the same spp.

  lobe          the report's settings: the lobe roulette, uniform diffuse, area triangles,
                the independent sampler (nee and mis default to all+sobol)
  thr1/3/5      --roulette throughput --roulette-depth 1, 3, 5
  tri           --triangle-sampling solid-angle
  cos           --diffuse-sampling cosine
  all           thr1 + tri + cos
  sobol, zsobol, pmj02   --sampler sobol, zsobol, pmj02
  all+sobol, all+zsobol, all+pmj02   all three knobs with that sampler

Usage: /usr/bin/python3 bench/efficiency.py [--scenes box,cornell,PATH.json,...] [--size 128]
       [--spp 64,256] [--repeats 3] [--reference-spp 8192] [--estimator mis]
       [--configs lobe,all,all+sobol,...] [--out FILE.json]
"""
import argparse
import csv
import json
import pathlib
import tempfile

import benchlib

CIERZO = benchlib.CIERZO
# nee and mis default to the four knobs' best settings; every configuration below names all
# four, so that "lobe" is the report's settings whatever the defaults are
BASE = {"--roulette": "lobe", "--diffuse-sampling": "uniform", "--triangle-sampling": "area",
        "--sampler": "independent"}
THR1 = {"--roulette": "throughput", "--roulette-depth": "1"}
TRI = {"--triangle-sampling": "solid-angle"}
COS = {"--diffuse-sampling": "cosine"}
ALL = {**THR1, **TRI, **COS}
CONFIGS = {
    "lobe": {},
    "thr1": THR1,
    "thr3": {"--roulette": "throughput", "--roulette-depth": "3"},
    "thr5": {"--roulette": "throughput", "--roulette-depth": "5"},
    "tri": TRI,
    "cos": COS,
    "all": ALL,
    "sobol": {"--sampler": "sobol"},
    "zsobol": {"--sampler": "zsobol"},
    "pmj02": {"--sampler": "pmj02"},
    "all+sobol": {**ALL, "--sampler": "sobol"},
    "all+zsobol": {**ALL, "--sampler": "zsobol"},
    "all+pmj02": {**ALL, "--sampler": "pmj02"},
}


def options(config):
    merged = {**BASE, **config}
    return [x for kv in merged.items() for x in kv]


def converge(scene, args, extra, tmp, reference=None, save=None):
    """`cierzo converge` of one configuration: its CSV rows."""
    out = pathlib.Path(tmp) / "run.csv"
    cmd = [CIERZO, "converge", scene, "--integrator", "wavefront", "--threads", "1",
           "--estimator", args.estimator, "--width", args.size, "--height", args.size,
           "--spp", args.spp, "--repeats", args.repeats, "--out", out, "--quiet"]
    if reference:
        cmd += ["--reference", reference]
    else:
        cmd += ["--reference-spp", args.reference_spp, "--reference-estimator", "mis",
                "--save-reference", save]
    benchlib.run(cmd + extra)
    with open(out) as f:
        return list(csv.DictReader(f))


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="box,cornell,soft_shadow,small_emitter,four_lobes,"
                    "glass_spheres,phong_spheres,quad_light")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", default="64,256")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--reference-spp", type=int, default=8192)
    ap.add_argument("--estimator", default="mis")
    ap.add_argument("--configs", default=",".join(CONFIGS),
                    help="configurations to run, comma-separated (lobe, the base, always runs)")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.scenes.split(","):
            # (a name of scenes/, or a path such as build/scenes-generated/mesh_200k.json)
            scene = benchlib.scene_path(name)
            name = scene.stem
            ref = pathlib.Path(tmp) / f"{name}_ref.exr"
            rows = {}
            chosen = ["lobe"] + [c for c in a.configs.split(",") if c != "lobe"]
            for label in chosen:
                extra = options(CONFIGS[label])
                rows[label] = converge(scene, a, extra, tmp,
                                       reference=ref if ref.exists() else None, save=ref)
            for i, base in enumerate(rows["lobe"]):
                entry = {"scene": name, "spp": int(base["spp"])}
                for label, r in rows.items():
                    entry[label] = {"seconds": float(r[i]["seconds"]),
                                    "rays_per_second": float(r[i]["rays_per_second"]),
                                    "rel_mse": float(r[i]["rel_mse_corrected"]),
                                    "efficiency": float(r[i]["efficiency"])}
                results.append(entry)
                print(json.dumps(entry), flush=True)
    labels = ["lobe"] + [c for c in a.configs.split(",") if c != "lobe"]
    print("\n| scene | spp | " + " | ".join(f"{l} / lobe" for l in labels[1:]) + " |")
    print("|---|---|" + "---|" * (len(labels) - 1))
    for e in results:
        base = e["lobe"]["efficiency"]
        print(f"| {e['scene']} | {e['spp']} | " +
              " | ".join(f"{e[l]['efficiency'] / base:.2f}" for l in labels[1:]) + " |")
    if a.out:
        benchlib.write_json(a.out, results, indent=1)


if __name__ == "__main__":
    main()
