#!/usr/bin/python3
"""Where the error comes from: each configuration's relative MSE split by path length.

For each scene, a reference of each band of path lengths (render.min_length/max_length):
  direct   lengths 1-2: emitters seen by the camera, and direct light at the first hit
  first    length 3: the first indirect bounce
  rest     lengths 4 and more
rendered with `mis` (its defaults) at --reference-spp on every core. The bands of one render
are the same paths' light split by length, so they add up to the whole image. Then each
configuration renders each band at --spp on 1 thread, and its error in each band is

  relMSE_band = mean over pixels of (x_band - ref_band)^2 / (ref_whole^2 + 1e-2)
                minus the reference's own noise,

each relative to the whole image's reference, so that the bands' errors add up to about
the whole image's (what is left is the bands' covariance). The table gives each band's
share of the sum, and the sum.

Configurations: as bench/efficiency.py (each names all four knobs):
  lobe        the report's settings (uniform diffuse, lobe roulette, area triangles,
              independent numbers)
  all         cosine diffuse, throughput roulette from vertex 1, triangles by solid angle
  all+sobol   the same with the sobol sampler: nee's and mis's defaults
With --guiding, instead (both by the scalar integrator, the only one that guides):
  defaults    all+sobol, unguided
  sdtree      all+sobol with --guiding sdtree. Each band is a render of its own, so its guide
              learns from that band's light alone (a guide of the whole image's light would
              learn the same directions where that band's light dominates)

Usage: PYTHONPATH=build/python/module /usr/bin/python3 bench/error_by_length.py
       [--scenes box,cornell,PATH.json] [--size 128] [--spp 64] [--reference-spp 4096]
       [--estimator mis] [--guiding] [--out FILE.json]
"""
import argparse
import json

import numpy as np

import benchlib
import cierzo

BANDS = {"direct": (1, 2), "first": (3, 3), "rest": (4, None)}
BASE = {"roulette": "lobe", "diffuse_sampling": "uniform", "triangle_sampling": "area",
        "sampler": "independent"}
ALL = {"roulette": "throughput", "roulette_depth": 1, "diffuse_sampling": "cosine",
       "triangle_sampling": "solid-angle"}
CONFIGS = {"lobe": {}, "all": ALL, "all+sobol": {**ALL, "sampler": "sobol"}}
GUIDED = {"defaults": {**ALL, "sampler": "sobol", "integrator": "scalar"},
          "sdtree": {**ALL, "sampler": "sobol", "integrator": "scalar", "guiding": "sdtree"}}


def band_kwargs(band):
    lo, hi = BANDS[band]
    kw = {"min_length": lo}
    if hi is not None:
        kw["max_length"] = hi
    return kw


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenes", default="box,cornell,soft_shadow,small_emitter,four_lobes,"
                    "glass_spheres,phong_spheres,quad_light")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--reference-spp", type=int, default=4096)
    ap.add_argument("--estimator", default="mis")
    ap.add_argument("--guiding", action="store_true",
                    help="compare unguided and guided defaults (scalar integrator)")
    ap.add_argument("--out", default=None)
    a = ap.parse_args()
    configs = GUIDED if a.guiding else CONFIGS
    results = []
    for name in a.scenes.split(","):
        scene = benchlib.scene_path(name)
        common = {"width": a.size, "height": a.size}
        ref, ref_var = {}, {}
        for band in BANDS:
            img, var, _ = cierzo.render(str(scene), spp=a.reference_spp, estimator="mis",
                                        threads=0, variance=True, **common, **band_kwargs(band))
            ref[band], ref_var[band] = img.astype(np.float64), var.astype(np.float64)
        whole = sum(ref.values())
        scale = benchlib.rel_weights(whole)
        for label, config in configs.items():
            entry = {"scene": scene.stem, "config": label, "spp": a.spp}
            for band in BANDS:
                img, _ = cierzo.render(str(scene), spp=a.spp, estimator=a.estimator, threads=1,
                                       **common, **band_kwargs(band), **{**BASE, **config})
                d = img.astype(np.float64) - ref[band]
                entry[band] = float(np.mean(d * d * scale) - np.mean(ref_var[band] * scale))
            entry["sum"] = sum(entry[b] for b in BANDS)
            results.append(entry)
            print(json.dumps(entry), flush=True)
    print("\n| scene | configuration | relMSE (sum of bands) | direct (1-2) | first indirect (3) "
          "| the rest (4+) |")
    print("|---|---|---|---|---|---|")
    for e in results:
        shares = " | ".join(f"{100 * e[b] / e['sum']:.0f}%" for b in BANDS)
        print(f"| {e['scene']} | {e['config']} | {e['sum']:.3g} | {shares} |")
    if a.out:
        benchlib.write_json(a.out, results, indent=1)


if __name__ == "__main__":
    main()
