#!/usr/bin/env python3
"""Measures distributed renders on this machine: rays/s with 1, 2 and 4 MPI ranks against
one process (interleaved rounds, medians), and the costs docs/distributed.md's model and
bench/mpi_scaling.py are calibrated by: the time per tile x pass unit, rank 0's main-thread
CPU per unit handed out (`mpi.rank0_cpu_seconds_per_unit`), the bytes sent between ranks per
unit, rank 0's CPU to gather the film per megapixel, and a checkpoint's size and write time.

    /usr/bin/python3 bench/distributed.py [--build build] [--scene scenes/cornell.json]
        [--estimator mis] [--width 960 --height 540 --spp 64] [--rounds 3]
        [--out bench/results/distributed.json] [--calibration FILE]

`--calibration FILE` writes the figures of the 4-rank runs as bench/mpi_scaling.py reads them.

Needs a build with MPI (mpirun on the PATH). As root it sets Open MPI's allow-run-as-root
variables. On a machine of 2 cores, more than 2 threads in all only share those 2 cores:
the figures measure the overhead of ranks, not a speed-up.
"""
import argparse, json, os, statistics, tempfile

import benchlib

def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--build", default="build")
    ap.add_argument("--scene", default="scenes/cornell.json")
    ap.add_argument("--width", type=int, default=960)
    ap.add_argument("--height", type=int, default=540)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--estimator", default="", help="the scene's own when not given")
    ap.add_argument("--calibration", default="")
    ap.add_argument("--out", default="")
    a = ap.parse_args()
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    cierzo = str(benchlib.cierzo_in(a.build))
    tmp = tempfile.mkdtemp(prefix="cierzo_dist_bench_")
    base = [cierzo, "render", a.scene, "--quiet", "--width", str(a.width), "--height", str(a.height),
            "--spp", str(a.spp), "--out", os.path.join(tmp, "img.exr")]
    if a.estimator:
        base += ["--estimator", a.estimator]
    # (label, ranks, threads per rank); ranks 0: no mpirun at all
    configs = [("one process, 2 threads", 0, 2), ("1 rank x 2 threads", 1, 2),
               ("2 ranks x 1 thread", 2, 1), ("4 ranks x 1 thread", 4, 1)]
    results = {c[0]: [] for c in configs}
    for r in range(a.rounds):
        order = configs if r % 2 == 0 else list(reversed(configs))
        for label, ranks, threads in order:
            stats = os.path.join(tmp, "s.json")
            cmd = base + ["--threads", str(threads), "--stats", stats]
            if ranks:
                cmd = ["mpirun", "-np", str(ranks), "--oversubscribe", "--bind-to", "none"] + cmd
            results[label].append(benchlib.render_stats(cmd, stats, env=env))
    table = []
    one = statistics.median(s["rays_per_second"] for s in results[configs[0][0]])
    for label, ranks, threads in configs:
        runs = results[label]
        traced = [s["mpi"]["rays_traced_per_second"] if "mpi" in s else s["rays_per_second"] for s in runs]
        row = {"config": label, "ranks": ranks, "threads_per_rank": threads,
               "rays_per_second": statistics.median(traced),
               "rays_per_second_per_core": statistics.median(traced) / 2.0,
               "vs_one_process": statistics.median(traced) / one,
               "seconds": statistics.median(s["seconds"] for s in runs)}
        m = [s["mpi"] for s in runs if "mpi" in s]
        if m:
            units = [sum(r["units"] for r in x["per_rank"]) for x in m]
            row["units"] = units[0]
            row["unit_seconds_per_thread"] = statistics.median(
                sum(r["seconds"] * r["threads"] for r in x["per_rank"]) / u for x, u in zip(m, units))
            row["rank0_cpu_seconds_per_unit"] = statistics.median(
                x["rank0_cpu_seconds_per_unit"] for x in m)
            row["bytes_sent_per_unit"] = statistics.median(x["bytes_sent_per_unit"] for x in m)
            row["requests"] = statistics.median(x["requests"] for x in m)
            row["rank0_cpu_seconds_per_request"] = statistics.median(
                x["rank0_cpu_seconds"] / max(1, x["requests"]) for x in m)
            row["rank0_deal_cpu_seconds_per_request"] = statistics.median(
                x["rank0_deal_cpu_seconds_per_request"] for x in m)
            row["rank0_gather_cpu_seconds_per_megapixel"] = statistics.median(
                x["rank0_gather_cpu_seconds"] / (a.width * a.height * 1e-6) for x in m)
        table.append(row)
    # A checkpoint of this film: size and write time (the final write of a short render)
    ck = os.path.join(tmp, "ck.exr")
    stats = os.path.join(tmp, "ck.json")
    c = benchlib.render_stats([cierzo, "render", a.scene, "--quiet", "--width", str(a.width),
                               "--height", str(a.height), "--spp", "2",
                               "--out", os.path.join(tmp, "c.exr"), "--checkpoint", ck,
                               "--stats", stats], stats, env=env)["checkpoint"]
    out = {"scene": a.scene, "estimator": a.estimator or "the scene's", "width": a.width, "height": a.height, "spp": a.spp, "rounds": a.rounds,
           "cpu": benchlib.cpu_name(),
           "cores": os.cpu_count(), "configs": table, "checkpoint": c}
    text = json.dumps(out, indent=2)
    print(text)
    if a.calibration:
        # For bench/mpi_scaling.py: a unit of 16 paths per pixel on a core of its own (the
        # 2-rank runs: one thread a core), rank 0's CPU per request of the 4-rank runs (of
        # the turns of its loop that dealt: requests, reports, answers, news, over the
        # requests; its polls are a cost per second, and its part per unit granted is below
        # what these runs separate), a unit's sums
        # (64 bytes a pixel of a full tile and a header), and the splats a 16-path unit sends
        two = next(r for r in table if r["ranks"] == 2)
        four = next(r for r in table if r["ranks"] == 4)
        m2 = [s["mpi"] for s in results[two["config"]]]
        passes = statistics.median(x["units"] for x in m2) / ((a.width + 15) // 16 * ((a.height + 15) // 16))
        per16 = 16.0 * passes / a.spp  # units of this run per unit of 16 paths
        m4 = [s["mpi"] for s in results[four["config"]]]
        splat = statistics.median(sum(r.get("splat_bytes_sent", 0) for r in x["per_rank"]) / x["units"]
                                  for x in m4)
        cal = {"t_u_seconds": two["unit_seconds_per_thread"] * per16,
               "rank0_seconds_per_request": statistics.median(
                   x["rank0_deal_cpu_seconds_per_request"] for x in m4),
               "rank0_seconds_per_unit": 0.0,
               "bytes_per_unit": 16 * 16 * 64 + 96,
               "gather_seconds_per_megapixel": four["rank0_gather_cpu_seconds_per_megapixel"],
               "source": f"bench/distributed.py --scene {a.scene} --estimator {a.estimator} "
                         f"--spp {a.spp}: 2 and 4 ranks x 1 thread, " + out["cpu"]}
        if splat > 0:
            cal["splat_bytes_per_unit"] = splat * per16
        benchlib.write_json(a.calibration, cal)
    if a.out:
        benchlib.write_json(a.out, out)

if __name__ == "__main__":
    main()
