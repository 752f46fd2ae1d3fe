#!/usr/bin/env python3
"""Writes scenes/meshes/torus.obj: a coarse torus (major radius 1, minor 0.4, in the xz plane)
with its exact vertex normals as 'vn' lines and quadrilateral faces 'f v//vn', the form most
OBJ exporters write. Coarse on purpose: flat shading shows every facet, smooth shading hides
them (scenes/smooth_normals.json)."""
import math
import sys

MAJOR, MINOR = 1.0, 0.4
U, V = 24, 12  # segments around the ring and around the tube


def main(path):
    lines = ["# torus: major radius 1, minor radius 0.4, %d x %d quads" % (U, V)]
    for i in range(U):
        a = 2 * math.pi * i / U
        for j in range(V):
            b = 2 * math.pi * j / V
            n = (math.cos(a) * math.cos(b), math.sin(b), math.sin(a) * math.cos(b))
            p = (math.cos(a) * MAJOR + MINOR * n[0], MINOR * n[1], math.sin(a) * MAJOR + MINOR * n[2])
            lines.append("v %.6f %.6f %.6f" % p)
            lines.append("vn %.6f %.6f %.6f" % n)
    for i in range(U):
        for j in range(V):
            k = [((i + di) % U) * V + (j + dj) % V + 1 for di, dj in ((0, 0), (0, 1), (1, 1), (1, 0))]
            lines.append("f " + " ".join("%d//%d" % (q, q) for q in k))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "scenes/meshes/torus.obj")
