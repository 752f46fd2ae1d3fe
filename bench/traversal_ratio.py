#!/usr/bin/python3
"""Traversal alone, interleaved: `cierzo trace` builds (this one, and optionally an older
one) against Embree's rtcIntersect1 (`embree_pt --trace-rays --api 1`, build quality high)
on the same ray file, one thread each, every round running all in turn; ratios are the
medians of each round's own ratios (a shared machine's slow spells fall on all alike).
With --render SPP, whole renders instead: `cierzo render` (wavefront, the scene's
estimator) against the Embree path tracer (`embree_pt --spp`), 300 x 300, one thread, rays/s
and image means (equal means: equal work).

Usage: /usr/bin/python3 bench/traversal_ratio.py SCENE.json RAYS [--rounds 7] [--repeat 3]
    [--cierzo build/cierzo] [--baseline OLD/cierzo] [--embree build/.../embree_pt]
    [--isa auto avx2 ...] [--render SPP] [--json OUT]
RAYS: a ray file (embree_pt --dump-rays; ignored with --render). Prints M rays/s (median)
and the ratios; names the CPU, which every number depends on.
"""
import argparse
import json
import pathlib
import re
import statistics
import subprocess
import tempfile

ROOT = pathlib.Path(__file__).resolve().parent.parent


def rays_per_second(cmd):
    out = subprocess.run([str(c) for c in cmd], check=True, capture_output=True, text=True).stdout
    keys = dict(re.findall(r"^(\w+): (.*)$", out, re.M))
    if "hits" in keys:
        return float(keys["rays_per_second"]), int(keys["hits"])
    if "mean_rgb" in keys:  # embree_pt rendering
        return float(keys["rays_per_second"]), keys["mean_rgb"]
    stats = json.loads(pathlib.Path(cmd[cmd.index("--stats") + 1]).read_text())
    return stats["rays_per_second_per_thread"], pfm_mean(cmd[cmd.index("--out") + 1])


def pfm_mean(path):
    """Mean RGB of a PFM image, as text."""
    data = pathlib.Path(path).read_bytes()
    header = data.split(b"\n", 3)
    w, h = (int(x) for x in header[1].split())
    import struct
    floats = struct.unpack(("<" if float(header[2]) < 0 else ">") + f"{3 * w * h}f", header[3])
    return " ".join(f"{sum(floats[c::3]) / (w * h):.5f}" for c in range(3))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene")
    p.add_argument("rays")
    p.add_argument("--rounds", type=int, default=7)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--cierzo", default=str(ROOT / "build" / "cierzo"))
    p.add_argument("--baseline")
    p.add_argument("--embree", default=str(ROOT / "build" / "bench" / "peers" / "embree" / "embree_pt"))
    p.add_argument("--isa", nargs="+", default=["auto"])
    p.add_argument("--render", type=int, metavar="SPP",
                   help="whole renders of SPP samples a pixel instead of the traversal alone")
    p.add_argument("--json")
    a = p.parse_args()
    tmp = pathlib.Path(tempfile.mkdtemp())
    runs = {}
    for isa in a.isa:
        for who, binary in (("cierzo", a.cierzo), ("baseline", a.baseline)):
            if not binary:
                continue
            if a.render:
                out, stats = tmp / f"{who}_{isa}.pfm", tmp / f"{who}_{isa}.json"
                runs[f"{who} {isa}"] = [binary, "render", a.scene, "--width", 300, "--height",
                                        300, "--spp", a.render, "--threads", 1, "--isa", isa,
                                        "--quiet", "--out", out, "--stats", stats]
            else:
                runs[f"{who} {isa}"] = [binary, "trace", a.scene, "--rays", a.rays, "--isa", isa,
                                        "--repeat", a.repeat]
    if a.render:
        runs["embree rtcIntersect1"] = [a.embree, a.scene, "--width", 300, "--height", 300,
                                        "--spp", a.render, "--out", tmp / "embree.pfm"]
    else:
        runs["embree rtcIntersect1"] = [a.embree, a.scene, "--trace-rays", a.rays, "--api", "1",
                                        "--repeat", a.repeat]
    samples = {k: [] for k in runs}
    hits = {}
    for _ in range(a.rounds):
        for name, cmd in runs.items():
            r, h = rays_per_second(cmd)
            samples[name].append(r)
            hits[name] = h
    cpu = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo")
                if l.startswith("model name")), "unknown")
    print(f"{a.scene}, {a.rays}: {a.rounds} interleaved rounds, --repeat {a.repeat}; CPU: {cpu}")
    print("| program | M rays/s (median) | hits (trace) or image mean (render) | / Embree (median of rounds) |")
    print("|---|---|---|---|")
    e = samples["embree rtcIntersect1"]
    result = {"cpu": cpu, "scene": a.scene, "rays": a.rays, "rounds": a.rounds, "runs": {}}
    for name, s in samples.items():
        ratio = statistics.median(x / y for x, y in zip(s, e))
        print(f"| {name} | {statistics.median(s) / 1e6:.2f} | {hits[name]} | {ratio:.3f} |")
        result["runs"][name] = {"rays_per_s": s, "hits": hits[name], "vs_embree": ratio}
    if a.baseline:
        for isa in a.isa:
            ratio = statistics.median(x / y for x, y in zip(samples[f"cierzo {isa}"],
                                                            samples[f"baseline {isa}"]))
            print(f"cierzo / baseline, {isa}: {ratio:.3f}")
            result[f"vs_baseline_{isa}"] = ratio
    if a.json:
        pathlib.Path(a.json).write_text(json.dumps(result, indent=2) + "\n")


if __name__ == "__main__":
    main()
