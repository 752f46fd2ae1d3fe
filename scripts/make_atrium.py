#!/usr/bin/env python3
"""Writes `atrium`, a benchmark scene after Crytek Sponza, into scenes/generated/atrium/.

A courtyard open to the sky with two stories of fluted columns and arches on its long sides,
brick and plaster walls, wooden beams, twelve draped banners and ten potted plants whose
leaves are alpha-masked quads, lit by an equirectangular HDR sky with a sun: the kind of
OBJ + MTL scene researchers download (262,000 triangles in Sponza; about 300,000 here), made
from fixed formulas in a few seconds with the Python 3 standard library only, so every
machine renders the same bytes.

    python3 scripts/make_atrium.py                 # into scenes/generated/atrium/
    python3 scripts/make_atrium.py --out DIR
    build/cierzo render scenes/generated/atrium/atrium.json

What it writes:

- `atrium.obj` (v, vt, f; one `usemtl` group per material) and `atrium.mtl` (Kd, Ks, Ns,
  map_Kd on every material, map_d on the two kinds of leaves);
- `textures/`: 22 images of 256 x 256 texels (128 x 128 for the leaves): 20 PNG (8-bit
  sRGB colour, one grey mask) and 2 TGA (one with the leaf's alpha channel), procedural
  patterns from fixed formulas;
- `sky.hdr`: a 256 x 128 Radiance HDR equirectangular sky (blue above, a sun of radiance
  2000 at 50 degrees elevation, brown ground below the horizon);
- `atrium.json`: the OBJ with its own materials under that sky, a right-handed camera
  looking down the courtyard as Sponza's classic view, 640 x 360, 16 paths per pixel;
- `atrium_flat.json`: the same with every colour texture replaced by its mean colour (the
  leaves keep their masks), to measure what the textures cost;
- `atrium_plain.json`: the same without textures and without masks (opaque leaf quads).
"""

import argparse
import json
import math
import os
import struct
import sys
import time
import zlib
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_OUT = REPO / "scenes" / "generated" / "atrium"

# ---- Images --------------------------------------------------------------------------


def srgb_decode(b):
    c = b / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


DECODED = [srgb_decode(b) for b in range(256)]
# The byte whose decoded value is nearest to x, for x on a grid of 1/65536
_THRESHOLDS = [0.5 * (DECODED[b] + DECODED[b + 1]) for b in range(255)]
ENCODE = [0] * 65537
_b = 0
for _i in range(65537):
    while _b < 255 and _i / 65536.0 > _THRESHOLDS[_b]:
        _b += 1
    ENCODE[_i] = _b


def srgb_encode(x):
    return ENCODE[int(min(max(x, 0.0), 1.0) * 65536.0 + 0.5)]


def png_bytes(w, h, rows, channels):
    """An 8-bit PNG (grey, RGB or RGBA) from rows of bytes."""
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data +
                struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    colour = {1: 0, 3: 2, 4: 6}[channels]
    raw = b"".join(b"\x00" + bytes(r) for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def tga_bytes(w, h, rows, channels):
    """An uncompressed 24- or 32-bit TGA, rows from the top (BGR(A) order)."""
    header = bytearray(18)
    header[2] = 2
    header[12:14] = struct.pack("<H", w)
    header[14:16] = struct.pack("<H", h)
    header[16] = 8 * channels
    header[17] = 0x20 | (8 if channels == 4 else 0)
    out = bytearray(header)
    for r in rows:
        for x in range(w):
            p = r[channels * x:channels * x + channels]
            out += bytes((p[2], p[1], p[0])) + (bytes((p[3],)) if channels == 4 else b"")
    return bytes(out)


def hdr_bytes(w, h, pixel):
    """A Radiance HDR of flat (not run-length encoded) RGBE scanlines, top row first."""
    out = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode())
    for y in range(h):
        for x in range(w):
            r, g, b = pixel(x, y)
            m = max(r, g, b)
            if m < 1e-32:
                out += b"\0\0\0\0"
                continue
            mant, e = math.frexp(m)
            s = mant * 256.0 / m
            out += bytes((int(r * s), int(g * s), int(b * s), e + 128))
    return bytes(out)


