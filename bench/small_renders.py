#!/usr/bin/python3
"""Whole renders of the default scene at small and large sizes, builds side by side.

What `converge` sweeps and Python sessions run most are small renders, where what the
render driver costs per unit (handing units out, adding passes to the film, waking threads)
shows beside the tracing itself. For each configuration (size x paths per pixel x threads)
this runs the `cierzo` program of every build given, in alternation, --rounds times, and
prints per build the median rays/s (from --stats), the median rays/s per thread, the median
of each round's own ratio to the first build, and the voluntary context switches of the
process (from wait4: a count, not a clock).

Usage: /usr/bin/python3 bench/small_renders.py [--build NAME=DIR ...] [--rounds N]
       [--scene SCENE.json] [--integrator wavefront|scalar] [--out FILE.json]
(default: the one build in build/). Run it on an otherwise idle machine.
"""
import argparse
import os
import statistics
import tempfile

import benchlib

# (width, height, paths per pixel, threads)
CONFIGS = [(250, 250, 16, 1), (250, 250, 16, 2), (500, 500, 128, 1), (960, 540, 64, 2)]


def run(program, scene, config, integrator, tmp):
    """One render; returns (rays/s, voluntary context switches)."""
    w, h, spp, threads = config
    stats = os.path.join(tmp, "stats.json")
    args = [program, "render", scene, "--width", str(w), "--height", str(h), "--spp", str(spp),
            "--threads", str(threads), "--integrator", integrator, "--quiet",
            "--out", os.path.join(tmp, "image.exr"), "--stats", stats]
    pid = os.fork()
    if pid == 0:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 2)
        os.execv(program, args)
    _, status, usage = os.wait4(pid, 0)
    if os.waitstatus_to_exitcode(status) != 0:
        raise SystemExit(f"{' '.join(args)} failed")
    return benchlib.read_stats(stats)["rays_per_second"], usage.ru_nvcsw


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build", action="append", default=[],
                        help="NAME=DIR: a build folder holding the cierzo program (repeatable)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--scene", default=str(benchlib.SCENES / "cornell.json"))
    parser.add_argument("--integrator", default="wavefront")
    parser.add_argument("--out", help="write the table as JSON here")
    a = parser.parse_args()
    builds = [b.split("=", 1) for b in a.build] or [["this", str(benchlib.BUILD)]]
    programs = {name: str(benchlib.cierzo_in(d)) for name, d in builds}
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for config in CONFIGS:
            rates = {name: [] for name in programs}
            switches = {name: [] for name in programs}
            for _ in range(a.rounds):
                for name, program in programs.items():
                    r, s = run(program, a.scene, config, a.integrator, tmp)
                    rates[name].append(r)
                    switches[name].append(s)
            first = builds[0][0]
            for name in programs:
                rows.append({"width": config[0], "height": config[1], "spp": config[2],
                             "threads": config[3], "build": name,
                             "rays_per_second": statistics.median(rates[name]),
                             "per_thread": statistics.median(rates[name]) / config[3],
                             "ratio_to_first": benchlib.median_ratio(rates[name], rates[first]),
                             "voluntary_switches": statistics.median(switches[name])})
    print(f"| size x spp | threads | build | Mrays/s | per thread | vs {builds[0][0]} "
          "| voluntary switches |")
    print("|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['width']}x{r['height']} x {r['spp']} | {r['threads']} | {r['build']} "
              f"| {r['rays_per_second'] / 1e6:.1f} | {r['per_thread'] / 1e6:.1f} "
              f"| {r['ratio_to_first']:.2f} | {r['voluntary_switches']:.0f} |")
    if a.out:
        benchlib.write_json(a.out, rows)


if __name__ == "__main__":
    main()
