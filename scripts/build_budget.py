#!/usr/bin/env python3
"""Where a build's time went, read from its folder's .ninja_log, and its budget checked.

    scripts/build_budget.py [BUILD] [--budget SECONDS] [--top N]

Prints the longest compile steps (translation units and precompiled headers), the critical
path (the chain of steps, each needing the one before, whose times add up to the most: the
build's wall time on unlimited cores), the sum of all steps and, for the last ninja run in
the folder, its wall time. Exits 1 when a compile step took longer than the budget (default
60 s; docs/build.md says why), naming it. The times are each step's wall time as ninja
measured it, so a run with more jobs than cores inflates them.
"""

import argparse
import os
import re
import subprocess
import sys

COMPILED = (".o", ".gch")


def read_log(path):
    """The .ninja_log's steps (output -> (start, end) in seconds) of the outputs' latest
    builds, and the steps (start, end, output) of its last run."""
    with open(path) as f:
        header = f.readline()
        if not header.startswith("# ninja log v"):
            sys.exit(f"{path}: not a ninja log (first line {header.strip()!r})")
        rows = []
        for line in f:
            parts = line.rstrip("\n").split("\t")
            if len(parts) != 5:
                continue
            start, end, mtime = int(parts[0]), int(parts[1]), int(parts[2])
            # (ninja times a run's steps from the run's start; the output's mtime, in ns,
            # less its end is when that run started)
            rows.append((start / 1000.0, end / 1000.0, parts[3], mtime / 1e6 - end))
    # (ninja rewrites the log in any order when it compacts it, so a step's run is found by
    # its start rather than by its place in the file)
    newest = {}
    for start, end, out, run in rows:
        if out not in newest or run >= newest[out][2]:
            newest[out] = (start, end, run)
    latest = {out: (start, end) for out, (start, end, _) in newest.items()}
    began = max((run for *_, run in rows), default=0.0)
    last = [(start, end, out) for out, (start, end, run) in newest.items() if abs(run - began) < 2000.0]
    return latest, last


def read_graph(build):
    """Each output's inputs, from `ninja -t graph` (its dot form: files are labelled nodes,
    a step with several inputs or outputs is an ellipse between them)."""
    dot = subprocess.run(["ninja", "-C", build, "-t", "graph", "all"], check=True,
                         capture_output=True, text=True).stdout
    label, steps, inputs = {}, set(), {}
    for line in dot.splitlines():
        m = re.match(r'"(0x[0-9a-f]+)" \[label="(.*?)"(, shape=ellipse)?\]$', line)
        if m:
            (steps.add if m.group(3) else lambda n: label.__setitem__(n, m.group(2)))(m.group(1))
            continue
        m = re.match(r'"(0x[0-9a-f]+)" -> "(0x[0-9a-f]+)"', line)
        if m:
            inputs.setdefault(m.group(2), []).append(m.group(1))

    def files_before(node):
        found = []
        for n in inputs.get(node, []):
            found.extend(files_before(n) if n in steps else [n])
        return found

    return {label[n]: [label[i] for i in files_before(n) if i in label]
            for n in label}


def critical_path(latest, graph):
    """The chain of logged steps whose times add up to the most, last step first."""
    sys.setrecursionlimit(100000)
    best = {}

    def finish(out):
        if out not in best:
            start, end = latest.get(out, (0.0, 0.0))
            before = max((finish(i) for i in graph.get(out, [])), default=(0.0, []),
                         key=lambda x: x[0])
            own = end - start
            best[out] = (before[0] + own, ([out] if own > 0 else []) + before[1])
        return best[out]

    return max((finish(out) for out in graph), default=(0.0, []), key=lambda x: x[0])


def short(out):
    out = re.sub(r"CMakeFiles/([^/]+)\.dir/", r"\1: ", out)
    return out.replace("src/integrators/wavefront/isa/", "")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("build", nargs="?", default="build", help="the build folder (build)")
    parser.add_argument("--budget", type=float, default=60.0,
                        help="the longest a compile step may take, in seconds (60)")
    parser.add_argument("--top", type=int, default=12, help="how many steps to list (12)")
    args = parser.parse_args()
    log = os.path.join(args.build, ".ninja_log")
    if not os.path.exists(log):
        sys.exit(f"{log}: no such file (build the folder with Ninja first)")
    latest, last_run = read_log(log)
    graph = read_graph(args.build)
    # (steps of outputs the build no longer has, left in the log by earlier configurations)
    latest = {out: times for out, times in latest.items() if out in graph}
    compiled = sorted(((end - start, out) for out, (start, end) in latest.items()
                       if out.endswith(COMPILED)), reverse=True)
    print(f"{len(compiled)} compile steps in {args.build}, the longest:")
    for seconds, out in compiled[:args.top]:
        print(f"  {seconds:7.1f} s  {short(out)}")
    total = sum(end - start for start, end in latest.values())
    print(f"all {len(latest)} steps: {total:.0f} s together", end="")
    if last_run:
        wall = max(e for _, e, _ in last_run) - min(s for s, _, _ in last_run)
        print(f"; the last run ({len(last_run)} steps) took {wall:.0f} s of wall time")
    else:
        print()
    length, chain = critical_path(latest, graph)
    print(f"critical path: {length:.1f} s in {len(chain)} steps")
    for out in reversed(chain):
        start, end = latest[out]
        print(f"  {end - start:7.1f} s  {short(out)}")
    over = [(s, out) for s, out in compiled if s > args.budget]
    if over:
        print(f"over the budget of {args.budget:.0f} s a compile step:")
        for seconds, out in over:
            print(f"  {seconds:7.1f} s  {short(out)}")
        return 1
    print(f"every compile step within the budget of {args.budget:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