def hash2(x, y, seed):
    h = (x * 374761393 + y * 668265263 + seed * 2246822519) & 0xFFFFFFFF
    h = ((h ^ (h >> 13)) * 1274126177) & 0xFFFFFFFF
    return ((h ^ (h >> 16)) & 0xFFFF) / 65535.0


LATTICES = {}


def value_noise(u, v, cells, seed):
    """Smooth noise in [0, 1], tiling with period 1 in u and v."""
    lat = LATTICES.get((cells, seed))
    if lat is None:
        lat = [[hash2(i % cells, j % cells, seed) for j in range(cells + 1)]
               for i in range(cells + 1)]
        LATTICES[(cells, seed)] = lat
    x, y = (u % 1.0) * cells, (v % 1.0) * cells
    x0, y0 = int(x), int(y)
    fx, fy = x - x0, y - y0
    fx, fy = fx * fx * (3 - 2 * fx), fy * fy * (3 - 2 * fy)
    c0, c1 = lat[x0], lat[x0 + 1]
    a = c0[y0] + (c1[y0] - c0[y0]) * fx
    b = c0[y0 + 1] + (c1[y0 + 1] - c0[y0 + 1]) * fx
    return a + (b - a) * fy


def fbm(u, v, seed, octaves=3, cells=4):
    total, amp, norm = 0.0, 1.0, 0.0
    for o in range(octaves):
        total += amp * value_noise(u, v, cells << o, seed + o)
        norm += amp
        amp *= 0.5
    return total / norm


def mix(a, b, t):
    return tuple(a[i] + (b[i] - a[i]) * t for i in range(3))


# Each texture: a function of (u, v) in [0, 1)² giving linear RGB (and alpha for the masks).

def bricks(base, mortar, rows, cols, seed):
    def f(u, v):
        row = int(v * rows)
        shift = 0.5 if row % 2 else 0.0
        bu = (u * cols + shift) % 1.0
        bv = (v * rows) % 1.0
        n = fbm(u, v, seed, 2, 8)
        if bu < 0.06 or bv < 0.08:
            return mix(mortar, (mortar[0] * 0.8, mortar[1] * 0.8, mortar[2] * 0.8), n)
        tone = 0.75 + 0.5 * hash2(int(u * cols + shift), row, seed)
        return tuple(c * tone * (0.85 + 0.3 * n) for c in base)
    return f


def stone(a, b, seed, cells=4):
    return lambda u, v: mix(a, b, fbm(u, v, seed, 4, cells))


def marble(a, b, seed):
    def f(u, v):
        t = 0.5 + 0.5 * math.sin(2 * math.pi * (u + v) * 2 + 6.0 * fbm(u, v, seed, 4, 4))
        return mix(a, b, t ** 3)
    return f


def tiles(a, b, seed):
    def f(u, v):
        i, j = int(u * 4), int(v * 4)
        cu, cv = (u * 4) % 1.0, (v * 4) % 1.0
        if cu < 0.04 or cv < 0.04:
            return (0.05, 0.05, 0.05)
        c = a if (i + j) % 2 == 0 else b
        n = fbm(u, v, seed, 3, 8)
        return tuple(x * (0.8 + 0.4 * n) for x in c)
    return f


def fabric(colour, trim, seed):
    def f(u, v):
        weave = 0.9 + 0.1 * math.sin(2 * math.pi * u * 64) * math.sin(2 * math.pi * v * 64)
        band = v < 0.08 or v > 0.92 or abs(u - 0.5) < 0.03
        c = trim if band else colour
        emblem = (u - 0.5) ** 2 + (v - 0.45) ** 2 < 0.02
        if emblem:
            c = trim
        return tuple(x * weave * (0.9 + 0.2 * fbm(u, v, seed, 2, 4)) for x in c)
    return f


def wood(a, b, seed):
    def f(u, v):
        t = 0.5 + 0.5 * math.sin(2 * math.pi * (v * 12 + 2.0 * fbm(u, v, seed, 3, 4)))
        return mix(a, b, t)
    return f


