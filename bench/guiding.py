#!/usr/bin/python3
"""Guided mis against mis at equal time: the issue's efficiency, 1 / (relMSE x seconds).

For each scene: a reference (mis, the wavefront integrator on every core, --reference-spp
paths, with its per-pixel variance), then, one after the other and --repeats times over,
renders of --budget seconds on one thread (each stops at the end of the pass that crosses
the budget) of these configurations, all mis with its defaults otherwise:

  scalar        the scalar integrator, unguided (a guided render's integrator)
  wavefront     today's default: the wavefront integrator, unguided
  sdtree1       the scalar integrator, --guiding sdtree --guided-vertices 1 (the default)
  sdtree0       the scalar integrator, --guiding sdtree --guided-vertices 0 (every vertex)
  wavefront_sdtree1  the wavefront integrator, --guiding sdtree --guided-vertices 1

The relative MSE is cierzo converge's, mean over pixels and channels of
(x - r)^2 / (r^2 + 1e-2), with the reference's own noise (its variance, so scaled)
subtracted. Efficiency ratios are over `scalar` and over `wavefront`, each from the mean
error and mean time of its repeats.

The wavefront draws the very paths of the scalar integrator (the same sample streams and
kernels: their images at equal paths differ by float rounding alone, which the script
checks at 16 paths), so its error at equal paths is the scalar's. In a budget it traces
more paths than a reference of reasonable cost holds (16,000 and more at 160 x 120), where
the reference's noise, estimated from its per-pixel variance, is no longer small against
the error measured: where it reaches more than --reference-spp / 16 paths, its efficiency
over `scalar` is the ratio of their paths per second instead (measured in the same budget),
and its relative MSE is derived from the scalar's at the paths it reached (the error taken
as 1/paths). The guided wavefront (wavefront_sdtree1) is derived alike from sdtree1, whose
paths it draws but for the rare one that rounding in the guide's trees moves across a
quadrant's edge. Below that many paths (a short --budget) both are measured.

Usage: PYTHONPATH=build/python/module /usr/bin/python3 bench/guiding.py
       [--scenes small_emitter,caustic,PATH.json] [--width 160 --height 120] [--budget 30]
       [--repeats 1] [--reference-spp 16384]
       [--configs scalar,wavefront,sdtree1,sdtree0,wavefront_sdtree1]
       [--seed 3] [--out FILE.json]
"""
import argparse
import json
import platform

import numpy as np

import benchlib
import cierzo

