#!/usr/bin/env python3
"""Writes the large benchmark scenes into scenes/generated/ (never committed).

Scene data that is too big for git (tens of thousands of spheres, meshes of hundreds of
thousands of triangles) is made here instead, from fixed seeds: every run writes the same
bytes, so two machines render exactly the same scene. Python 3 standard library only.

    python3 scripts/make_scenes.py                  # the default set, into scenes/generated/
    python3 scripts/make_scenes.py --list           # every scene it knows, and which are default
    python3 scripts/make_scenes.py --only mesh_1m   # just these (comma-separated)
    python3 scripts/make_scenes.py --spheres 50000  # spheres_50000.json
    python3 scripts/make_scenes.py --triangles 4000000  # mesh_4m.json + mesh_4m.ply
    build/cierzo render scenes/generated/spheres_1000.json

Every scene file starts with `//` comment lines saying what it is and the command that
makes it; meshes are binary little-endian PLY (float x, y, z; `list uchar int
vertex_indices`), next to the scene that uses them. All scenes use only cierzo's existing
materials and no point lights.

The scenes:

- `spheres_N.json` (10, 1000 and 10000 by default; `--spheres N` for any N): after the final
  scene of *Ray Tracing in One Weekend*. A ground plane, N small spheres (radius 0.16 to
  0.24) on a jittered grid of spacing 1, each inside its own cell so none overlap; 80%
  diffuse, 15% mirror, 5% glass (ior 1.5), from a fixed palette of materials that is the
  same in every file; three big spheres (diffuse, glass, mirror) in the middle; and one
  emitter, a sky sphere of radius 10,000 with emission 1 around everything. The cells are
  taken in order of distance from a point on the ground in the foreground of the view, and
  each cell's sphere depends only on the cell, so spheres_10 is the ten spheres of
  spheres_10000 nearest that point: the same camera (RTIOW's: from (13, 2, 3) towards the
  origin, vfov 20), the same scene, more spheres. 500x500, 16 spp.
- `box.json` (committed in scenes/, made with `--only box --out scenes`): an open box of
  ten `triangle` objects (floor, back wall, red left and green right walls, emitting
  ceiling), seen through its open front from where the Cornell scenes' camera is. Diffuse
  and emission only. 500x500, 64 spp.
- `mesh_200k.json` + `.ply`: that box with one mesh of exactly 200,000 triangles standing on
  its floor: a (3, 5) torus knot tube with twisted ridges and a swelling along its length.
  Diffuse and emission only. 500x500, 16 spp.
- `instances_100.json` + `knot.ply`: that box with 100 `mesh` objects all reading the same
  12,000-triangle trefoil knot, each with its own scale (some non-uniform, some mirrored),
  rotation and translation, resting on the floor in a 10x10 grid (1.2 M triangles traced
  from one 12,000-triangle file, for instancing). Diffuse and emission only. 500x500, 16 spp.
- `mesh_N.json` + `.ply` (`--triangles N`; the default set has `mesh_1m`, N = 1,000,000,
  a 19 MB PLY): the mesh_200k scene with the knot made of N triangles (exactly N when N/2
  has a divisor near the ideal tube resolution, else within about 1%), for BVH build
  benchmarks. mesh_200k is this scene with N = 200,000.
- `sticks_100k.json` + `.ply`: that box with 50,000 straws thrown into its lower part, each
  a long thin quad (two triangles, 0.1 to 0.3 long, 0.004 wide) of random direction: 100,000
  triangles whose boxes are far larger than their area, as in grass, hair, fences and wire
  (the case for the BVH's spatial splits). Diffuse and emission only. 500x500, 16 spp.

Each scene's time is printed, and the total: the whole default set takes 2 to 3 s (1.7 to
3.2 s wall over six runs under `nice` on a shared two-core machine; mesh_1m is about 1 s
of it, spheres_10000 about 0.3 s).
"""

import argparse
import array
import json
import math
import os
import re
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "scenes" / "generated"
SCRIPT = "scripts/make_scenes.py"

# ---- Deterministic random numbers ---------------------------------------------------
# SplitMix64, so the numbers (and the files) do not depend on the Python version.

MASK64 = (1 << 64) - 1
GOLDEN = 0x9E3779B97F4A7C15


def mix64(z):
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK64
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK64
    return z ^ (z >> 31)