def leaf_shape(u, v, lobes):
    """Coverage of a leaf (or a fern frond) in the unit square: 1 inside, 0 outside."""
    x, y = u - 0.5, v
    if lobes == 0:  # a broad leaf: an almond about the midrib
        half = 0.42 * math.sin(math.pi * min(max(y, 0.0), 1.0)) ** 0.8
        return 1.0 if abs(x) < half and 0.02 < y < 0.98 else 0.0
    # a frond: leaflets along the stem, narrowing to the tip
    if abs(x) < 0.03:
        return 1.0
    width = 0.45 * (1.0 - y)
    leaflet = 0.5 + 0.5 * math.cos(2 * math.pi * (y * lobes + abs(x) * 1.5))
    return 1.0 if abs(x) < width * leaflet else 0.0


TEXTURES = {
    # name: (format, size, function, kind) — kind "colour", "rgba" (colour and alpha), "mask"
    "floor_tiles": ("png", 256, tiles((0.45, 0.38, 0.30), (0.30, 0.24, 0.18), 1), "colour"),
    "marble": ("png", 256, marble((0.70, 0.68, 0.62), (0.35, 0.33, 0.30), 2), "colour"),
    "column_stone": ("png", 256, stone((0.55, 0.50, 0.42), (0.40, 0.36, 0.30), 3), "colour"),
    "arch_brick": ("png", 256, bricks((0.50, 0.25, 0.15), (0.55, 0.52, 0.45), 8, 4, 4), "colour"),
    "gallery_stone": ("png", 256, stone((0.50, 0.47, 0.40), (0.30, 0.28, 0.24), 5, 8), "colour"),
    "wall_brick": ("png", 256, bricks((0.45, 0.22, 0.12), (0.50, 0.48, 0.42), 16, 6, 6), "colour"),
    "wall_plaster": ("png", 256, stone((0.72, 0.66, 0.55), (0.60, 0.54, 0.44), 7, 2), "colour"),
    "upper_plaster": ("png", 256, stone((0.65, 0.62, 0.58), (0.52, 0.50, 0.46), 8, 3), "colour"),
    "banner_red": ("png", 256, fabric((0.55, 0.05, 0.04), (0.70, 0.55, 0.10), 9), "colour"),
    "banner_blue": ("png", 256, fabric((0.05, 0.10, 0.45), (0.70, 0.55, 0.10), 10), "colour"),
    "banner_green": ("png", 256, fabric((0.05, 0.35, 0.08), (0.60, 0.60, 0.55), 11), "colour"),
    "banner_gold": ("png", 256, fabric((0.60, 0.42, 0.05), (0.20, 0.05, 0.03), 12), "colour"),
    "banner_purple": ("png", 256, fabric((0.30, 0.05, 0.35), (0.70, 0.55, 0.10), 13), "colour"),
    "banner_teal": ("png", 256, fabric((0.03, 0.35, 0.35), (0.60, 0.60, 0.55), 14), "colour"),
    "pot_terracotta": ("png", 256, stone((0.55, 0.22, 0.10), (0.40, 0.15, 0.07), 15, 4), "colour"),
    "soil": ("png", 256, stone((0.12, 0.08, 0.05), (0.06, 0.04, 0.03), 16, 16), "colour"),
    "wood_beam": ("png", 256, wood((0.35, 0.20, 0.10), (0.20, 0.11, 0.05), 17), "colour"),
    "trim_stone": ("png", 256, stone((0.62, 0.60, 0.55), (0.45, 0.43, 0.40), 18, 6), "colour"),
    "roof_tiles": ("tga", 256, bricks((0.45, 0.15, 0.08), (0.25, 0.10, 0.05), 12, 8, 19), "colour"),
    "fern": ("png", 128, lambda u, v: mix((0.05, 0.25, 0.04), (0.15, 0.45, 0.08), v), "colour"),
    "fern_mask": ("png", 128, lambda u, v: leaf_shape(u, v, 7), "mask"),
    "leaf": ("tga", 128, lambda u, v: (mix((0.04, 0.30, 0.05), (0.20, 0.50, 0.10),
                                           fbm(u, v, 20, 2, 4)), leaf_shape(u, v, 0)), "rgba"),
}


