#!/usr/bin/python3
"""What one incoherent ray reads: memory references, simulated cache misses and bytes, for
cierzo's traversal and Embree's, on the same rays (valgrind's cachegrind).

These virtual machines have no hardware cache counters (`perf stat` says <not supported>),
so the misses are cachegrind's simulation of this CPU's caches (its first-level data cache
and its last level, as cachegrind reads them from the CPU), which is deterministic: the same
binary and rays give the same counts on any load of the machine. Each program runs twice
under cachegrind, once with N rays and once with none, and the difference is divided by the
rays traced (`cierzo trace` and `embree_pt --trace-rays` trace the file twice: a warm-up and a
timed pass), so loading the scene and building the tree cancel out. Bytes per ray are the
first-level misses times 64 (the lines fetched into the core); cachegrind simulates no
prefetching, so these are the lines a ray needs, not what the hardware prefetchers add.

Usage: /usr/bin/python3 bench/bytes_per_ray.py [--scenes mesh_200k,mesh_1m] [--rays N]
         [--ray-group G]
Needs valgrind and bench/peers/embree/embree_pt (bench/peers/README.md); the scenes come from
scripts/make_scenes.py.
"""
import argparse
import pathlib
import re
import tempfile

import benchlib

CIERZO, EMBREE = benchlib.CIERZO, benchlib.EMBREE
EVENTS = ["Ir", "Dr", "D1mr", "DLmr"]


def cachegrind(cmd, tmp):
    """Program totals of EVENTS for cmd under cachegrind."""
    out = pathlib.Path(tmp) / "cg.out"
    benchlib.run(["valgrind", "--tool=cachegrind", "--cache-sim=yes",
                  f"--cachegrind-out-file={out}", *cmd])
    text = out.read_text()
    names = re.search(r"^events: (.*)$", text, re.M).group(1).split()
    totals = [int(x) for x in re.search(r"^summary: (.*)$", text, re.M).group(1).split()]
    return {n: totals[names.index(n)] for n in EVENTS}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scenes", default="mesh_200k,mesh_1m")
    ap.add_argument("--rays", type=int, default=20000)
    ap.add_argument("--ray-group", type=int, default=1, help="cierzo trace --ray-group")
    a = ap.parse_args()
    benchlib.require(EMBREE, f"{EMBREE} is needed (bench/peers/README.md builds it)")
    cpu = benchlib.cpu_name("?")
    print(f"CPU: {cpu}; cachegrind's simulated caches; {a.rays} rays traced twice\n")
    print("| scene | tracer | instructions / ray | data reads / ray | L1 misses / ray | bytes / ray (L1 lines) | last-level misses / ray |")
    print("|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in filter(None, a.scenes.split(",")):
            benchlib.ensure_scenes([name])
            scene = benchlib.generated_scene(name)
            full, some, none = (pathlib.Path(tmp) / f for f in ("all.rays", "some.rays", "none.rays"))
            benchlib.dump_rays(scene, full, a.rays)
            benchlib.head_of(full, some, a.rays)
            benchlib.head_of(full, none, 0)
            tracers = {
                "cierzo": lambda rays: [CIERZO, "trace", scene, "--rays", rays, "--ray-group", a.ray_group],
                "Embree rtcIntersect1": lambda rays: [EMBREE, scene, "--trace-rays", rays, "--api", "1"],
            }
            for who, cmd in tracers.items():
                with_rays, without = cachegrind(cmd(some), tmp), cachegrind(cmd(none), tmp)
                per = {e: (with_rays[e] - without[e]) / (2 * a.rays) for e in EVENTS}
                print(f"| {name} | {who} | {per['Ir']:.0f} | {per['Dr']:.0f} | {per['D1mr']:.1f} | "
                      f"{64 * per['D1mr']:.0f} | {per['DLmr']:.2f} |")


if __name__ == "__main__":
    main()