class Rng:
    """A stream keyed by a tuple of integers: Rng(7, a, b) is the same for the same key."""

    def __init__(self, *key):
        s = 0x243F6A8885A308D3
        for k in key:
            s = mix64(((s ^ (k & MASK64)) + GOLDEN) & MASK64)
        self.state = s

    def random(self):
        self.state = (self.state + GOLDEN) & MASK64
        return (mix64(self.state) >> 11) * (1.0 / 9007199254740992.0)

    def uniform(self, a, b):
        return a + (b - a) * self.random()

    def below(self, n):
        return min(int(self.random() * n), n - 1)


# ---- Writing -------------------------------------------------------------------------


def num(x, digits=5):
    """A number as short fixed-point text: 0.5, -1.25, 10000 (never -0)."""
    if isinstance(x, int):
        return str(x)
    s = f"{x:.{digits}f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def jvalue(v):
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return num(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(jvalue(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)}: {jvalue(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def write_atomic(path, data):
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


def scene_text(header, render, camera, materials, objects):
    """The scene as JSON with one material and one object per line, under // comments."""
    lines = [f"// {h}" if h else "//" for h in header]
    lines.append("{")
    # Every generated scene names the report's estimator, which its measurements use (a scene
    # that names none renders with mis)
    lines.append(f'  "render": {jvalue({"estimator": "report", **render})},')
    lines.append(f'  "camera": {jvalue(camera)},')
    lines.append('  "materials": {')
    items = list(materials.items())
    for i, (name, m) in enumerate(items):
        lines.append(f"    {json.dumps(name)}: {jvalue(m)}" + ("," if i + 1 < len(items) else ""))
    lines.append("  },")
    lines.append('  "objects": [')
    for i, o in enumerate(objects):
        lines.append(f"    {jvalue(o)}" + ("," if i + 1 < len(objects) else ""))
    lines.append("  ]")
    lines.append("}")
    text = "\n".join(lines) + "\n"
    # The reader allows // comments; the body alone must be plain JSON.
    json.loads("\n".join(l for l in lines if not l.startswith("//")))
    return text


def ply_bytes(header, positions, indices):
    """Binary little-endian PLY: positions a flat list of x, y, z; indices 3 per triangle."""
    nv, nf = len(positions) // 3, len(indices) // 3
    head = ["ply", "format binary_little_endian 1.0"]
    head += [f"comment {h}" for h in header]
    head += [f"element vertex {nv}", "property float x", "property float y", "property float z",
             f"element face {nf}", "property list uchar int vertex_indices", "end_header"]
    verts = array.array("f", positions)
    idx = array.array("i", indices)
    if sys.byteorder == "big":
        verts.byteswap()
        idx.byteswap()
    # Each face is 13 bytes: the count 3, then three int32. Filled by strided slices.
    ib = idx.tobytes()
    faces = bytearray(13 * nf)
    faces[0::13] = b"\x03" * nf
    for k in range(12):
        faces[1 + k::13] = ib[k::12]
    return ("\n".join(head) + "\n").encode("ascii") + verts.tobytes() + bytes(faces)


def command(name, out):
    cmd = f"python3 {SCRIPT} --only {name}"
    out = Path(out).resolve()
    if out != DEFAULT_OUT:
        try:
            rel = out.relative_to(REPO)
            cmd += f" --out {rel.as_posix()}"
        except ValueError:
            cmd += f" --out {out.as_posix()}"
    return cmd


# ---- Geometry ------------------------------------------------------------------------


def transform_matrix(scale, rotate):
    """cierzo's mesh transform without the translation: Rz Ry Rx diag(scale), as 3 rows.
    A vertex goes to p' = M p + translate (rotations in degrees, about x, then y, then z)."""
    ax, ay, az = (math.radians(a) for a in rotate)
    cx, sx, cy, sy, cz, sz = (math.cos(ax), math.sin(ax), math.cos(ay), math.sin(ay),
                              math.cos(az), math.sin(az))
    rx = [[1, 0, 0], [0, cx, -sx], [0, sx, cx]]
    ry = [[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]]
    rz = [[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]

    def mul(a, b):
        return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]

    m = mul(rz, mul(ry, rx))
    return [[m[i][j] * scale[j] for j in range(3)] for i in range(3)]


def bounds(positions, scale=(1, 1, 1), rotate=(0, 0, 0)):
    """The box around the transformed vertices (before any translation)."""
    m = transform_matrix(scale, rotate)
    xs, ys, zs = positions[0::3], positions[1::3], positions[2::3]
    lo, hi = [], []
    for row in m:
        a, b, c = row
        vals = [a * x + b * y + c * z for x, y, z in zip(xs, ys, zs)]
        lo.append(min(vals))
        hi.append(max(vals))
    return lo, hi


class Knot:
    """A closed tube around a (p, q) torus knot: U rings of V vertices, 2*U*V triangles.

    The centre line winds p times around the z axis and q times around the torus core
    (radius R, tube-of-torus radius r). Around the line the tube has radius
    rho * (1 + ridge * sin(ridges*phi + twist*t) + swell * sin(swells*t)): twisted ridges
    like a rope and a slow swelling along its length. The frame is the tangent and the
    direction from the torus core to the line, which is exactly perpendicular to the
    tangent, so it closes up without a seam. Scaled so the knot fits in the unit sphere
    about the origin, in the xy plane (facing -z)."""

    def __init__(self, p, q, R, r, rho, ridges, twist, ridge, swells, swell):
        self.p, self.q, self.R, self.r, self.rho = p, q, R, r, rho
        self.ridges, self.twist, self.ridge = ridges, twist, ridge
        self.swells, self.swell = swells, swell

    def grid_for(self, triangles):
        """U, V with 2*U*V close to `triangles` and quads about square on the surface."""
        # Length of the centre line against the tube's circumference
        m = 2000
        length = sum(math.dist(self.centre(2 * math.pi * i / m)[0],
                               self.centre(2 * math.pi * (i + 1) / m)[0]) for i in range(m))
        aspect = length / (2 * math.pi * self.rho)
        half = max(triangles // 2, 24)
        ideal = max(8, math.sqrt(half / aspect))
        # A divisor of triangles/2 near the ideal ring size gives exactly that many
        best = None
        if triangles % 2 == 0:
            for v in range(max(8, int(ideal * 0.75)), int(ideal * 1.33) + 2):
                if half % v == 0 and (best is None or abs(v - ideal) < abs(best - ideal)):
                    best = v
        v = best if best else max(8, round(ideal))
        u = max(3, round(half / v))
        return u, v

    def centre(self, t):
        p, q, R, r = self.p, self.q, self.R, self.r
        cp, sp, cq, sq = math.cos(p * t), math.sin(p * t), math.cos(q * t), math.sin(q * t)
        rad = R + r * cq
        c = (rad * cp, rad * sp, r * sq)
        d = (-r * q * sq * cp - rad * p * sp, -r * q * sq * sp + rad * p * cp, r * q * cq)
        n = (cq * cp, cq * sp, sq)  # core to line, unit, perpendicular to d
        return c, d, n

    def mesh(self, u_count, v_count):
        extent = self.R + self.r + self.rho * (1 + self.ridge + self.swell)
        k = 1.0 / extent
        phis = [2 * math.pi * j / v_count for j in range(v_count)]
        cs = [(math.cos(f), math.sin(f), math.cos(self.ridges * f), math.sin(self.ridges * f))
              for f in phis]
        pos = []
        for i in range(u_count):
            t = 2 * math.pi * i / u_count
            c, d, n = self.centre(t)
            dl = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
            tx, ty, tz = d[0] / dl, d[1] / dl, d[2] / dl
            bx, by, bz = ty * n[2] - tz * n[1], tz * n[0] - tx * n[2], tx * n[1] - ty * n[0]
            ct, st = math.cos(self.twist * t), math.sin(self.twist * t)
            base = self.rho * (1 + self.swell * math.sin(self.swells * t))
            for cf, sf, cr, sr in cs:
                # sin(ridges*phi + twist*t) from the precomputed sines and cosines
                rad = (base + self.rho * self.ridge * (sr * ct + cr * st)) * k
                ox, oy, oz = cf * n[0] + sf * bx, cf * n[1] + sf * by, cf * n[2] + sf * bz
                pos += (c[0] * k + rad * ox, c[1] * k + rad * oy, c[2] * k + rad * oz)
        idx = []
        v = v_count
        for i in range(u_count):
            row, nxt = i * v, ((i + 1) % u_count) * v
            for j in range(v):
                j1 = (j + 1) % v
                a, b, c, d = row + j, nxt + j, nxt + j1, row + j1
                idx += (a, d, c, a, c, b)  # outward normals
        return pos, idx


# The knot of mesh_200k and mesh_N, and the instanced one of instances_100
BIG_KNOT = Knot(p=3, q=5, R=1.0, r=0.45, rho=0.16, ridges=7, twist=60, ridge=0.12,
                swells=12, swell=0.15)
INSTANCE_KNOT = Knot(p=2, q=3, R=1.0, r=0.45, rho=0.28, ridges=4, twist=9, ridge=0.1,
                     swells=3, swell=0.1)
INSTANCE_KNOT_TRIANGLES = 12000

# ---- The open box --------------------------------------------------------------------

BOX_MATERIALS = {
    "white": {"kd": [0.8, 0.8, 0.8]},
    "red": {"kd": [0.8, 0.1, 0.1]},
    "green": {"kd": [0.1, 0.8, 0.1]},
    "light": {"emission": [1, 1, 1]},
}
# The Cornell scenes' frame (eye at z = -3.5, tan(fov/2) = 1/3) in the look_at form
BOX_CAMERA = {"position": [0, 0, -3.5], "look_at": [0, 0, 0], "up": [0, 1, 0],
              "vfov": 2 * math.degrees(math.atan(1 / 3))}


def box_objects():
    """Ten triangles: the box [-1, 1]^3 without its front (z = -1), normals inwards."""
    def quad(corners, inward, material):
        p0, p1, p2, p3 = corners
        e1 = [p1[k] - p0[k] for k in range(3)]
        e2 = [p2[k] - p0[k] for k in range(3)]
        n = (e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
             e1[0] * e2[1] - e1[1] * e2[0])
        if sum(n[k] * inward[k] for k in range(3)) < 0:
            p1, p3 = p3, p1
        return [{"type": "triangle", "vertices": [p0, p1, p2], "material": material},
                {"type": "triangle", "vertices": [p0, p2, p3], "material": material}]

    return (quad([[-1, -1, -1], [1, -1, -1], [1, -1, 1], [-1, -1, 1]], (0, 1, 0), "white")
            + quad([[-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], (0, 0, -1), "white")
            + quad([[-1, -1, -1], [-1, -1, 1], [-1, 1, 1], [-1, 1, -1]], (1, 0, 0), "red")
            + quad([[1, -1, -1], [1, -1, 1], [1, 1, 1], [1, 1, -1]], (-1, 0, 0), "green")
            + quad([[-1, 1, -1], [1, 1, -1], [1, 1, 1], [-1, 1, 1]], (0, -1, 0), "light"))


BOX_HEADER = [
    "An open box [-1, 1]^3 of ten triangles (5 quads): white floor and back wall, red wall",
    "at x = -1, green wall at x = 1, emitting ceiling (emission 1) at y = 1; no front wall.",
    "The camera looks in through the open front from the Cornell scenes' eye point.",
]


def make_box(name, out):
    objects = box_objects()
    header = [f"{name}.json: a triangle-only scene, diffuse and emission only."] + BOX_HEADER
    header += [f"{len(objects)} triangle objects; no meshes, planes or spheres.",
               f"Made by: {command(name, out)}"]
    text = scene_text(header, {"width": 500, "height": 500, "spp": 64, "seed": 1},
                      BOX_CAMERA, BOX_MATERIALS, objects)
    write_atomic(Path(out) / f"{name}.json", text.encode())
    return {"objects": len(objects), "triangles": len(objects)}


# ---- Scenes with meshes --------------------------------------------------------------


def make_mesh(name, out, triangles):
    u, v = BIG_KNOT.grid_for(triangles)
    pos, idx = BIG_KNOT.mesh(u, v)
    nf = len(idx) // 3
    cmd = command(name, out)
    ply_header = [f"{name}.ply: a ({BIG_KNOT.p}, {BIG_KNOT.q}) torus knot tube with twisted ridges, "
                  f"{u} rings of {v} vertices, {nf} triangles, in the unit sphere",
                  f"made by: {cmd}"]
    write_atomic(Path(out) / f"{name}.ply", ply_bytes(ply_header, pos, idx))
    # Stand it on the floor, facing the camera, turned a little
    scale, rotate = 0.72, [0, 25, 0]
    lo, _ = bounds(pos, [scale] * 3, rotate)
    translate = [0, -1 - lo[1] + 1e-5, 0.1]  # on the floor, whatever the rounding
    mesh = {"type": "mesh", "file": f"{name}.ply", "scale": scale, "rotate": rotate,
            "translate": translate, "material": "knot"}
    return write_box_with_mesh(
        name, out, mesh, ("knot", [0.75, 0.7, 0.6]), nf,
        [f"{name}.json: one mesh of {nf:,} triangles ({name}.ply, a ({BIG_KNOT.p}, "
         f"{BIG_KNOT.q}) torus knot tube with", "twisted ridges) standing in the open box."])


def write_box_with_mesh(name, out, mesh, material, triangles, header):
    """NAME.json: the open box and one mesh object (its PLY already written), 500x500x16."""
    objects = box_objects() + [mesh]
    materials = dict(BOX_MATERIALS, **{material[0]: {"kd": material[1]}})
    header = header + BOX_HEADER + [
        f"{len(objects) - 1} triangle objects + 1 mesh = {triangles + len(objects) - 1:,} "
        "triangles; diffuse and emission only.",
        f"Made by: {command(name, out)}"]
    text = scene_text(header, {"width": 500, "height": 500, "spp": 16, "seed": 1},
                      BOX_CAMERA, materials, objects)
    write_atomic(Path(out) / f"{name}.json", text.encode())
    return {"objects": len(objects), "triangles": triangles + len(objects) - 1,
            "files": [f"{name}.json", f"{name}.ply"]}


STICKS = 50_000


def make_sticks(name, out):
    """The open box with 50,000 straws thrown into its lower part: long thin quads (two
    triangles each) of random direction, whose boxes are far larger than their area, as in
    grass, hair, fences and wire (the case spatial splits in a BVH are for)."""
    pos, idx = [], []
    rng = Rng(11, STICKS)
    for i in range(STICKS):
        c = [rng.uniform(-0.85, 0.85), rng.uniform(-0.95, 0.0), rng.uniform(-0.6, 0.85)]
        # a direction uniform on the sphere, and a width across it
        z = rng.uniform(-1.0, 1.0)
        phi = rng.uniform(0.0, 2.0 * math.pi)
        s = math.sqrt(max(0.0, 1.0 - z * z))
        d = [s * math.cos(phi), s * math.sin(phi), z]
        a = [1.0, 0.0, 0.0] if abs(d[0]) < 0.9 else [0.0, 1.0, 0.0]
        w = [d[1] * a[2] - d[2] * a[1], d[2] * a[0] - d[0] * a[2], d[0] * a[1] - d[1] * a[0]]
        wl = math.sqrt(sum(x * x for x in w))
        half, width = rng.uniform(0.05, 0.15), 0.004
        w = [x / wl * width * 0.5 for x in w]
        base = len(pos) // 3
        for sl, sw in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
            pos += [c[k] + sl * half * d[k] + sw * w[k] for k in range(3)]
        idx += [base, base + 1, base + 2, base, base + 2, base + 3]
    nf = len(idx) // 3
    cmd = command(name, out)
    write_atomic(Path(out) / f"{name}.ply",
                 ply_bytes([f"{name}.ply: {STICKS:,} straws, long thin quads of random "
                            f"direction, {nf} triangles", f"made by: {cmd}"], pos, idx))
    return write_box_with_mesh(
        name, out, {"type": "mesh", "file": f"{name}.ply", "material": "straw"},
        ("straw", [0.8, 0.7, 0.35]), nf,
        [f"{name}.json: {STICKS:,} straws ({name}.ply: long thin quads of random direction, "
         f"{nf:,} triangles)", "thrown into the lower part of the open box."])


# Per-instance scales before normalising: uniform, non-uniform and mirrored
INSTANCE_SCALES = [
    [1, 1, 1], [1, 0.5, 1.5], [-1, 1, 1], [1, 1, -1], [1.4, 0.7, 1], [0.7, 1.4, 0.9],
    [-1, 0.6, 1.2], [1.2, 1, 0.6], [1, -1, 1], [-0.8, 1.3, -1],
]


def make_instances(name, out):
    count_side, spacing = 10, 0.18
    u, v = INSTANCE_KNOT.grid_for(INSTANCE_KNOT_TRIANGLES)
    pos, idx = INSTANCE_KNOT.mesh(u, v)
    nf = len(idx) // 3
    cmd = command(name, out)
    ply_header = [f"knot.ply: a ({INSTANCE_KNOT.p}, {INSTANCE_KNOT.q}) torus knot (trefoil) tube, "
                  f"{u} rings of {v} vertices, {nf} triangles, in the unit sphere",
                  f"made by: {cmd}"]
    write_atomic(Path(out) / "knot.ply", ply_bytes(ply_header, pos, idx))
    rng = Rng(100, 1)
    objects = box_objects()
    n_box = len(objects)
    half_cell = spacing / 2
    for row in range(count_side):
        for col in range(count_side):
            s = INSTANCE_SCALES[rng.below(len(INSTANCE_SCALES))]
            size = rng.uniform(0.065, 0.08) / max(abs(c) for c in s)
            scale = [round(c * size, 5) for c in s]  # as written, so the placement is exact
            rotate = [round(rng.uniform(0, 360), 2) for _ in range(3)]
            lo, hi = bounds(pos, scale, rotate)
            cx = (col - (count_side - 1) / 2) * spacing
            cz = (row - (count_side - 1) / 2) * spacing + 0.1
            # 1e-5 above the floor, so the 5-digit rounding never sinks it in
            translate = [cx - (lo[0] + hi[0]) / 2, -1 - lo[1] + 1e-5, cz - (lo[2] + hi[2]) / 2]
            # Each instance stays inside its own cell, so none overlap
            assert max(hi[0] - lo[0], hi[2] - lo[2]) / 2 < half_cell, (row, col)
            assert abs(cx) + half_cell < 1 and abs(cz) + half_cell < 1, (row, col)
            objects.append({"type": "mesh", "file": "knot.ply", "scale": scale, "rotate": rotate,
                            "translate": translate, "material": f"k{(row + col) % 4}"})
    materials = dict(BOX_MATERIALS)
    for i, kd in enumerate([[0.75, 0.7, 0.6], [0.3, 0.45, 0.75], [0.8, 0.55, 0.2],
                            [0.5, 0.7, 0.45]]):
        materials[f"k{i}"] = {"kd": kd}
    n_inst = len(objects) - n_box
    header = [f"{name}.json: {n_inst} instances of one mesh (knot.ply, {nf:,} triangles, a "
              "trefoil knot tube), each a `mesh`",
              "object with its own scale (some non-uniform, some mirrored), rotation and "
              "translation, resting on the", "floor of the open box in a 10x10 grid."]
    header += BOX_HEADER[:2] + [
        "The camera is just inside the open front, looking down at the floor.",
        f"{n_box} triangle objects + {n_inst} mesh objects = {n_box + n_inst * nf:,} "
        "triangles traced; diffuse and emission only.",
        f"Made by: {cmd}"]
    camera = {"position": [0, 0.8, -0.98], "look_at": [0, -1, 0.2], "up": [0, 1, 0],
              "vfov": 58}
    text = scene_text(header, {"width": 500, "height": 500, "spp": 16, "seed": 1},
                      camera, materials, objects)
    write_atomic(Path(out) / f"{name}.json", text.encode())
    return {"objects": len(objects), "triangles": n_box + n_inst * nf,
            "files": [f"{name}.json", "knot.ply"]}


# ---- Spheres after Ray Tracing in One Weekend ----------------------------------------

SPHERE_CAMERA = {"position": [13, 2, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov": 20}
# The cells are taken in order of distance from this ground point, hit by the camera ray
# through the middle column 80% of the way down the image: in front of the big spheres.
SPHERE_FOCUS = (5.5, 1.3)
BIG_SPHERES = [((-4, 1, 0), 1, "big_diffuse"), ((0, 1, 0), 1, "glass"),
               ((4, 1, 0), 1, "big_mirror")]
SKY_RADIUS = 10000
N_DIFFUSE, N_MIRROR = 48, 8


def sphere_materials():
    rng = Rng(10, 0)
    m = {"ground": {"kd": [0.5, 0.5, 0.5]}, "sky": {"emission": [1, 1, 1]},
         "glass": {"kt": [0.95, 0.95, 0.95], "ior": 1.5},
         "big_diffuse": {"kd": [0.4, 0.2, 0.1]}, "big_mirror": {"kr": [0.7, 0.6, 0.5]}}
    for i in range(N_DIFFUSE):
        m[f"d{i}"] = {"kd": [round(rng.random() * rng.random(), 3) for _ in range(3)]}
    for i in range(N_MIRROR):
        m[f"m{i}"] = {"kr": [round(0.5 + 0.5 * rng.random(), 3) for _ in range(3)]}
    return m


def cell_sphere(a, b):
    """The sphere of grid cell (a, b): inside the cell [a, a+1] x [b, b+1], on the ground."""
    rng = Rng(10, a, b)
    radius = rng.uniform(0.16, 0.24)
    room = 0.5 - radius
    x = a + 0.5 + rng.uniform(-room, room)
    z = b + 0.5 + rng.uniform(-room, room)
    pick = rng.random()
    if pick < 0.8:
        material = f"d{rng.below(N_DIFFUSE)}"
    elif pick < 0.95:
        material = f"m{rng.below(N_MIRROR)}"
    else:
        material = "glass"
    return (x, radius, z), radius, material


def clear_of_big_spheres(c, r):
    return all(math.dist(c, bc) > br + r + 0.05 for bc, br, _ in BIG_SPHERES)


def sphere_cells(n):
    """The first n usable cells by distance of their centre from SPHERE_FOCUS."""
    fx, fz = SPHERE_FOCUS
    reach = math.sqrt(n / math.pi) + 4
    while True:
        lo_a, hi_a = math.floor(fx - reach), math.ceil(fx + reach)
        lo_b, hi_b = math.floor(fz - reach), math.ceil(fz + reach)
        cells = [((a + 0.5 - fx) ** 2 + (b + 0.5 - fz) ** 2, a, b)
                 for a in range(lo_a, hi_a) for b in range(lo_b, hi_b)]
        cells = [c for c in cells if c[0] <= reach * reach]
        cells.sort()
        chosen = []
        for _, a, b in cells:
            sphere = cell_sphere(a, b)
            if clear_of_big_spheres(sphere[0], sphere[1]):
                chosen.append(sphere)
                if len(chosen) == n:
                    return chosen, math.sqrt(cells[-1][0])
        reach *= 1.5


def make_spheres(name, out, n):
    spheres, reach = sphere_cells(n)
    assert reach + abs(SPHERE_FOCUS[0]) + abs(SPHERE_FOCUS[1]) < SKY_RADIUS / 2, "too many spheres"
    objects = [{"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "ground"},
               {"type": "sphere", "center": [0, 0, 0], "radius": SKY_RADIUS, "material": "sky"}]
    for c, r, mat in BIG_SPHERES:
        objects.append({"type": "sphere", "center": list(c), "radius": r, "material": mat})
    for c, r, mat in spheres:
        objects.append({"type": "sphere", "center": list(c), "radius": round(r, 5),
                        "material": mat})
    counts = {"diffuse": 0, "mirror": 0, "glass": 0}
    for _, _, mat in spheres:
        counts["diffuse" if mat[0] == "d" else "mirror" if mat[0] == "m" else "glass"] += 1
    header = [
        f"{name}.json: after the final scene of Ray Tracing in One Weekend, with {n:,} small "
        "spheres.",
        f"A ground plane (y = 0); {n:,} spheres of radius 0.16-0.24 on a jittered grid of "
        "spacing 1, one per cell",
        f"(never overlapping): {counts['diffuse']} diffuse, {counts['mirror']} mirror, "
        f"{counts['glass']} glass (ior 1.5); three big spheres of radius 1 (diffuse,",
        f"glass, mirror); one emitter, a sky sphere of radius {SKY_RADIUS} around everything "
        "(emission 1).",
        "Cells are taken nearest first from a ground point in the foreground, and each cell's "
        "sphere is the",
        "same in every N: spheres_10 is the ten spheres of spheres_10000 nearest that point, "
        "under the same camera.",
        f"{len(objects)} objects: 1 plane and {len(objects) - 1} spheres; no triangles.",
        f"Made by: {command(name, out)}"]
    text = scene_text(header, {"width": 500, "height": 500, "spp": 16, "seed": 1},
                      SPHERE_CAMERA, sphere_materials(), objects)
    write_atomic(Path(out) / f"{name}.json", text.encode())
    return {"objects": len(objects), "triangles": 0, "files": [f"{name}.json"]}


# ---- Names ---------------------------------------------------------------------------


def count_name(n):
    if n % 1_000_000 == 0:
        return f"{n // 1_000_000}m"
    if n % 1000 == 0:
        return f"{n // 1000}k"
    return str(n)


def parse_count(text):
    m = re.fullmatch(r"(\d+)([km]?)", text)
    if not m:
        return None
    return int(m.group(1)) * {"": 1, "k": 1000, "m": 1_000_000}[m.group(2)]


MAX_SPHERES = 10_000_000
MAX_TRIANGLES = 100_000_000

CATALOGUE = [
    # name, in the default set, description
    ("spheres_10", True, "RTIOW-style field, 10 small spheres + 3 big, sky-sphere emitter"),
    ("spheres_1000", True, "the same with 1,000 small spheres"),
    ("spheres_10000", True, "the same with 10,000 small spheres"),
    ("mesh_200k", True, "open box + one 200,000-triangle torus knot mesh"),
    ("instances_100", True, "open box + 100 transformed instances of one 12,000-triangle knot"),
    ("mesh_1m", True, "open box + one 1,000,000-triangle knot (BVH build benchmark)"),
    ("sticks_100k", True, "open box + 50,000 straws: 100,000 long thin triangles of random "
                          "direction (spatial splits)"),
    ("box", False, "open box of 10 triangles; committed as scenes/box.json "
                   "(--only box --out scenes)"),
]


def resolve(name):
    """(canonical name, function of out) for a scene name, or None."""
    if name == "box":
        return name, lambda out: make_box(name, out)
    if name == "instances_100":
        return name, lambda out: make_instances(name, out)
    if name == "sticks_100k":
        return name, lambda out: make_sticks(name, out)
    m = re.fullmatch(r"spheres_(\w+)", name)
    if m:
        n = parse_count(m.group(1))
        if n is not None and 1 <= n <= MAX_SPHERES:
            return f"spheres_{n}", lambda out: make_spheres(f"spheres_{n}", out, n)
    m = re.fullmatch(r"mesh_(\w+)", name)
    if m:
        n = parse_count(m.group(1))
        if n is not None and 1000 <= n <= MAX_TRIANGLES:
            canon = f"mesh_{count_name(n)}"
            return canon, lambda out: make_mesh(canon, out, n)
    return None


def count_arg(text):
    n = parse_count(text.strip().lower())
    if n is None:
        raise argparse.ArgumentTypeError(f"'{text}' is not a count (e.g. 5000, 250k, 2m)")
    return n


def main():
    parser = argparse.ArgumentParser(
        description="Write cierzo's large benchmark scenes (deterministic; the same bytes "
                    "every run).",
        epilog="Names: " + ", ".join(n for n, _, _ in CATALOGUE) +
               f"; also spheres_N (1 <= N <= {MAX_SPHERES:,}) and mesh_N "
               f"(1000 <= N <= {MAX_TRIANGLES:,}; N may end in k or m). "
               "Without --only, --spheres or --triangles the default set is written.")
    parser.add_argument("--out", default=str(DEFAULT_OUT),
                        help="folder to write into (default: scenes/generated in the repository)")
    parser.add_argument("--only", metavar="NAME[,NAME]",
                        help="write only these scenes (see --list)")
    parser.add_argument("--spheres", type=count_arg, action="append", default=[], metavar="N",
                        help="write spheres_N.json with N small spheres (repeatable; adds to --only)")
    parser.add_argument("--triangles", type=count_arg, action="append", default=[], metavar="N",
                        help="write mesh_N.json + .ply with a knot of about N triangles "
                             "(repeatable; adds to --only)")
    parser.add_argument("--list", action="store_true",
                        help="list the scenes and which are in the default set, and exit")
    args = parser.parse_args()

    if args.list:
        for name, default, what in CATALOGUE:
            print(f"{name:15} {'default' if default else '       '}  {what}")
        print(f"{'spheres_N':15} {'':7}  --spheres N: the sphere field with N small spheres")
        print(f"{'mesh_N':15} {'':7}  --triangles N: the knot scene with about N triangles")
        return 0

    names = []
    if args.only:
        names += [n.strip() for n in args.only.split(",") if n.strip()]
    names += [f"spheres_{n}" for n in args.spheres]
    names += [f"mesh_{n}" for n in args.triangles]
    if not names:
        names = [n for n, default, _ in CATALOGUE if default]
    jobs = {}
    for name in names:
        r = resolve(name)
        if r is None:
            parser.error(f"unknown scene '{name}' (see --list)")
        jobs.setdefault(r[0], r[1])

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.perf_counter()
    for name, make in jobs.items():
        t0 = time.perf_counter()
        info = make(out)
        files = info.get("files", [f"{name}.json"])
        size = sum((out / f).stat().st_size for f in files)
        print(f"{name:15} {info['objects']:7,} objects {info['triangles']:11,} triangles "
              f"{size / 1e6:8.2f} MB  {time.perf_counter() - t0:5.2f} s  "
              + " ".join(str(out / f) for f in files))
    print(f"{len(jobs)} scene(s) in {time.perf_counter() - start:.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
