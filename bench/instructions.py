#!/usr/bin/python3
"""Instructions per traced ray, by part of the traversal, for cierzo and Embree on the same rays.

callgrind counts every instruction of `cierzo trace` (and of `embree_pt --trace-rays`) on a
ray file, and again on the file's first ray alone; the difference, divided by the rays
traced, is what one ray costs, with loading, building and start-up cancelled out. Counts do
not move with the machine's load, so a change to the traversal is judged by them first and
confirmed by time in an interleaved run (bench/accel.py).

cierzo's instructions are split by the inlined function they come from (addr2line -i on
every executed address: the innermost function of a known part decides):

  set-up     the ray prepared for the tree: reciprocals, shear, lanes, frame and registers
  node       the slab test of a node's children
  order      entering children: push, pop, sort, prefetch, the traversal's own loop
  leaf       leaf and primitive tests (triangles, spheres, quadrics, instances, alpha)
  unbounded  planes and unbounded quadrics, tested beside the tree
  harness    the trace command's loop over the rays and its totals
  loading    reading the ray file and laying it out (before the clock starts)

Embree's library has no line tables, so its part is one (the traversal inside
libembree3), beside its API entry and the harness.

Needs a cierzo built with debug information (its code is the same: -g never changes GCC's
output), for example:
  cmake -S . -B build-cg -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS=-g
  ninja -C build-cg cierzo embree_pt
Usage:
  /usr/bin/python3 bench/instructions.py SCENE.json RAYS [--build build-cg] [--isa avx2]
      [--integrator wavefront|scalar] [--ray-group N] [--no-embree] [--json OUT]
RAYS: a ray file (embree_pt --dump-rays); 20,000 rays take about a minute under callgrind.
valgrind has no AVX-512: the default ISA here is AVX2.
"""
import argparse
import collections
import pathlib
import re
import struct
import sys
import tempfile

import benchlib

ROOT = benchlib.ROOT

# The innermost function of an address's inline chain that matches decides its part
# (patterns are tried on each frame, innermost first).
CIERZO_PARTS = [
    ("leaf", r"\b(hit_triangle_leaf|hit_sphere_leaf|hit_leaf|intersect_triangle|intersect_sphere|"
             r"intersect_quadric|nearest_lane|alpha_filter|alpha_keeps|alpha_at|leaf_block|"
             r"test_triangles|triangle_block)\b"),
    ("node", r"\b(enter_children|slab_hits|node_test)\b"),
    ("order", r"\b(push_children|prefetch_children|prefetch_lines|pop_entry)\b"),
    ("set-up", r"\b(make_node_ray|make_leaf_ray|make_traversal_ray|make_ray_shear|WideRays|"
               r"TraversalRay|lane|set_up_rays|closest_in_tree_by_ray|closest_in_tree|"
               r"closest_lanes|occluded_by_ray)\b"),
    ("unbounded", r"\b(closest_unbounded|intersect_plane)\b"),
    ("traverse", r"\b(traverse|traverse_in)\b"),
    ("loading", r"\b(read_rays|ray_columns)\b"),
    ("harness", r"\b(trace_rays_isa|trace_rays_grouped|trace_ray_streams|record_batch|"
                r"run_trace_command|trace_rays_avx2|trace_rays_sse42|trace_rays_avx512|"
                r"Scene::intersect|intersect)\b"),
]


def first_ray(rays, out):
    """A ray file of the first ray of `rays`."""
    data = pathlib.Path(rays).read_bytes()
    if data[:8] != b"CZRAYS1\0":
        sys.exit(f"{rays}: not a ray file (no CZRAYS1 signature)")
    count = struct.unpack_from("<Q", data, 8)[0]
    if count < 2:
        sys.exit(f"{rays}: {count} rays; at least 2 are needed")
    benchlib.head_of(rays, out, 1)
    return count


# callgrind's name-compressed keys, by the table of names they share
TABLES = {"ob": "ob", "cob": "ob", "fl": "fl", "cfl": "fl", "fi": "fl", "cfi": "fl", "fe": "fl",
          "fn": "fn", "cfn": "fn"}


