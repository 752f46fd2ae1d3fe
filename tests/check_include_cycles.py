#!/usr/bin/env python3
"""Fails on any cycle of includes between modules: a module is a header and its source
(`x.h` and `x.cpp` in one folder), and module A depends on B when a file of A includes B's
header ("folder/b.h", quoted, as the code spells its includes from the repository's roots).
Prints each cycle as its modules in order and exits 1; exits 0 when there is none.

    check_include_cycles.py ROOT [FOLDER ...]   (default: src kernels)

Include paths are resolved against ROOT and ROOT/src, as the build's include directories
are; an include that resolves to neither (the system's, a third party's) is not an edge.
"""
import pathlib
import re
import sys

INCLUDE = re.compile(r'^\s*#\s*include\s*"([^"]+)"', re.M)


def module_of(path, root):
    """The module a file belongs to: its path from ROOT without the extension."""
    return str(path.relative_to(root).with_suffix(""))


def graph(root, folders):
    """Each module's set of modules it includes (itself excluded)."""
    deps = {}
    for folder in folders:
        for path in sorted((root / folder).rglob("*")):
            if path.suffix not in (".h", ".cpp") or not path.is_file():
                continue
            mod = module_of(path, root)
            edges = deps.setdefault(mod, set())
            for name in INCLUDE.findall(path.read_text(errors="replace")):
                for base in (root, root / "src", path.parent):
                    target = base / name
                    if target.is_file():
                        dep = module_of(target.resolve(), root.resolve())
                        if dep != mod:
                            edges.add(dep)
                        break
    return deps


def cycles(deps):
    """The strongly connected components of more than one module (Tarjan's algorithm), each
    with one cycle through them, in the order found."""
    index, low, on, stack, found = {}, {}, set(), [], []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(deps.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append((sorted(component), cycle_through(sorted(component), deps)))

    sys.setrecursionlimit(10000)
    for v in sorted(deps):
        if v not in index:
            visit(v)
    return found


def cycle_through(component, deps):
    """One cycle inside a strongly connected component, from its first module back to it."""
    members, start = set(component), component[0]
    path, seen = [start], {start}
    parents = {start: None}
    frontier = [start]
    while frontier:  # (breadth first, for the shortest way back to start)
        nxt = []
        for v in frontier:
            for w in sorted(deps.get(v, ())):
                if w == start:
                    back = [v]
                    while parents[back[-1]] is not None:
                        back.append(parents[back[-1]])
                    return list(reversed(back)) + [start]
                if w in members and w not in seen:
                    seen.add(w)
                    parents[w] = v
                    nxt.append(w)
        frontier = nxt
    return path


def main(argv):
    if len(argv) < 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    root = pathlib.Path(argv[1]).resolve()
    folders = argv[2:] or ["src", "kernels"]
    for folder in folders:
        if not (root / folder).is_dir():
            print(f"check_include_cycles: no folder {root / folder}", file=sys.stderr)
            return 2
    deps = graph(root, folders)
    found = cycles(deps)
    for members, cycle in found:
        print(f"include cycle among {len(members)} modules ({', '.join(members)}), one way "
              "round: " + " -> ".join(cycle))
    if found:
        return 1
    print(f"check_include_cycles: {len(deps)} modules in {', '.join(folders)}, no cycle")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
