#!/usr/bin/python3
"""One process, every scene of scenes/, two builds side by side: rays/s of each.

For the changes to the render driver that a one-process render should not feel (the MPI
bands, the film's exact error sum): every scene at its own estimator, `--width` x `--height`,
`--spp` paths per pixel and `--threads` threads, both builds in alternation (in opposite
orders in alternate rounds) for `--rounds` rounds; per scene the median over rounds of each
round's own ratio new / old rays/s (from --stats), and the geometric mean over scenes.

Usage: /usr/bin/python3 bench/one_process.py --old DIR --new DIR [--rounds 3]
       [--width 320 --height 240 --spp 16 --threads 1] [--target-error E] [--out FILE.json]
Run it on an otherwise idle machine.
"""
import argparse
import math
import os
import statistics
import tempfile

import benchlib


def rays_per_second(build, scene, a, tmp):
    """One render by the cierzo of build folder `build`: its rays/s (--stats)."""
    stats = os.path.join(tmp, "s.json")
    cmd = [benchlib.cierzo_in(build), "render", scene, "--quiet", "--width",
           a.width, "--height", a.height, "--spp", a.spp, "--threads",
           a.threads, "--out", os.path.join(tmp, "img.exr"), "--stats", stats]
    if a.target_error:
        cmd += ["--target-error", a.target_error]
    return benchlib.render_stats(cmd, stats)["rays_per_second"]


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--old", required=True)
    ap.add_argument("--new", required=True)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--width", type=int, default=320)
    ap.add_argument("--height", type=int, default=240)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--target-error", type=float, default=0.0)
    ap.add_argument("--out", default="")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="cierzo_one_process_")
    rows = []
    for scene in sorted(benchlib.SCENES.glob("*.json")):
        old, new = [], []
        for r in range(a.rounds):
            order = [("old", a.old), ("new", a.new)]
            if r % 2:
                order.reverse()
            got = {name: rays_per_second(build, scene, a, tmp) for name, build in order}
            old.append(got["old"]), new.append(got["new"])
        row = {"scene": scene.name, "old_rays_per_second": statistics.median(old),
               "new_rays_per_second": statistics.median(new),
               "new_over_old": benchlib.median_ratio(new, old)}
        rows.append(row)
        print(f"{scene.name:28s} {row['old_rays_per_second'] / 1e6:9.2f} "
              f"{row['new_rays_per_second'] / 1e6:9.2f} Mrays/s  {row['new_over_old']:.3f}")
    geo = math.exp(statistics.fmean(math.log(r["new_over_old"]) for r in rows))
    worst = min(rows, key=lambda r: r["new_over_old"])
    print(f"geometric mean new/old {geo:.3f}; lowest {worst['new_over_old']:.3f} ({worst['scene']})")
    if a.out:
        benchlib.write_json(a.out, {"cpu": benchlib.cpu_name(), "settings": vars(a), "scenes": rows,
                                    "geometric_mean": geo})


if __name__ == "__main__":
    main()