def parse_callgrind(path):
    """{object: {address: instructions}} of self cost from a --dump-instr=yes profile."""
    names = {"ob": {}, "fl": {}, "fn": {}}
    costs = collections.defaultdict(lambda: collections.defaultdict(int))
    obj = None
    last = 0
    skip = False
    with open(path) as f:
        for line in f:
            if skip:  # the inclusive cost of a call, on the line after calls=
                skip = False
                m = re.match(r"^(0x[0-9a-f]+|[+-]\d+|\*)", line)
                if m:
                    last = _position(m.group(1), last)
                continue
            if line.startswith("calls="):
                skip = True
                continue
            m = re.match(r"^(c?ob|c?fl|c?fn|c?fi|fe)=\((\d+)\)(?: (.*))?$", line.rstrip("\n"))
            if m:
                key, ident, name = m.groups()
                table = names[TABLES[key]]
                if name is not None:
                    table[ident] = name
                if key == "ob":
                    obj = names["ob"][ident]
                continue
            m = re.match(r"^(0x[0-9a-f]+|[+-]\d+|\*)\s+(\d+)", line)
            if m and obj is not None:
                last = _position(m.group(1), last)
                costs[obj][last] += int(m.group(2))
    return costs


def _position(token, last):
    if token == "*":
        return last
    if token.startswith("0x"):
        return int(token, 16)
    return last + int(token)


def load_base(binary, costs):
    """What to subtract from callgrind's addresses of `binary` to get its own: callgrind
    writes a position-independent object's addresses relative to where it was loaded (0),
    but other versions or set-ups may not; the base under which most executed addresses
    are some symbol's is taken."""
    symbols = set()
    for line in benchlib.run(["nm", "--defined-only", binary]).splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] in "tTwW":
            symbols.add(int(parts[0], 16))
    votes = collections.Counter()
    for address in costs:
        for base in (0, 0x108000, 0x400000, 0x4000000):
            if address - base in symbols:
                votes[base] += 1
    if not votes:
        sys.exit(f"{binary}: its executed addresses match none of its symbols")
    return votes.most_common(1)[0][0]


def inline_chains(binary, addresses):
    """{address: [function names, innermost first]} by addr2line -i."""
    text = "\n".join(hex(a) for a in addresses)
    out = benchlib.run(["addr2line", "-e", binary, "-f", "-C", "-i", "-a"], input=text).splitlines()
    chains, current = {}, None
    i = 0
    while i < len(out):
        line = out[i]
        if re.match(r"^0x[0-9a-f]+$", line):
            current = int(line, 16)
            chains[current] = []
            i += 1
            continue
        function = line
        location = out[i + 1] if i + 1 < len(out) else ""
        chains[current].append((function, location))
        i += 2
    return chains


def part_of(chain, rules, traverse_loop):
    for function, location in chain:
        for part, pattern in rules:
            if re.search(pattern, function.split("(")[0]):
                if part == "traverse":
                    # The traversal's own code: before its loop, the ray's set-up (frame,
                    # registers); in it, entering and leaving nodes
                    m = re.search(r":(\d+)", location)
                    line = int(m.group(1)) if m else 0
                    inside = location.split(":")[0].endswith("traverse.h") and line >= traverse_loop
                    return "order" if inside else "set-up"
                return part
    return "other"


def traverse_loop_line(root=ROOT):
    """The first line of the single-ray traversal's loop in kernels/bvh/traverse.h (the
    function is traverse_in, or traverse in older trees)."""
    lines = (root / "kernels" / "bvh" / "traverse.h").read_text().splitlines()
    start = next((i for i, l in enumerate(lines) if re.search(r"\bbool traverse_in\(", l)),
                 None)
    if start is None:
        start = next(i for i, l in enumerate(lines) if re.search(r"\bbool traverse\(", l))
    loop = next(i for i in range(start, len(lines)) if re.match(r"\s*for \(;;\)", lines[i]))
    return loop + 1


def callgrind(cmd, out):
    benchlib.run(["valgrind", "--tool=callgrind", "--dump-instr=yes", "--dump-line=no",
                  f"--callgrind-out-file={out}"] + cmd)
    return parse_callgrind(out)


def cierzo_parts(args, rays, one, tmp):
    binary = benchlib.cierzo_in(args.build)
    cmd = [binary, "trace", args.scene, "--rays", None, "--integrator", args.integrator,
           "--ray-group", args.ray_group]
    if args.integrator == "wavefront":
        cmd += ["--isa", args.isa]
    totals = {}
    for name, file in (("all", rays), ("one", one)):
        c = list(cmd)
        c[4] = file
        totals[name] = callgrind(c, tmp / f"cierzo_{name}.out")
    obj = next(o for o in totals["all"] if pathlib.Path(o).name == "cierzo")
    base = load_base(binary, totals["all"][obj])
    addresses = set(totals["all"][obj]) | set(totals["one"][obj])
    chains = inline_chains(binary, sorted(a - base for a in addresses))
    loop = traverse_loop_line(pathlib.Path(args.source))
    parts = collections.Counter()
    functions = collections.defaultdict(collections.Counter)  # part -> outermost known frame
    for sign, name in ((1, "all"), (-1, "one")):
        for o, costs in totals[name].items():
            for a, n in costs.items():
                if o == obj:
                    chain = chains.get(a - base, [])
                    part = part_of(chain, CIERZO_PARTS, loop)
                    parts[part] += sign * n
                    where = " < ".join(short_name(f) for f, _ in chain[:3])
                    functions[part][where] += sign * n
                else:
                    parts["libraries"] += sign * n
    return parts, functions