def write_textures(folder):
    """Writes every texture; returns each one's mean linear colour (as cierzo decodes it)."""
    folder.mkdir(parents=True, exist_ok=True)
    means = {}
    for name, (fmt, n, f, kind) in TEXTURES.items():
        channels = {"colour": 3, "rgba": 4, "mask": 1}[kind]
        rows, total = [], [0.0, 0.0, 0.0]
        for y in range(n):
            row = bytearray()
            v = 1.0 - (y + 0.5) / n  # (the first row is the top, v = 1)
            for x in range(n):
                u = (x + 0.5) / n
                value = f(u, v)
                if kind == "mask":
                    row.append(int(round(255 * value)))
                    continue
                rgb, alpha = (value[0], value[1]) if kind == "rgba" else (value, 1.0)
                b = [srgb_encode(c) for c in rgb]
                for i in range(3):
                    total[i] += DECODED[b[i]]
                row += bytes(b)
                if kind == "rgba":
                    row.append(int(round(255 * alpha)))
            rows.append(row)
        data = png_bytes(n, n, rows, channels) if fmt == "png" else tga_bytes(n, n, rows, channels)
        (folder / f"{name}.{fmt}").write_bytes(data)
        means[name] = [t / (n * n) for t in total]
    return means


def sky(x, y, w, h):
    """The sky's radiance in direction of texel (x, y): u across, theta down from +y."""
    theta = math.pi * (y + 0.5) / h
    phi = 2 * math.pi * ((x + 0.5) / w - 0.5)
    d = (math.sin(theta) * math.sin(phi), math.cos(theta), math.sin(theta) * math.cos(phi))
    sun_el, sun_az = math.radians(50), math.radians(35)
    s = (math.cos(sun_el) * math.sin(sun_az), math.sin(sun_el), math.cos(sun_el) * math.cos(sun_az))
    cos_sun = sum(a * b for a, b in zip(d, s))
    if cos_sun > math.cos(math.radians(2.0)):
        return (2000.0, 1900.0, 1700.0)
    if d[1] < 0:
        return (0.25, 0.20, 0.15)
    t = d[1]
    glow = 2.0 * max(cos_sun, 0.0) ** 8
    return (0.9 - 0.6 * t + glow, 1.1 - 0.5 * t + glow * 0.9, 1.6 - 0.3 * t + glow * 0.7)


# ---- Geometry ------------------------------------------------------------------------


