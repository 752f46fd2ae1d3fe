#!/usr/bin/env python3
"""Writes a scene file of N spheres, to measure how the JSON reader scales with file size.

    python3 bench/big_json_scene.py 1000000 /tmp/spheres_1m.json    # about 130 MB
    /usr/bin/time -v build/cierzo render /tmp/spheres_1m.json --spp 1 --width 8 --height 8 \
        --out /tmp/s.exr --stats /tmp/s.json

Spheres on a jittered grid on the ground, one per cell (none overlapping), with materials
that vary: three in four name one of 64 materials in "materials", one in four carries its own
inline material (diffuse, mirror or glass, some with a texture object), so the file holds a
long array of objects that themselves hold objects and arrays. Fixed seed: the same N gives
the same bytes. Python 3 standard library only.
"""

import random
import sys

N_NAMED = 64


def num(x):
    return f"{x:.5f}".rstrip("0").rstrip(".")


def rgb(rng, lo, hi):
    return "[" + ", ".join(num(rng.uniform(lo, hi)) for _ in range(3)) + "]"


def inline_material(rng):
    pick = rng.random()
    if pick < 0.6:
        return '{"kd": ' + rgb(rng, 0.05, 0.9) + "}"
    if pick < 0.8:
        return ('{"kd": {"texture": "sin", "a": ' + rgb(rng, 0.1, 0.9) + ', "b": ' +
                rgb(rng, 0.1, 0.9) + ', "frequency": ' + num(rng.uniform(1, 8)) + "}}")
    if pick < 0.95:
        return '{"kr": ' + rgb(rng, 0.5, 1.0) + "}"
    return '{"kt": [0.95, 0.95, 0.95], "ior": 1.5}'


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: big_json_scene.py N OUT.json")
    n, out = int(sys.argv[1]), sys.argv[2]
    rng = random.Random(24)
    side = max(1, int(n ** 0.5 + 0.999))
    lines = [f"// {n} spheres for measuring the scene reader: python3 bench/big_json_scene.py {n} OUT",
             "{",
             '  "render": {"width": 320, "height": 240, "spp": 4},',
             f'  "camera": {{"position": [{side // 2}, {side // 4 + 2}, -8], '
             f'"look_at": [{side // 2}, 0, {side // 3}], "vfov": 50}},',
             '  "materials": {']
    for i in range(N_NAMED):
        kind = "kr" if i % 8 == 7 else "kd"
        lines.append(f'    "m{i}": {{"{kind}": {rgb(rng, 0.05, 0.95)}}},')
    lines.append('    "sky": {"emission": 1}')
    lines.append("  },")
    lines.append('  "objects": [')
    lines.append('    {"type": "plane", "normal": [0, 1, 0], "distance": 0, "material": "m0"},')
    lines.append(f'    {{"type": "sphere", "center": [0, 0, 0], "radius": {4 * side}, '
                 '"material": "sky"},')
    for i in range(n):
        a, b = i % side, i // side
        r = rng.uniform(0.16, 0.24)
        x = a + 0.5 + rng.uniform(r - 0.5, 0.5 - r)
        z = b + 0.5 + rng.uniform(r - 0.5, 0.5 - r)
        mat = (inline_material(rng) if rng.random() < 0.25
               else f'"m{rng.randrange(N_NAMED)}"')
        lines.append(f'    {{"type": "sphere", "center": [{num(x)}, {num(r)}, {num(z)}], '
                     f'"radius": {num(r)}, "material": {mat}}}' + ("," if i + 1 < n else ""))
    lines.append("  ]")
    lines.append("}")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