CONFIGS = {
    "scalar": {"integrator": "scalar"},
    "wavefront": {"integrator": "wavefront"},
    "sdtree1": {"integrator": "scalar", "guiding": "sdtree", "guided_vertices": 1},
    "sdtree0": {"integrator": "scalar", "guiding": "sdtree", "guided_vertices": 0},
    "wavefront_sdtree1": {"integrator": "wavefront", "guiding": "sdtree", "guided_vertices": 1},
}
# The configurations whose error may be derived, and what from (the module's docstring)
DERIVED_FROM = {"wavefront": "scalar", "wavefront_sdtree1": "sdtree1"}


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="small_emitter,caustic,scenes/generated/mesh_200k.json,"
                    "scenes/guiding/lantern.json")
    ap.add_argument("--width", type=int, default=160)
    ap.add_argument("--height", type=int, default=120)
    ap.add_argument("--budget", type=float, default=30.0, help="seconds per render")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--reference-spp", type=int, default=16384)
    ap.add_argument("--configs", default=",".join(CONFIGS))
    ap.add_argument("--seed", type=int, default=3)
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    configs = a.configs.split(",")
    for c in configs:
        if c not in CONFIGS:
            ap.error(f"--configs: unknown configuration {c!r} (known: {', '.join(CONFIGS)})")
    results = {"cpu": benchlib.cpu_name(None) or platform.processor(), "width": a.width,
               "height": a.height, "budget": a.budget, "repeats": a.repeats,
               "reference_spp": a.reference_spp, "scenes": []}
    for name in a.scenes.split(","):
        scene = benchlib.scene_path(name)
        if not scene.is_file():
            ap.error(f"{scene}: no such scene (scenes/generated/: scripts/make_scenes.py)")
        size = {"width": a.width, "height": a.height}
        ref, ref_var, _ = cierzo.render(str(scene), spp=a.reference_spp, estimator="mis",
                                        seed=a.seed + 1000, variance=True, **size)
        ref, ref_var = ref.astype(np.float64), ref_var.astype(np.float64)
        scale = benchlib.rel_weights(ref)
        ref_noise = float(np.mean(ref_var * scale))
        if "wavefront" in configs:
            # (the two integrators draw the same paths: their images at equal paths agree far
            # below either's error)
            same = dict(estimator="mis", spp=16, seed=a.seed, **size)
            w, _ = cierzo.render(str(scene), integrator="wavefront", **same)
            s_, _ = cierzo.render(str(scene), integrator="scalar", **same)
            apart = float(np.mean((w.astype(np.float64) - s_) ** 2 * scale))
            error = float(np.mean((s_.astype(np.float64) - ref) ** 2 * scale))
            if not apart < 1e-3 * error:
                raise SystemExit(f"{scene}: the wavefront's and the scalar's paths differ "
                                 f"({apart:.3g} against an error of {error:.3g})")
        runs = {c: [] for c in configs}
        for r in range(a.repeats):
            for c in configs:
                img, st = cierzo.render(str(scene), estimator="mis", threads=1, spp=1 << 24,
                                        time_budget=a.budget, seed=a.seed + r, **size,
                                        **CONFIGS[c])
                d = img.astype(np.float64) - ref
                rel = float(np.mean(d * d * scale)) - ref_noise
                runs[c].append({"paths": st["spp_reached"], "seconds": st["seconds"],
                                "rel_mse": rel})
                print(f"{scene.stem:14s} {c:10s} {st['spp_reached']:6d} paths "
                      f"{st['seconds']:7.2f} s relMSE {rel:.4e}", flush=True)
        entry = {"scene": scene.stem, "reference_rel_mse": ref_noise, "configs": {}}
        eff = {}
        for c in sorted(configs, key=lambda c: c in DERIVED_FROM):  # (bases first)
            paths = float(np.mean([x["paths"] for x in runs[c]]))
            sec = float(np.mean([x["seconds"] for x in runs[c]]))
            derived = c in DERIVED_FROM and paths > a.reference_spp / 16
            if derived:
                if DERIVED_FROM[c] not in runs:
                    raise SystemExit(f"--configs: {c} reaches more paths than the reference "
                                     f"measures; its error is derived from {DERIVED_FROM[c]}, "
                                     "which --configs must name")
                base = entry["configs"][DERIVED_FROM[c]]
                rel = base["rel_mse"] * base["paths"] / paths
            else:
                rel = float(np.mean([x["rel_mse"] for x in runs[c]]))
            eff[c] = 1.0 / (rel * sec) if rel > 0 else float("inf")
            entry["configs"][c] = {"runs": runs[c], "paths": paths, "rel_mse": rel,
                                   "derived": derived, "seconds": sec,
                                   "efficiency": eff[c]}
        for c in configs:
            for base in ("scalar", "wavefront"):
                if base in eff:
                    entry["configs"][c][f"efficiency_over_{base}"] = eff[c] / eff[base]
        for base in ("scalar", "wavefront"):
            if base in eff:
                print(f"{scene.stem:14s} efficiency over {base} mis: " +
                      ", ".join(f"{c} {entry['configs'][c][f'efficiency_over_{base}']:.3g}x"
                                for c in configs), flush=True)
        results["scenes"].append(entry)
    if a.out:
        benchlib.write_json(a.out, results, indent=1)
    else:
        print(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