class Obj:
    def __init__(self):
        self.v, self.vt = [], []
        self.groups = {}  # material -> list of (a, b, c) vertex indices (1-based)

    def vertex(self, p, uv):
        self.v.append(p)
        self.vt.append(uv)
        return len(self.v)

    def tri(self, material, a, b, c):
        self.groups.setdefault(material, []).append((a, b, c))

    def quad(self, material, a, b, c, d):
        self.tri(material, a, b, c)
        self.tri(material, a, c, d)

    def grid(self, material, corner, du, dv, nu, nv, uv_scale=(1.0, 1.0), warp=None):
        """A parallelogram of nu x nv quads: corner + s du + t dv, s, t in [0, 1]."""
        idx = []
        for j in range(nv + 1):
            for i in range(nu + 1):
                s, t = i / nu, j / nv
                p = [corner[k] + s * du[k] + t * dv[k] for k in range(3)]
                if warp:
                    p = warp(p, s, t)
                idx.append(self.vertex(p, (s * uv_scale[0], t * uv_scale[1])))
        for j in range(nv):
            for i in range(nu):
                a = idx[j * (nu + 1) + i]
                self.quad(material, a, a + 1, a + nu + 2, a + nu + 1)

    def box(self, material, lo, hi, uv_per_unit=0.5):
        x0, y0, z0 = lo
        x1, y1, z1 = hi
        faces = [
            ((x0, y0, z1), (x1 - x0, 0, 0), (0, y1 - y0, 0)),
            ((x1, y0, z0), (x0 - x1, 0, 0), (0, y1 - y0, 0)),
            ((x0, y0, z0), (0, 0, z1 - z0), (0, y1 - y0, 0)),
            ((x1, y0, z1), (0, 0, z0 - z1), (0, y1 - y0, 0)),
            ((x0, y1, z1), (x1 - x0, 0, 0), (0, 0, z0 - z1)),
            ((x0, y0, z0), (x1 - x0, 0, 0), (0, 0, z1 - z0)),
        ]
        for c, du, dv in faces:
            lu = math.sqrt(sum(x * x for x in du))
            lv = math.sqrt(sum(x * x for x in dv))
            self.grid(material, c, du, dv, 1, 1, (lu * uv_per_unit, lv * uv_per_unit))

    def lathe(self, material, centre, profile, segments, u_repeat=2.0, flutes=0):
        """A surface of revolution about +y: profile [(y, r)], `flutes` grooves."""
        cx, cy, cz = centre
        rings = []
        length = 0.0
        for k, (y, r) in enumerate(profile):
            if k:
                length += math.hypot(y - profile[k - 1][0], r - profile[k - 1][1])
            row = []
            for i in range(segments + 1):
                a = 2 * math.pi * i / segments
                rr = r * (1.0 + (0.035 * math.cos(flutes * a) if flutes else 0.0))
                row.append(self.vertex((cx + rr * math.sin(a), cy + y, cz + rr * math.cos(a)),
                                       (u_repeat * i / segments, length)))
            rings.append(row)
        for k in range(len(rings) - 1):
            for i in range(segments):
                a, b = rings[k][i], rings[k][i + 1]
                c, d = rings[k + 1][i + 1], rings[k + 1][i]
                self.quad(material, a, b, c, d)

    def text(self, mtllib):
        out = [f"# atrium: {len(self.v)} vertices, "
               f"{sum(len(g) for g in self.groups.values())} triangles (scripts/make_atrium.py)",
               f"mtllib {mtllib}"]
        f5 = lambda x: f"{x:.5f}".rstrip("0").rstrip(".")
        out += [f"v {f5(p[0])} {f5(p[1])} {f5(p[2])}" for p in self.v]
        out += [f"vt {f5(t[0])} {f5(t[1])}" for t in self.vt]
        for m, faces in self.groups.items():
            out.append(f"usemtl {m}")
            out += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in faces]
        return "\n".join(out) + "\n"


def column_profile(height, radius, rings):
    """A column's (y, r): a flared base, a fluted shaft with entasis, a capital."""
    prof = []
    for k in range(rings + 1):
        t = k / rings
        y = t * height
        if t < 0.06:
            r = radius * (1.45 - 0.45 * (t / 0.06) ** 0.5)
        elif t > 0.9:
            r = radius * (1.0 + 0.6 * ((t - 0.9) / 0.1) ** 2)
        else:
            r = radius * (1.0 + 0.06 * math.sin(math.pi * (t - 0.06) / 0.84))
        prof.append((y, r))
    return prof