def short_name(function):
    """A function's name without namespaces, template arguments or parameters."""
    name = function.split("(")[0]
    depth, out = 0, []
    for ch in name:
        depth += ch == "<"
        if depth == 0:
            out.append(ch)
        depth -= ch == ">"
    return "".join(out).split("::")[-1] or name[:40]


def embree_parts(args, rays, one, tmp):
    binary = benchlib.embree_in(args.build)
    totals = {}
    for name, file in (("all", rays), ("one", one)):
        totals[name] = callgrind([binary, args.scene, "--trace-rays", file, "--api", "1",
                                  "--quality", "high"], tmp / f"embree_{name}.out")
    obj = next(o for o in totals["all"] if pathlib.Path(o).name == "embree_pt")
    base = load_base(binary, totals["all"][obj])
    addresses = set(totals["all"][obj]) | set(totals["one"][obj])
    chains = inline_chains(binary, sorted(a - base for a in addresses))
    rules = [("loading", r"\bread_rays\b")]
    parts = collections.Counter()
    for sign, name in ((1, "all"), (-1, "one")):
        for o, costs in totals[name].items():
            lib = pathlib.Path(o).name
            if o == obj:
                for a, n in costs.items():
                    part = part_of(chains.get(a - base, []), rules, 0)
                    parts["harness" if part == "other" else part] += sign * n
            elif "embree" in lib:
                parts["traversal (libembree3)"] += sign * sum(costs.values())
            else:
                parts["libraries"] += sign * sum(costs.values())
    return parts


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("scene")
    p.add_argument("rays")
    p.add_argument("--build", default=str(ROOT / "build-cg"))
    p.add_argument("--isa", default="avx2")
    p.add_argument("--integrator", default="wavefront", choices=["wavefront", "scalar"])
    p.add_argument("--ray-group", default=1, type=int)
    p.add_argument("--no-embree", action="store_true")
    p.add_argument("--source", default=str(ROOT),
                   help="the source tree the build was made from (for the traversal's lines)")
    p.add_argument("--json")
    p.add_argument("--detail", type=int, default=0, metavar="N",
                   help="also print each part's N largest sources (inline chains)")
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as t:
        tmp = pathlib.Path(t)
        one = tmp / "one.rays"
        count = first_ray(args.rays, one)
        # Each program traces the file twice (a warm-up pass and one timed pass)
        per_ray = 1.0 / (2 * (count - 1))
        results = {}
        results["cierzo"], functions = cierzo_parts(args, args.rays, one, tmp)
        embree = benchlib.embree_in(args.build)
        if not args.no_embree and embree.exists():
            results["embree"] = embree_parts(args, args.rays, one, tmp)
    report = {}
    for who, parts in results.items():
        report[who] = {k: v * per_ray for k, v in sorted(parts.items())}
        report[who]["total"] = sum(parts.values()) * per_ray
    cpu = benchlib.cpu_name("unknown")
    print(f"instructions per ray, {count} rays of {args.rays} through {args.scene}")
    print(f"cierzo: {args.integrator}, isa {args.isa}, ray group {args.ray_group}; CPU: {cpu}")
    print("(counts, not times: the CPU changes nothing but the ISA valgrind may run)\n")
    names = ["set-up", "node", "order", "leaf", "unbounded", "harness", "loading", "libraries",
             "other",
             "traversal (libembree3)"]
    print("| part | " + " | ".join(report) + " |")
    print("|---|" + "---|" * len(report))
    for n in names + ["total"]:
        if any(n in r for r in report.values()):
            print(f"| {n} | " + " | ".join(f"{r[n]:.0f}" if n in r else "" for r in report.values())
                  + " |")
    if args.detail:
        per_ray = 1.0 / (2 * (count - 1))
        for part, where in sorted(functions.items()):
            print(f"\n{part}: where its instructions come from (innermost < callers)")
            for w, n in where.most_common(args.detail):
                if abs(n * per_ray) >= 0.5:
                    print(f"  {n * per_ray:7.1f}  {w}")
    if args.json:
        benchlib.write_json(args.json, {
            "scene": args.scene, "rays": args.rays, "count": count, "isa": args.isa,
            "integrator": args.integrator, "cpu": cpu, "per_ray": report})


if __name__ == "__main__":
    main()