def build(rng_seed=1):
    o = Obj()
    X, Z, H = 15.0, 6.0, 11.0  # half length, half width, wall height
    # Floor and walls
    o.grid("floor", (-X, 0, -Z), (2 * X, 0, 0), (0, 0, 2 * Z), 60, 24, (X, Z))
    for side in (-1, 1):
        z = side * Z
        o.grid("wall_brick", (-X, 0, z), (2 * X, 0, 0), (0, 5.5, 0), 30, 6, (6, 1.5))
        o.grid("upper_plaster", (-X, 5.5, z), (2 * X, 0, 0), (0, H - 5.5, 0), 30, 6, (5, 1.2))
        x = side * X
        o.grid("wall_plaster", (x, 0, -Z), (0, 0, 2 * Z), (0, H, 0), 12, 11, (3, 3))
        # Trim ledges along the walls, and the roof's edge
        o.box("trim", (-X, 5.4, z - 0.15 if side > 0 else z), (X, 5.6, z if side > 0 else z + 0.15))
        o.box("roof", (-X, H, z - 0.6 if side > 0 else z), (X, H + 0.3, z if side > 0 else z + 0.6))
    # Arcades: two stories of columns and arches on each long side, galleries between
    cols = [-13.5 + 3.0 * k for k in range(10)]
    for side in (-1, 1):
        zc = side * 4.0
        for story, (y0, h, mat, arch_mat) in enumerate(((0.0, 4.2, "marble", "arch"),
                                                        (6.0, 3.4, "column", "arch"))):
            for x in cols:
                o.lathe(mat, (x, y0, zc), column_profile(h, 0.32, 47), 64, 2.0, 16)
            # Arches between neighbouring columns: a band swept along a half circle
            for a, b in zip(cols, cols[1:]):
                xc, r0, r1 = 0.5 * (a + b), 1.1, 1.45
                yb = y0 + h
                n = 24
                for face in range(4):
                    ring = []
                    for i in range(n + 1):
                        t = math.pi * i / n
                        pts = []
                        for (r, dz) in (((r0, -0.3), (r1, -0.3)), ((r1, -0.3), (r1, 0.3)),
                                        ((r1, 0.3), (r0, 0.3)), ((r0, 0.3), (r0, -0.3)))[face]:
                            pts.append((xc - r * math.cos(t), yb + r * math.sin(t), zc + dz))
                        ring.append((o.vertex(pts[0], (i / n * 2, 0)), o.vertex(pts[1], (i / n * 2, 0.3))))
                    for i in range(n):
                        o.quad(arch_mat, ring[i][0], ring[i + 1][0], ring[i + 1][1], ring[i][1])
            # The gallery floor (a slab from the arcade to the wall) and its beams
            if story == 0:
                lo_z, hi_z = (zc - 0.4, Z) if side > 0 else (-Z, zc + 0.4)
                o.box("gallery", (-X, 5.5, lo_z), (X, 6.0, hi_z))
                for x in cols:
                    o.box("beam", (x - 0.15, 5.2, lo_z), (x + 0.15, 5.5, hi_z))
    # Banners hanging from the upper gallery, draped
    fabrics = ["banner_red", "banner_blue", "banner_green", "banner_gold", "banner_purple",
               "banner_teal"]
    k = 0
    for side in (-1, 1):
        for i in range(6):
            x = -11.25 + 4.5 * i
            zb = side * 3.55
            def drape(p, s, t, phase=i * 0.7):
                p[2] += side * 0.12 * math.sin(math.pi * s * 3 + phase) * (1 - t) * 0.6
                return p
            o.grid(fabrics[k % 6], (x - 0.6, 1.8, zb), (1.2, 0, 0), (0, 3.8, 0), 12, 40,
                   (1, 1), drape)
            k += 1
    # Potted plants along the middle: a pot, its soil, and leaves (alpha-masked quads)
    seed = rng_seed
    for i in range(10):
        px, pz = -12.0 + 2.65 * i, (1.3 if i % 2 else -1.3)
        prof = [(0.0, 0.25), (0.05, 0.30), (0.6, 0.42), (0.7, 0.47), (0.75, 0.45), (0.72, 0.40)]
        o.lathe("pot", (px, 0, pz), prof, 32, 2.0)
        o.lathe("soil", (px, 0.66, pz), [(0.0, 0.41), (0.0, 0.0)], 32, 1.0)
        leaf_mat = "leaf" if i % 2 == 0 else "fern"
        for j in range(120):
            seed += 1
            a = 2 * math.pi * hash2(j, i, seed)
            tilt = 0.3 + 1.0 * hash2(j, i, seed + 7)
            length = 0.55 + 0.35 * hash2(j, i, seed + 11)
            width = length * (0.5 if leaf_mat == "leaf" else 0.6)
            base_y = 0.7 + 0.9 * hash2(j, i, seed + 13)
            r0 = 0.05 + 0.15 * hash2(j, i, seed + 17)
            dx, dz = math.sin(a), math.cos(a)
            b = (px + r0 * dx, base_y, pz + r0 * dz)
            up = (dx * math.sin(tilt) * length, math.cos(tilt) * length, dz * math.sin(tilt) * length)
            side_v = (dz * width * 0.5, 0.0, -dx * width * 0.5)
            c0 = o.vertex((b[0] - side_v[0], b[1], b[2] - side_v[2]), (0, 0))
            c1 = o.vertex((b[0] + side_v[0], b[1], b[2] + side_v[2]), (1, 0))
            c2 = o.vertex((b[0] + side_v[0] + up[0], b[1] + up[1], b[2] + side_v[2] + up[2]), (1, 1))
            c3 = o.vertex((b[0] - side_v[0] + up[0], b[1] + up[1], b[2] - side_v[2] + up[2]), (0, 1))
            o.quad(leaf_mat, c0, c1, c2, c3)
    return o


MATERIALS = {
    # name: (texture, Ks, Ns, mask)
    "floor": ("floor_tiles", 0.04, 30, None),
    "marble": ("marble", 0.08, 80, None),
    "column": ("column_stone", 0.0, 0, None),
    "arch": ("arch_brick", 0.0, 0, None),
    "gallery": ("gallery_stone", 0.0, 0, None),
    "wall_brick": ("wall_brick", 0.0, 0, None),
    "wall_plaster": ("wall_plaster", 0.0, 0, None),
    "upper_plaster": ("upper_plaster", 0.0, 0, None),
    "trim": ("trim_stone", 0.02, 20, None),
    "roof": ("roof_tiles", 0.0, 0, None),
    "beam": ("wood_beam", 0.05, 25, None),
    "pot": ("pot_terracotta", 0.02, 15, None),
    "soil": ("soil", 0.0, 0, None),
    "leaf": ("leaf", 0.06, 40, "leaf.tga"),
    "fern": ("fern", 0.04, 30, "fern_mask.png"),
    "banner_red": ("banner_red", 0.0, 0, None),
    "banner_blue": ("banner_blue", 0.0, 0, None),
    "banner_green": ("banner_green", 0.0, 0, None),
    "banner_gold": ("banner_gold", 0.0, 0, None),
    "banner_purple": ("banner_purple", 0.0, 0, None),
    "banner_teal": ("banner_teal", 0.0, 0, None),
}


def mtl_text():
    out = ["# atrium materials (scripts/make_atrium.py): the report's Phong model"]
    for name, (tex, ks, ns, mask) in MATERIALS.items():
        fmt = TEXTURES[tex][0]
        out += [f"newmtl {name}", "Kd 1 1 1", f"Ks {ks} {ks} {ks}", f"Ns {ns}",
                "illum 2" if ks > 0 else "illum 1", f"map_Kd textures/{tex}.{fmt}"]
        if mask:
            out.append(f"map_d textures/{mask}")
        out.append("")
    return "\n".join(out)


def scene_json(overrides=None):
    s = {
        "render": {"width": 640, "height": 360, "spp": 16, "seed": 1},
        "camera": {"position": [-12.5, 1.7, 0.2], "look_at": [0, 3.4, 0], "vfov": 60,
                   "handedness": "right"},
        "environment": {"emission": {"texture": "image", "file": "sky.hdr"}},
        "objects": [{"type": "mesh", "file": "atrium.obj"}],
    }
    if overrides:
        s["objects"][0]["materials"] = overrides
    return json.dumps(s, indent=2) + "\n"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=str(DEFAULT_OUT), help="folder (default: %(default)s)")
    args = parser.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    start = time.time()
    means = write_textures(out / "textures")
    t_tex = time.time() - start
    sky_w, sky_h = 256, 128
    (out / "sky.hdr").write_bytes(hdr_bytes(sky_w, sky_h, lambda x, y: sky(x, y, sky_w, sky_h)))
    o = build()
    (out / "atrium.obj").write_text(o.text("atrium.mtl"))
    (out / "atrium.mtl").write_text(mtl_text())
    flat, plain = {}, {}
    for name, (tex, ks, ns, mask) in MATERIALS.items():
        m = {"kd": [round(c, 5) for c in means[tex]]}
        if ks > 0:
            m.update({"ks": ks, "shininess": ns})
        plain[name] = dict(m)
        if mask:
            m["alpha"] = {"texture": "image", "file": f"textures/{mask}"}
        flat[name] = m
    (out / "atrium.json").write_text(scene_json())
    (out / "atrium_flat.json").write_text(scene_json(flat))
    (out / "atrium_plain.json").write_text(scene_json(plain))
    triangles = sum(len(g) for g in o.groups.values())
    print(f"{out}: {triangles} triangles, {len(TEXTURES)} textures ({t_tex:.1f} s), "
          f"{time.time() - start:.1f} s in all")


if __name__ == "__main__":
    sys.exit(main())
