#!/usr/bin/python3
"""Writes the seed files of the fuzz corpora (docs/fuzzing.md): small PLY files in every
format and layout the reader supports, small OBJ files of every form the OBJ reader accepts
and some it refuses (some with an MTL library after a "#%mtl" line), MTL libraries, small
images in every format the texture decoder reads (and broken ones), HDR images as
cierzo-tonemap reads them (OpenEXR and PFM), render states for the checkpoint reader, the
messages between MPI ranks, the fixtures that seed scenes refer to (meshes, an OBJ with its
MTL library, images of every format, an environment map), and small scene files covering
every key of docs/scene-format.md. The scenes of scenes/ are copied as well. Run from
anywhere; files are (over)written in tests/fuzz/. The fuzzers' own finds are added later
with -merge=1.

With --cierzo PATH (a built `cierzo` program), it also renders a tiny scene and keeps what
cierzo itself writes: a checkpoint and a guided render's path guide for the checkpoint
corpus, and a float EXR with variance layers and a PFM for the HDR corpus."""
import argparse
import math
import os
import pathlib
import shutil
import struct
import subprocess
import tempfile
import zlib

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
PLY_DIR = HERE / "corpus" / "ply"
OBJ_DIR = HERE / "corpus" / "obj"
SCENE_DIR = HERE / "corpus" / "scene"
MTL_DIR = HERE / "corpus" / "mtl"
IMAGE_DIR = HERE / "corpus" / "image"
HDR_DIR = HERE / "corpus" / "hdr_image"
CHECKPOINT_DIR = HERE / "corpus" / "checkpoint"
RANK_DIR = HERE / "corpus" / "rank_messages"
FIXTURES = HERE / "scene_root" / "meshes"
TEXTURES = HERE / "scene_root" / "textures"

TYPES = {"char": "b", "uchar": "B", "short": "h", "ushort": "H", "int": "i", "uint": "I",
         "float": "f", "double": "d", "int8": "b", "uint8": "B", "int16": "h",
         "uint16": "H", "int32": "i", "uint32": "I", "float32": "f", "float64": "d"}


def ply(fmt, elements, comments=("seed for cierzo's PLY fuzzer",), eol="\n"):
    """elements: [(name, [(prop, type) or (prop, 'list', count_t, item_t)], rows)]."""
    head = ["ply", f"format {fmt} 1.0"] + [f"comment {c}" for c in comments]
    for name, props, rows in elements:
        head.append(f"element {name} {len(rows)}")
        for p in props:
            head.append(f"property list {p[2]} {p[3]} {p[0]}" if p[1] == "list"
                        else f"property {p[1]} {p[0]}")
    head.append("end_header")
    out = (eol.join(head) + eol).encode()
    order = "<" if fmt == "binary_little_endian" else ">"
    for _, props, rows in elements:
        for row in rows:
            if fmt == "ascii":
                vals = []
                for p, v in zip(props, row):
                    vals += [len(v), *v] if p[1] == "list" else [v]
                out += (" ".join(str(x) for x in vals) + eol).encode()
                continue
            for p, v in zip(props, row):
                if p[1] == "list":
                    out += struct.pack(order + TYPES[p[2]], len(v))
                    out += struct.pack(order + TYPES[p[3]] * len(v), *v)
                else:
                    out += struct.pack(order + TYPES[p[1]], v)
    return out


def faces(index_lists):
    """Face rows with the index list as their only property."""
    return [(f,) for f in index_lists]


XYZ = [("x", "float"), ("y", "float"), ("z", "float")]
RGB = [("red", "uchar"), ("green", "uchar"), ("blue", "uchar")]
TRI = [("vertex_indices", "list", "uchar", "int")]
QUAD_V = [(-1.0, -1.0, 0.0), (1.0, -1.0, 0.0), (1.0, 1.0, 0.0), (-1.0, 1.0, 0.0)]
QUAD_C = [(255, 255, 255), (255, 0, 0), (0, 255, 0), (0, 0, 255)]
TETRA_V = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
TETRA_F = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]


def icosahedron():
    t = (1 + math.sqrt(5)) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t),
         (0, -1, -t), (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    n = math.sqrt(1 + t * t)
    v = [tuple(round(c / n, 6) for c in p) for p in v]
    f = [[0, 11, 5], [0, 5, 1], [0, 1, 7], [0, 7, 10], [0, 10, 11], [1, 5, 9], [5, 11, 4],
         [11, 10, 2], [10, 7, 6], [7, 1, 8], [3, 9, 4], [3, 4, 2], [3, 2, 6], [3, 6, 8],
         [3, 8, 9], [4, 9, 5], [2, 4, 11], [6, 2, 10], [8, 6, 7], [9, 8, 1]]
    c = [tuple(int(round(127.5 * (x + 1))) for x in p) for p in v]
    return v, f, c


def ply_seeds():
    seeds = {}
    ico_v, ico_f, ico_c = icosahedron()
    for fmt, tag in [("ascii", "ascii"), ("binary_little_endian", "le"),
                     ("binary_big_endian", "be")]:
        seeds[f"tetra_{tag}.ply"] = ply(fmt, [("vertex", XYZ, TETRA_V), ("face", TRI, faces(TETRA_F))])
        seeds[f"quad_colors_{tag}.ply"] = ply(fmt, [
            ("vertex", XYZ + RGB, [v + c for v, c in zip(QUAD_V, QUAD_C)]),
            ("face", TRI, faces([[0, 1, 2, 3]]))])
        seeds[f"ico_colors_{tag}.ply"] = ply(fmt, [
            ("vertex", XYZ + RGB, [v + c for v, c in zip(ico_v, ico_c)]),
            ("face", TRI, faces(ico_f))])
        # Every scalar type, float colours, a list in the vertex element, extra elements
        # before and between, an extra face property, a pentagon
        seeds[f"types_{tag}.ply"] = ply(fmt, [
            ("material", [("id", "uchar"), ("name", "list", "uchar", "char")],
             [(1, [104, 105]), (2, [])]),
            ("vertex", [("x", "double"), ("nx", "short"), ("y", "int"), ("z", "float32"),
                        ("red", "float"), ("green", "double"), ("blue", "float"),
                        ("tags", "list", "ushort", "int16")],
             [(0.5, -3, 1, 0.0, 0.25, 0.5, 1.0, [1, -2]), (1.5, 7, 0, 2.0, 0, 0, 0, []),
              (-2.0, 0, -4, 1e-3, 1, 1, 1, [5]), (3.0, 1, 2, -1.0, 0.1, 0.2, 0.3, []),
              (0.0, 2, 3, 4.0, 0.9, 0.8, 0.7, [9, 9, 9])]),
            ("edge", [("vertex1", "int"), ("vertex2", "int")], [(0, 1), (1, 2)]),
            ("face", [("flags", "uint8"), ("vertex_index", "list", "uint", "uint16"),
                      ("texcoord", "list", "uchar", "float")],
             [(0, [0, 1, 2, 3, 4], [0.0, 1.0]), (255, [4, 3, 2], [])])])
        seeds[f"colors16_{tag}.ply"] = ply(fmt, [
            ("vertex", XYZ + [("red", "ushort"), ("green", "short"), ("blue", "uint")],
             [(0.0, 0.0, 0.0, 65535, 32767, 4294967295), (1.0, 0.0, 0.0, 0, 0, 0),
              (0.0, 1.0, 0.0, 1000, 2000, 3000)]),
            ("face", [("vertex_indices", "list", "int", "uint")], faces([[0, 1, 2]]))])
        seeds[f"empty_faces_{tag}.ply"] = ply(fmt, [("vertex", XYZ, TETRA_V),
                                                    ("face", TRI, [])])
    # Ascii details: CRLF, blank lines, '+' signs, exponents, obj_info
    seeds["tetra_crlf.ply"] = ply("ascii", [("vertex", XYZ, TETRA_V), ("face", TRI, faces(TETRA_F))],
                                  eol="\r\n")
    seeds["ascii_details.ply"] = (
        b"ply\nformat ascii 1.0\nobj_info made by hand\ncomment signs and exponents\n"
        b"element vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
        b"element face 1\nproperty list uchar int vertex_indices\nend_header\n\n"
        b"+1.5e0 -2E-3 .5\n\n  0 0 0  \n1e10 -1e-10 +0\n3 +0 1 2\n")
    # Refusals the reader must explain (truncated, lying counts, bad indices)
    good = seeds["tetra_le.ply"]
    seeds["truncated_le.ply"] = good[:-7]
    seeds["lying_count.ply"] = good.replace(b"element vertex 4", b"element vertex 400000000")
    seeds["bad_index_ascii.ply"] = seeds["tetra_ascii.ply"].replace(b"3 1 2 3", b"3 1 2 9")
    seeds["no_end_header.ply"] = b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
    return seeds


def scene(body):
    return (body.strip() + "\n").encode()


CAM = '"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]}'
FRAME = '"camera": {"position": [0, 0, -3.5], "forward": [0, 0, 3], "left": [-1, 0, 0], "up": [0, 1, 0]}'


def scene_seeds():
    s = {}
    s["minimal.json"] = scene('{' + CAM + ', "objects": [{"type": "sphere", "center": [0, 0, 0], '
                              '"radius": 1, "material": {"emission": 1}}]}')
    s["empty_objects_frame.json"] = scene('{' + FRAME + ', "objects": []}')
    s["render_all_keys.json"] = scene('''
{"render": {"width": 32, "height": 24.0, "spp": 4, "seed": 4294967295, "survival_cap": 0.5,
            "diffuse_sampling": "cosine", "output": "out/x.pfm"},
 "scene_ior": 1.33,
 "camera": {"position": [0, 0.2, -3.5], "look_at": [0, -0.2, 0], "up": [0, 1, 0], "vfov": 45},
 "objects": [{"type": "plane", "normal": [0, 2, 0], "distance": 2, "material": {"kd": 0.5}}],
 "lights": [{"type": "point", "position": [0, 0.9, -0.5], "intensity": [0.5, 0.5, 0.5]},
            {"position": [1, 1, 1], "intensity": 2}]}''')
    s["textures.json"] = scene('''
{"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0], "vfov": 30},
 "materials": {
   "solid": {"kd": {"texture": "solid", "a": [0.1, 0.2, 0.3]}},
   "sin": {"kd": {"texture": "sin", "a": 0.1, "b": 0.9, "frequency": 20, "axis": [0, 1, 0]}},
   "sin2": {"ks": {"texture": "sin2", "a": 0, "b": [1, 0, 0]}, "shininess": 1e6},
   "sincos": {"kr": {"texture": "sincos", "a": 0.1, "b": 0.9, "frequency": -3,
                     "axis": [1, 0, 0], "axis2": [0, 0, 1]}},
   "glass": {"kt": 0.95, "ior": 1.5},
   "glow": {"emission": {"texture": "sin", "a": 0, "b": 2}},
   "near": {"kd": {"texture": "vertex_nearest"}},
   "weighted": {"kd": {"texture": "vertex_weighted", "scale": [0.9, 0.8, 0.7]}}},
 "objects": [
   {"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "solid"},
   {"type": "sphere", "center": [1, 0, 0], "radius": 0.5, "material": "sin"},
   {"type": "sphere", "center": [-1, 0, 0], "radius": 0.5, "material": "sin2"},
   {"type": "sphere", "center": [0, 1, 0], "radius": 0.5, "material": "sincos"},
   {"type": "sphere", "center": [0, -1, 0], "radius": 0.5, "material": "glass"},
   {"type": "plane", "normal": [0, 0, -1], "distance": 5, "material": "glow"},
   {"type": "triangle", "vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "material": "near",
    "colors": [[1, 0, 0], 0.5, [0, 0, 1]]},
   {"type": "triangle", "vertices": [[0, 0, 2], [1, 0, 2], [0, 1, 2]], "material": "weighted"}]}''')
    s["quadrics.json"] = scene('''
{"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
 "objects": [
   {"type": "quadric", "coefficients": [1, 0, 1, 0, 0, 0, 0, 0, 0, -0.04],
    "bounds": {"min": [-1, -1, -1], "max": [1, -0.6, 1]}, "material": {"kd": 0.5}},
   {"type": "quadric", "coefficients": [1, -1, 0, 0.5, 0, 0, 0, 0, 1, 0], "material": {"kr": 1}},
   {"type": "quadric", "coefficients": [0, 0, 0, 0, 0, 0, 0, 1, 0, 2], "material": {"emission": 1}}]}''')
    s["meshes.json"] = scene('''
// Meshes from tests/fuzz/scene_root/meshes (the fuzzer resolves files there)
{"render": {"width": 8, "height": 8, "spp": 1},
 "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
 "materials": {"w": {"kd": {"texture": "vertex_weighted"}}},
 "objects": [
   {"type": "mesh", "file": "meshes/quad.ply", "scale": 0.4, "rotate": [0, 30, 0],
    "translate": [0.5, 0.2, 0.6], "material": "w"},
   {"type": "mesh", "file": "meshes/icosphere.ply", "scale": [1, -2, 0.5], "material": "w"},
   {"type": "mesh", "file": "meshes/tetra_be.ply", "rotate": [90, -45, 180],
    "material": {"kd": 1}}]}''')
    s["mesh_missing.json"] = scene('{' + CAM + ', "objects": [{"type": "mesh", "file": '
                                   '"meshes/none.ply", "material": {"kd": 1}}]}')
    s["doc_full.json"] = scene('''
{
  /* the "Full" example of docs/scene-format.md */
  "render": {"width": 320, "height": 240, "spp": 64, "seed": 7, "survival_cap": 0.9,
             "diffuse_sampling": "cosine", "output": "renders/full.exr"},
  "scene_ior": 1.0,
  "camera": {"position": [0, 0.2, -3.5], "look_at": [0, -0.2, 0], "up": [0, 1, 0], "vfov": 45},
  "materials": {
    "white": {"kd": 0.8}, "red": {"kd": [0.8, 0.1, 0.1]}, "green": {"kd": [0.1, 0.8, 0.1]},
    "ceiling_light": {"emission": [4, 4, 4]},
    "glossy": {"kd": [0.1, 0.1, 0.4], "ks": 0.5, "shininess": 50},
    "mirror": {"kr": 0.9}, "glass": {"kt": 0.95, "ior": 1.5},
    "painted": {"kd": {"texture": "vertex_weighted", "scale": 0.9}}
  },
  "objects": [
    {"type": "plane", "normal": [1, 0, 0], "distance": 1, "material": "red"},
    {"type": "plane", "normal": [-1, 0, 0], "distance": 1, "material": "green"},
    {"type": "plane", "normal": [0, -1, 0], "distance": 1, "material": "ceiling_light"},
    {"type": "sphere", "center": [-0.5, -0.7, 0.25], "radius": 0.3, "material": "glass"},
    {"type": "sphere", "center": [0.5, -0.7, -0.25], "radius": 0.3, "material": "mirror"},
    {"type": "quadric", "coefficients": [1, 0, 1, 0, 0, 0, 0, 0, 0, -0.04],
     "bounds": {"min": [-1, -1, -1], "max": [1, -0.6, 1]}, "material": "glossy"},
    {"type": "triangle", "vertices": [[-0.9, 0.5, 0.9], [-0.3, 0.5, 0.9], [-0.6, 0.9, 0.9]],
     "colors": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "material": "painted"},
    {"type": "mesh", "file": "meshes/quad.ply", "scale": 0.4, "rotate": [0, 30, 0],
     "translate": [0.5, 0.2, 0.6], "material": {"kd": {"texture": "vertex_nearest"}}}
  ],
  "lights": [{"type": "point", "position": [0, 0.9, -0.5], "intensity": [0.5, 0.5, 0.5]}]
}''')
    # Refusals the reader must explain
    s["err_unknown_key.json"] = scene('{' + CAM + ', "objects": [], "materials": {"w": {"shininnes": 1}}}')
    s["err_bad_json.json"] = scene('{"camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},,}')
    s["err_overflow.json"] = scene('{' + CAM + ', "objects": [{"type": "sphere", "center": [1e39, 0, 0], "radius": 1e400, "material": {}}]}')
    s["smooth_meshes.json"] = scene('{' + CAM + ', "objects": ['
        '{"type": "mesh", "file": "meshes/icosphere.obj", "smooth": true, "material": {"kd": 0.5}},'
        '{"type": "mesh", "file": "meshes/icosphere.ply", "smooth": true, "translate": [2, 0, 0],'
        ' "material": {"ks": 0.5, "shininess": 20}},'
        '{"type": "mesh", "file": "meshes/icosphere.obj", "smooth": true, "instance": true,'
        ' "scale": [1, -1, 2], "material": {"kt": 0.9, "ior": 1.5}}]}')
    s["err_smooth.json"] = scene('{' + CAM + ', "objects": [{"type": "mesh", "file": '
        '"meshes/icosphere.obj", "smooth": 1, "material": {"kd": 1}}]}')
    s["err_too_big.json"] = scene('{"render": {"width": 65536, "height": 4097}, ' + CAM + ', "objects": []}')
    s["err_camera.json"] = scene('{"camera": {"position": [0, 0, 0], "look_at": [0, 1, 0], "forward": [0, 0, 1]}, "objects": []}')
    return s


def obj(vertices, faces_, normals=(), extra=""):
    lines = ["# seed for cierzo's OBJ fuzzer"]
    lines += ["v " + " ".join(repr(float(x)) for x in v) for v in vertices]
    lines += ["vn " + " ".join(repr(float(x)) for x in n) for n in normals]
    lines += ["f " + " ".join(str(i) for i in f) for f in faces_]
    return ("\n".join(lines) + "\n" + extra).encode()


def obj_seeds():
    ico_v, ico_f, ico_c = icosahedron()
    tri = [[a + 1, b + 1, c + 1] for a, b, c in TETRA_F]
    seeds = {
        "tetra.obj": obj(TETRA_V, tri),
        "quad_polygon.obj": obj(QUAD_V, [[1, 2, 3, 4]]),
        "ico_colors.obj": obj([v + c for v, c in zip(ico_v, ico_c)], [[a + 1, b + 1, c + 1] for a, b, c in ico_f]),
        "ico_normals.obj": obj(ico_v, [[f"{a + 1}//{a + 1}", f"{b + 1}//{b + 1}", f"{c + 1}//{c + 1}"]
                                       for a, b, c in ico_f], normals=ico_v),
        "crease.obj": obj(QUAD_V, [["1//1", "2//1", "3//1"], ["1//2", "3//2", "4//2"]],
                          normals=[(0, 0, 1), (0, 1, 0)]),
        "texcoords.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvn 0 0 1\nf 1/1/1 2/2/1 3/1/1\nf 1/1 2/2 3/2\n",
        "relative.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 1 1 1\nf -1 -2 -3\n",
        "groups.obj": (b"mtllib a.mtl\r\no one\r\ng g1 g2\r\nusemtl m\r\ns off\r\nv\t0 0 0\r\n"
                       b"v +1 .5 5.\r\nv 1e-3 1E+3 -0\r\nf 1 2 3\r\nl 1 2\r\np 3\r\nvp 0.5\r\n"),
        "weights.obj": b"v 0 0 0 1\nv 1 0 0 1.0\nv 0 1 0 1\nf 1 2 3\n",
        "err_number.obj": b"v 0 0 0\nv 1 x 0\nv 0 1 0\nf 1 2 3\n",
        "err_index.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
        "err_zero.obj": b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
        "err_short_face.obj": b"v 0 0 0\nv 1 0 0\nf 1 2\n",
        "err_no_faces.obj": b"v 0 0 0\n",
    }
    seeds["truncated.obj"] = seeds["ico_normals.obj"][:-9]
    seeds["materials.obj"] = (b"mtllib full.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\n"
                              b"vt 1 0\nvt 1 1\nvt 0 1\nusemtl stone\nf 1/1 2/2 3/3\nusemtl\n"
                              b"f 1/1 3/3 4/4\nusemtl leaf\nf 1/1 2/2 4/4\n#%mtl\n" + MTL_FULL)
    seeds["materials_bad_mtl.obj"] = (b"mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl a\n"
                                      b"f 1 2 3\n#%mtl\nnewmtl a\nNs -4\n")
    return seeds


MTL_FULL = (b"# every key\nnewmtl stone\nKa 0.1 0.1 0.1\nKd 0.5 0.4 0.3\nKs 0.2 0.2 0.2\n"
            b"Ns 40\nillum 2\nmap_Kd -s 2 2 1 -o 0.5 0 0 -clamp on textures\\stone.png\n"
            b"map_Ks spec.tga\nnewmtl glass\nKs 0.1 0.1 0.1\nTf 0.9 0.9 0.9\nNi 1.5\nillum 7\n"
            b"d 0.3\nnewmtl lamp\nKe 4 4 4\nmap_Ke -bm 1 glow.hdr\nnewmtl leaf\nKd 0.2 0.6 0.1\n"
            b"map_d -imfchan m leaf.tga\nTr 0.1\nnewmtl pbr\nPr 0.5\nPm 1\nmap_bump -bm 2 n.png\n"
            b"d -halo 0.5\n")


def mtl_seeds():
    return {
        "full.mtl": MTL_FULL,
        "crlf.mtl": MTL_FULL.replace(b"\n", b"\r\n"),
        "mirror.mtl": b"newmtl m\nKd 0 0 0\nKs 0.9 0.9 0.9\nillum 3\n",
        "empty_name.mtl": b"newmtl\nKd 1 1 1\n",
        "err_negative.mtl": b"newmtl a\nKd -1 0 0\n",
        "err_spectral.mtl": b"newmtl a\nKd spectral curve.rfl\n",
        "err_before_newmtl.mtl": b"Kd 1 1 1\nnewmtl a\n",
        "err_twice.mtl": b"newmtl a\nnewmtl a\n",
        "err_map_without_file.mtl": b"newmtl a\nmap_Kd -s 1 1 1\n",
        "err_illum.mtl": b"newmtl a\nillum 2.5\n",
    }


def png(w, h, channels, rows):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    colour = {1: 0, 2: 4, 3: 2, 4: 6}[channels]
    raw = b"".join(b"\0" + bytes(r) for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, colour, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


UINT, HALF, FLOAT = 0, 1, 2
EXR_FORMS = {UINT: "<I", HALF: "<e", FLOAT: "<f"}


def exr_zip(raw):
    """OpenEXR's ZIP coding of a block: bytes split even / odd, deltas, then zlib (kept raw
    where that is not smaller, as OpenEXR does)."""
    t = bytearray(raw[0::2] + raw[1::2])
    for i in range(len(t) - 1, 0, -1):
        t[i] = (t[i] - t[i - 1] + 128 + 256) & 0xFF
    packed = zlib.compress(bytes(t), 9)
    return packed if len(packed) < len(raw) else raw


def exr_file(w, h, channels, compression=0, attrs=(), tile=None, origin=(0, 0)):
    """A single-part OpenEXR file: `channels` is [(name, type, value(x, y))], stored sorted by
    name; compression 0 (none), 2 (ZIP, a line a block) or 3 (ZIP, 16 lines a block);
    `attrs` more attributes (name, type, bytes); `tile` (w, h) makes it tiled, one level;
    `origin` is the data window's corner."""
    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value
    channels = sorted(channels)
    chlist = b"".join(n.encode() + b"\0" + struct.pack("<iB3xii", t, 0, 1, 1) for n, t, _ in channels) + b"\0"
    x0, y0 = origin
    box = struct.pack("<iiii", x0, y0, x0 + w - 1, y0 + h - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<I", 2 | (0x200 if tile else 0))
              + attr("channels", "chlist", chlist)
              + attr("compression", "compression", bytes([compression]))
              + attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box)
              + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1.0))
              + (attr("tiles", "tiledesc", struct.pack("<IIB", tile[0], tile[1], 0)) if tile else b"")
              + b"".join(attr(*a) for a in attrs) + b"\0")

    def lines(ys, xs):
        return b"".join(struct.pack(EXR_FORMS[t], f(x, y)) for y in ys for _, t, f in channels
                        for x in xs)
    blocks = []
    if tile:
        for ty in range(0, h, tile[1]):
            for tx in range(0, w, tile[0]):
                data = lines(range(ty, min(ty + tile[1], h)), range(tx, min(tx + tile[0], w)))
                data = exr_zip(data) if compression else data
                blocks.append(struct.pack("<iiiii", tx // tile[0], ty // tile[1], 0, 0, len(data)) + data)
    else:
        step = 16 if compression == 3 else 1
        for y in range(0, h, step):
            data = lines(range(y, min(y + step, h)), range(w))
            data = exr_zip(data) if compression else data
            blocks.append(struct.pack("<ii", y0 + y, len(data)) + data)
    offsets, offset = b"", len(header) + 8 * len(blocks)
    for b in blocks:
        offsets += struct.pack("<Q", offset)
        offset += len(b)
    return header + offsets + b"".join(blocks)


def exr(w, h, pixel):
    """An uncompressed scanline OpenEXR of float R, G, B."""
    return exr_file(w, h, [(n, FLOAT, lambda x, y, c=c: pixel(x, y)[c]) for c, n in enumerate("RGB")])


ZIGZAG = [0, 1, 8, 16, 9, 2, 3, 10, 17, 24, 32, 25, 18, 11, 4, 5, 12, 19, 26, 33, 40, 48,
          41, 34, 27, 20, 13, 6, 7, 14, 21, 28, 35, 42, 49, 56, 57, 50, 43, 36, 29, 22, 15, 23,
          30, 37, 44, 51, 58, 59, 52, 45, 38, 31, 39, 46, 53, 60, 61, 54, 47, 55, 62, 63]


def jpeg_category(v):
    """A coefficient's size in bits and its bits (a negative v as v - 1 in them: T.81 F.1.2)."""
    size = abs(v).bit_length()
    return size, (v if v >= 0 else v + (1 << size) - 1), size


def jpeg(w, h, pixel, grey=False, subsample=False, quantiser=4):
    """A baseline JPEG (ITU T.81): YCbCr or grey, luma sampled 2 x 2 against the chroma when
    `subsample`, every coefficient quantised by `quantiser`, one Huffman table per class of
    equal-length codes for exactly the symbols used (2^length > their count: no code is all
    ones)."""
    comps = [(1, 2, 2) if subsample else (1, 1, 1)] + ([] if grey else [(2, 1, 1), (3, 1, 1)])
    hmax, vmax = max(c[1] for c in comps), max(c[2] for c in comps)
    mw, mh = 8 * hmax, 8 * vmax
    W, H = -(-w // mw) * mw, -(-h // mh) * mh

    def plane(k):  # Y, Cb or Cr of every pixel of the MCUs, edges repeated, level-shifted
        out = []
        for y in range(H):
            row = []
            for x in range(W):
                r, g, b = pixel(min(x, w - 1), min(y, h - 1))
                row.append([0.299 * r + 0.587 * g + 0.114 * b,
                            -0.168736 * r - 0.331264 * g + 0.5 * b + 128,
                            0.5 * r - 0.418688 * g - 0.081312 * b + 128][k] - 128)
            out.append(row)
        return out

    def block(p, bx, by, step):  # 8 x 8 samples, each the mean of step x step pixels
        return [[sum(p[(by + y) * step + j][(bx + x) * step + i] for i in range(step)
                     for j in range(step)) / step ** 2 for x in range(8)] for y in range(8)]

    def dct(b):  # quantised, in zigzag order
        c = [math.sqrt(0.5)] + [1.0] * 7
        out = [0] * 64
        for v in range(8):
            for u in range(8):
                t = sum(b[y][x] * math.cos((2 * x + 1) * u * math.pi / 16)
                        * math.cos((2 * y + 1) * v * math.pi / 16) for y in range(8) for x in range(8))
                out[8 * v + u] = int(round(0.25 * c[u] * c[v] * t / quantiser))
        return [out[z] for z in ZIGZAG]

    planes = [plane(k) for k in range(len(comps))]
    symbols, predictions = [], [0] * len(comps)  # (class, symbol, bits, size)
    for my in range(H // mh):
        for mx in range(W // mw):
            for k, (_, hs, vs) in enumerate(comps):
                for j in range(vs):
                    for i in range(hs):
                        z = dct(block(planes[k], (mx * hs + i) * 8, (my * vs + j) * 8, hmax // hs))
                        diff, predictions[k] = z[0] - predictions[k], z[0]
                        symbols.append((0,) + jpeg_category(diff))
                        last = max([n for n in range(1, 64) if z[n]] or [0])
                        run = 0
                        for a in z[1:last + 1]:
                            if a == 0:
                                run += 1
                                continue
                            while run > 15:
                                symbols.append((1, 0xF0, 0, 0))
                                run -= 16
                            size, bits, _ = jpeg_category(a)
                            symbols.append((1, run << 4 | size, bits, size))
                            run = 0
                        if last < 63:
                            symbols.append((1, 0x00, 0, 0))
    tables, codes = [], {}
    for cls in (0, 1):
        used = sorted({sym for c, sym, _, _ in symbols if c == cls})
        length = max(1, len(used).bit_length())
        counts = [0] * 16
        counts[length - 1] = len(used)
        tables.append(bytes([cls << 4]) + bytes(counts) + bytes(used))
        codes.update({(cls, sym): (n, length) for n, sym in enumerate(used)})
    bits = []
    for cls, sym, value, size in symbols:
        code, length = codes[cls, sym]
        bits += [(code >> (length - 1 - i)) & 1 for i in range(length)]
        bits += [(value >> (size - 1 - i)) & 1 for i in range(size)]
    bits += [1] * (-len(bits) % 8)
    data = bytearray()
    for i in range(0, len(bits), 8):
        data.append(int("".join(map(str, bits[i:i + 8])), 2))
        if data[-1] == 0xFF:
            data.append(0)  # (stuffed)

    def segment(marker, payload):
        return bytes([0xFF, marker]) + struct.pack(">H", len(payload) + 2) + payload
    return (b"\xff\xd8" + segment(0xE0, b"JFIF\0\x01\x01\0\0\x01\0\x01\0\0")
            + segment(0xDB, b"\0" + bytes([quantiser] * 64))
            + segment(0xC0, struct.pack(">BHHB", 8, h, w, len(comps))
                      + b"".join(bytes([cid, hs << 4 | vs, 0]) for cid, hs, vs in comps))
            + segment(0xC4, tables[0]) + segment(0xC4, tables[1])
            + segment(0xDA, bytes([len(comps)]) + b"".join(bytes([cid, 0]) for cid, _, _ in comps)
                      + b"\0\x3f\0")
            + bytes(data) + b"\xff\xd9")


def image_seeds():
    w, h = 4, 3
    rgb = [[(17 * x + 5 * y + c * 40) % 256 for x in range(w) for c in range(3)] for y in range(h)]
    rgba = [[(x * 60 + c * 30 + y) % 256 for x in range(w) for c in range(4)] for y in range(h)]
    grey_alpha = [[(x * 80 + y * 7 + c * 100) % 256 for x in range(w) for c in range(2)] for y in range(h)]
    tga = bytearray(18)
    tga[2], tga[16], tga[17] = 2, 32, 0x28
    tga[12:16] = struct.pack("<HH", w, h)
    for r in rgba:
        for x in range(w):
            p = r[4 * x:4 * x + 4]
            tga += bytes((p[2], p[1], p[0], p[3]))
    row_bytes = (3 * w + 3) // 4 * 4
    bmp_pixels = b"".join(bytes(sum(([r[3 * x + 2], r[3 * x + 1], r[3 * x]] for x in range(w)), []))
                          + b"\0" * (row_bytes - 3 * w) for r in reversed(rgb))
    bmp = (b"BM" + struct.pack("<IHHI", 54 + len(bmp_pixels), 0, 0, 54)
           + struct.pack("<IiiHHIIiiII", 40, w, h, 1, 24, 0, len(bmp_pixels), 2835, 2835, 0, 0)
           + bmp_pixels)
    ppm = f"P6\n{w} {h}\n255\n".encode() + b"".join(bytes(r) for r in rgb)
    pgm = f"P5 {w} {h} 255\n".encode() + bytes(range(0, w * h * 20, 20))
    hdr = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 3 +X 4\n"
    for y in range(h):
        for x in range(w):
            hdr += bytes((x * 60, y * 80, 128, 129 + x % 3))
    good_exr = exr(w, h, lambda x, y: (x * 0.5, y * 0.25, 2.0 + x))
    seeds = {
        "rgb.png": png(w, h, 3, rgb),
        "rgba.png": png(w, h, 4, rgba),
        "grey_alpha.png": png(w, h, 2, grey_alpha),
        "grey.png": png(w, h, 1, [[x * 60 + y for x in range(w)] for y in range(h)]),
        "rgba.tga": bytes(tga),
        "rgb.bmp": bmp,
        "rgb.ppm": ppm,
        "grey.pgm": pgm,
        "sky.hdr": hdr,
        "float.exr": good_exr,
        "truncated.png": png(w, h, 3, rgb)[:-20],
        "truncated.exr": good_exr[:-10],
        "lying_size.png": png(w, h, 3, rgb).replace(struct.pack(">II", w, h), struct.pack(">II", 100000, 100000), 1),
        "lying_size.exr": good_exr.replace(struct.pack("<iiii", 0, 0, w - 1, h - 1),
                                           struct.pack("<iiii", 0, 0, 99999, 99999)),
        "negative.exr": exr(w, h, lambda x, y: (-1.0 if x == 2 else 0.5, 0.5, 0.5)),
        "not_an_image.txt": b"this is not an image\n",
        "photo.jpg": jpeg(12, 10, photo),
        "photo_420.jpg": jpeg(20, 18, photo, subsample=True, quantiser=6),
        "grey.jpg": jpeg(9, 7, lambda x, y: (x * 25, x * 25, x * 25), grey=True),
        "rgba_half.exr": exr_file(w, h, [(c, HALF, lambda x, y, k=k: [0.25 * x, 0.5, 1.5, 0.2 * y][k])
                                         for k, c in enumerate("RGBA")]),
        "zip.exr": exr_file(5, 20, [(c, FLOAT, lambda x, y, k=k: 0.1 * (x + y + k)) for k, c in enumerate("RGB")],
                            compression=3),
        "tiled.exr": exr_file(6, 5, [(c, HALF, lambda x, y, k=k: 0.3 * (x + k)) for k, c in enumerate("BGR")],
                              tile=(4, 4)),
        "window.exr": exr_file(w, h, [(c, FLOAT, lambda x, y: 0.5) for c in "RGB"], origin=(3, -2)),
        "palette.png": png_chunks(w, h, 8, 3, [bytes([x % 3 for x in range(w)]) for y in range(h)],
                                  [(b"PLTE", bytes([255, 0, 0, 0, 255, 0, 0, 0, 255])),
                                   (b"tRNS", bytes([255, 128]))]),
        "rgb16.png": png_chunks(w, h, 16, 2, [b"".join(struct.pack(">HHH", 4000 * x, 9000 * y, 65535)
                                                      for x in range(w)) for y in range(h)]),
        "interlaced.png": png_chunks(9, 9, 8, 0, [bytes((x * 28 + y) % 256 for x in range(9)) for y in range(9)],
                                     interlace=True),
        "rle.tga": tga_rle(w, h),
        "palette.bmp": bmp_palette(w, h),
    }
    return seeds


def photo(x, y):
    return ((x * 21) % 256, (y * 27) % 256, (128 + 40 * ((x + y) % 3)) % 256)


def png_chunks(w, h, depth, colour, rows, chunks=(), interlace=False):
    """A PNG of raw rows (unfiltered) with more chunks before IDAT; Adam7-interlaced passes
    taken from the same rows when `interlace`."""
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    size = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}[colour] * depth // 8
    if interlace:
        raw = b""
        for x0, y0, dx, dy in [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4),
                               (1, 0, 2, 2), (0, 1, 1, 2)]:
            for y in range(y0, h, dy):
                if x0 < w:
                    raw += b"\0" + b"".join(rows[y][x * size:(x + 1) * size] for x in range(x0, w, dx))
    else:
        raw = b"".join(b"\0" + r for r in rows)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, colour, 0, 0, int(interlace)))
            + b"".join(chunk(k, d) for k, d in chunks) + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def tga_rle(w, h):
    """A run-length encoded true-colour TGA (type 10), bottom-up: a row is a run of w - 1
    texels and a raw packet of one."""
    out = bytearray(18)
    out[2], out[16] = 10, 24
    out[12:16] = struct.pack("<HH", w, h)
    for y in range(h):
        out += bytes([0x80 | (w - 2)]) + bytes((10 * y, 200, 30))
        out += bytes([0]) + bytes((255, 0, 0))
    return bytes(out)


def bmp_palette(w, h):
    """An 8-bit BMP with a palette of four colours."""
    row = (w + 3) // 4 * 4
    pixels = b"".join(bytes((x + y) % 4 for x in range(w)) + b"\0" * (row - w) for y in range(h))
    palette = bytes([0, 0, 0, 0, 0, 0, 255, 0, 0, 255, 0, 0, 255, 0, 0, 0])
    offset = 54 + len(palette)
    return (b"BM" + struct.pack("<IHHI", offset + len(pixels), 0, 0, offset)
            + struct.pack("<IiiHHIIiiII", 40, w, h, 1, 8, 0, len(pixels), 2835, 2835, 4, 0)
            + palette + pixels)


TEXTURED_OBJ = b"""# a quad and a fan of triangles, with texture coordinates, in the materials of textured.mtl
mtllib textured.mtl
mtllib missing.mtl
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
v 0 0 1
v 0 2 0.5
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vt 0.5 0.5
vn 0 0 1
usemtl wood
f 1/1/1 2/2/1 3/3/1
usemtl leaf
f 1/1/1 3/3/1 4/4/1
usemtl lamp
f 1/1 2/2 5/5
usemtl mirror
f 2/2 3/3 5/5
usemtl glass
f 3/3 4/4 5/5
usemtl decal
f 4/4 1/1 5/5
usemtl fog
f 3/3 6/5 4/4
usemtl exr
f 1/1 5/5 6/3
usemtl ppm
f 2/2 6/4 5/5
usemtl undefined
f 1/1 6/2 2/3
"""

TEXTURED_MTL = b"""# every map cierzo reads, of every image format, in the textures folder beside this one
newmtl wood
Kd 0.8 0.7 0.6
map_Kd -s 2 2 1 -o 0.5 0 0 ../textures/rgb.png
Ks 0.2 0.2 0.2
Ns 20
map_Ks -colorspace linear ../textures/grey.png
newmtl leaf
Kd 0.3 0.6 0.2
map_Kd ../textures/photo.jpg
map_d -imfchan m ../textures/rgba.png
newmtl lamp
Ke 1 1 1
map_Ke ../textures/sky.hdr
newmtl mirror
illum 3
Ks 0.9 0.9 0.9
map_Ks -clamp on ../textures/rgb.bmp
newmtl glass
illum 7
Ni 1.5
Tf 0.9 0.9 0.9
d 0.5
newmtl decal
map_Kd ../textures/rgba.tga
map_d -imfchan r ../textures/grey_alpha.png
d 0.8
newmtl fog
Tr 1
newmtl exr
map_Kd ../textures/rgba_half.exr
map_d ../textures/rgba_half.exr
newmtl ppm
map_Kd ..\\textures\\rgb.ppm
map_Ks ../textures/grey.pgm
"""


def fixtures():
    ico_v, ico_f, ico_c = icosahedron()
    return {
        "quad.ply": ply("ascii", [("vertex", XYZ + RGB, [v + c for v, c in zip(QUAD_V, QUAD_C)]),
                                  ("face", TRI, faces([[0, 1, 2, 3]]))]),
        "icosphere.ply": ply("ascii", [("vertex", XYZ + RGB, [v + c for v, c in zip(ico_v, ico_c)]),
                                       ("face", TRI, faces(ico_f))]),
        "tetra_be.ply": ply("binary_big_endian", [("vertex", XYZ, TETRA_V), ("face", TRI, faces(TETRA_F))]),
        "icosphere.obj": obj_seeds()["ico_normals.obj"],
        "textured.obj": TEXTURED_OBJ,
        "textured.mtl": TEXTURED_MTL,
        # (an MTL library, and a map, outside the scene's folder: refused)
        "escapes.obj": (b"mtllib ../../corpus/mtl/full.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\n"
                        b"usemtl stone\nf 1/1 2/1 3/1\n"),
        "escapes_map.obj": (b"mtllib escapes_map.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nusemtl m\n"
                            b"f 1/1 2/1 3/1\n"),
        "escapes_map.mtl": b"newmtl m\nmap_Kd ../../corpus/image/rgb.png\n",
        # (glass without an index: refused)
        "glass_without_ni.obj": (b"mtllib glass_without_ni.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n"
                                 b"usemtl glass\nf 1 2 3\n"),
        "glass_without_ni.mtl": b"newmtl glass\nillum 4\nKs 1 1 1\nNi 0\n",
    }


def hdr_header(w, h):
    return f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n".encode()


def png_header_only(w, h):
    """A PNG's signature and IHDR (8-bit RGB) with no image data: its size can be probed,
    it cannot be decoded."""
    return png_chunks(w, h, 8, 2, [])[:33] + png_chunks(1, 1, 8, 2, [b"\0\0\0"])[-12:]


def texture_fixtures():
    """The images fuzzed scenes and textured.mtl name: one of every format, environment maps,
    and headers whose images would take more than the fuzzer's budget (they are refused from
    the header: their texels are not there)."""
    images = image_seeds()
    env = hdr_header(8, 4) + b"".join(bytes((128, 64 + 8 * x, 32 * y, 136 if (x, y) == (3, 1) else 129))
                                      for y in range(4) for x in range(8))
    files = {name: images[name] for name in ("rgb.png", "rgba.png", "grey.png", "grey_alpha.png",
                                             "photo.jpg", "rgba.tga", "rgb.bmp", "rgb.ppm",
                                             "grey.pgm", "sky.hdr", "float.exr", "rgba_half.exr")}
    files.update({
        "env.hdr": env,
        "env.exr": exr(8, 4, lambda x, y: (0.5 + x, 0.25 * y, 100.0 if (x, y) == (5, 2) else 1.0)),
        "big_header.png": png_header_only(3000, 2000),  # 46 MB decoding: within the budget once
        "huge_header.png": png_header_only(16384, 16384),  # 2 GB
        "env_over_budget.hdr": hdr_header(4096, 2048),  # 480 MB as an environment
        "png_named.tga": images["rgb.png"],  # (the extension must agree with the signature)
        "tiny.gif": b"GIF89a\x01\0\x01\0\0\0\0;",  # (a format cierzo does not read)
    })
    return files


# Symbolic links in the textures folder: one inside it, one out of the scene's folder.
TEXTURE_LINKS = {"link_in.png": "rgb.png", "link_out.png": "../../corpus/image/rgb.png"}

CAM_Z = '"camera": {"position": [0, 0.5, -4], "look_at": [0, 0, 0]}'


def image_scene_seeds():
    """Scenes that use image textures, alpha masks, environment maps and OBJ + MTL materials
    of the fixtures in scene_root, and refusals of each (outside the folder, over the budget,
    of the wrong format)."""
    s = {}
    s["images.json"] = scene("""
{"render": {"width": 8, "height": 8, "spp": 1},
 "camera": {"position": [0, 0.5, -4], "look_at": [0, 0, 0]},
 "materials": {
   "png": {"kd": {"texture": "image", "file": "textures/rgb.png", "wrap": "clamp", "scale": [2, 1], "offset": 0.5}},
   "jpg": {"kd": {"texture": "image", "file": "textures/photo.jpg", "factor": 0.8}},
   "tga": {"kd": 0.2, "ks": {"texture": "image", "file": "textures/rgba.tga"}, "shininess": 10},
   "bmp": {"kr": {"texture": "image", "file": "textures/rgb.bmp", "srgb": false}},
   "ppm": {"kt": {"texture": "image", "file": "textures/rgb.ppm", "factor": [0.9, 0.8, 0.7]}, "ior": 1.5},
   "pgm": {"kd": {"texture": "image", "file": "textures/grey.pgm"}},
   "hdr": {"emission": {"texture": "image", "file": "textures/sky.hdr", "factor": 2}},
   "exr": {"kd": {"texture": "image", "file": "textures/float.exr", "factor": 0.1}},
   "half": {"kd": {"texture": "image", "file": "textures/rgba_half.exr", "factor": 0.5}}},
 "objects": [
   {"type": "sphere", "center": [-1.5, 0, 0], "radius": 0.5, "material": "png"},
   {"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "jpg"},
   {"type": "sphere", "center": [1.5, 0, 0], "radius": 0.5, "material": "tga"},
   {"type": "sphere", "center": [-1.5, 1.5, 0], "radius": 0.5, "material": "bmp"},
   {"type": "sphere", "center": [0, 1.5, 0], "radius": 0.5, "material": "ppm"},
   {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": "pgm"},
   {"type": "plane", "normal": [0, 0, -1], "distance": 5, "material": "hdr"},
   {"type": "triangle", "vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "uvs": [[0, 0], [1, 0], [0.5, 1]], "material": "exr"},
   {"type": "triangle", "vertices": [[0, 0, 2], [1, 0, 2], [0, 1, 2]], "material": "half"}]}""")
    s["alpha.json"] = scene("{" + CAM_Z + """, "objects": [
   {"type": "triangle", "vertices": [[0, 0, 1], [1, 0, 1], [0, 1, 1]], "material": {"kd": 0.5, "alpha": 0.5}},
   {"type": "triangle", "vertices": [[0, 0, 2], [1, 0, 2], [0, 1, 2]], "material": {"kd": 0.5,
    "alpha": {"texture": "image", "file": "textures/grey_alpha.png", "channel": "a"}}},
   {"type": "triangle", "vertices": [[0, 0, 3], [1, 0, 3], [0, 1, 3]], "material": {"kd": 0.5,
    "alpha": {"texture": "image", "file": "textures/rgba.png"}}},
   {"type": "triangle", "vertices": [[0, 0, 4], [1, 0, 4], [0, 1, 4]], "material": {"kd": 0.5,
    "alpha": {"texture": "image", "file": "textures/grey.png", "channel": "r", "factor": 0.5,
              "wrap": "clamp", "scale": 3, "offset": [0.25, 0.5]}}},
   {"type": "mesh", "file": "meshes/textured.obj", "translate": [0, 0, 5]}]}""")
    s["environment_exr.json"] = scene("{" + CAM_Z + """, "environment": {"emission":
   {"texture": "image", "file": "textures/env.exr", "factor": 2}, "rotate": [0, 90, 0]},
 "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"kd": 0.5}}]}""")
    s["environment_hdr.json"] = scene("{" + CAM_Z + """, "environment": {"emission":
   {"texture": "image", "file": "textures/env.hdr", "factor": [1, 0.5, 0.25], "srgb": false}},
 "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"kr": 0.9}}]}""")
    s["environment_png.json"] = scene("{" + CAM_Z + """, "environment": {"emission":
   {"texture": "image", "file": "textures/rgb.png"}}, "objects": []}""")
    s["environment_colour.json"] = scene("{" + CAM_Z + """, "environment": {"emission": [0.5, 0.6, 0.7],
 "rotate": [10, 20, 30]}, "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"kd": 0.5}}]}""")
    s["obj_mtl.json"] = scene("{" + CAM_Z + """, "objects": [
   {"type": "mesh", "file": "meshes/textured.obj"},
   {"type": "mesh", "file": "meshes/textured.obj", "translate": [2, 0, 0], "smooth": true,
    "materials": {"wood": {"kd": {"texture": "image", "file": "textures/photo.jpg"}}, "glass": {"kt": 1, "ior": 1.33}}},
   {"type": "mesh", "file": "meshes/textured.obj", "instance": true, "scale": 0.5, "rotate": [0, 45, 0]}]}""")
    s["images_dotdot.json"] = scene("{" + CAM_Z + """, "objects": [
   {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"kd": {"texture": "image", "file": "textures/../textures/rgb.png"}}},
   {"type": "sphere", "center": [2, 0, 0], "radius": 1, "material": {"kd": {"texture": "image", "file": "../scene_root/textures/rgba.png"}}},
   {"type": "sphere", "center": [4, 0, 0], "radius": 1, "material": {"kd": {"texture": "image", "file": "textures/link_in.png"}}}]}""")

    def image(name, extra=""):
        return scene("{" + CAM_Z + ', "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, '
                     '"material": {"kd": {"texture": "image", "file": "' + name + '"' + extra + "}}}]}")
    s["images_over_budget.json"] = image("textures/huge_header.png")
    s["image_within_budget_undecodable.json"] = image("textures/big_header.png")
    s["image_twice_over_budget.json"] = scene("{" + CAM_Z + """, "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
   "material": {"kd": {"texture": "image", "file": "textures/big_header.png"},
                "ks": {"texture": "image", "file": "textures/big_header.png", "srgb": false}}}]}""")
    s["environment_over_budget.json"] = scene("{" + CAM_Z + """, "environment": {"emission":
   {"texture": "image", "file": "textures/env_over_budget.hdr"}}, "objects": []}""")
    s["err_image_outside.json"] = image("../corpus/image/rgb.png")
    s["err_image_absolute.json"] = image("/dev/stdin")
    s["err_image_link_out.json"] = image("textures/link_out.png")
    s["err_image_wrong_extension.json"] = image("textures/png_named.tga")
    s["err_image_missing.json"] = image("textures/missing.png")
    s["err_image_gif.json"] = image("textures/tiny.gif")
    s["err_image_srgb.json"] = image("textures/rgb.png", ', "srgb": 1')
    s["err_image_on_ply.json"] = scene("{" + CAM_Z + """, "objects": [{"type": "mesh", "file": "meshes/quad.ply",
   "material": {"kd": {"texture": "image", "file": "textures/rgb.png"}}}]}""")
    s["err_image_on_quadric.json"] = scene("{" + CAM_Z + """, "objects": [{"type": "quadric",
   "coefficients": [1, 0, 1, 0, 0, 0, 0, 0, 0, -0.04], "material": {"kd": {"texture": "image", "file": "textures/rgb.png"}}}]}""")
    s["err_alpha_on_sphere.json"] = scene("{" + CAM_Z + """, "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1,
   "material": {"kd": 0.5, "alpha": {"texture": "image", "file": "textures/grey.png"}}}]}""")
    s["err_mtl_outside.json"] = scene("{" + CAM_Z + ', "objects": [{"type": "mesh", "file": "meshes/escapes.obj"}]}')
    s["err_mtl_map_outside.json"] = scene("{" + CAM_Z + ', "objects": [{"type": "mesh", "file": "meshes/escapes_map.obj"}]}')
    s["err_mask_on_ply.json"] = scene("{" + CAM_Z + """, "objects": [{"type": "mesh", "file": "meshes/quad.ply",
   "material": {"kd": 0.5, "alpha": {"texture": "image", "file": "textures/grey_alpha.png"}}}]}""")
    s["err_mtl_glass_without_ni.json"] = scene("{" + CAM_Z + ', "objects": [{"type": "mesh", "file": "meshes/glass_without_ni.obj"}]}')
    s["err_mesh_absolute.json"] = scene("{" + CAM_Z + ', "objects": [{"type": "mesh", "file": "/dev/zero", "material": {"kd": 1}}]}')
    return s


# ---- HDR images (cierzo-tonemap) -------------------------------------------------------

def pfm(w, h, values, grey=False, scale=-1.0, eol=b"\n", comment=b""):
    """A PFM: 'PF' (RGB) or 'Pf' (grey), rows bottom to top, little-endian for a negative
    scale; values(x, y) gives a pixel's floats."""
    order = "<" if scale < 0 else ">"
    head = (b"Pf" if grey else b"PF") + eol + comment + f"{w} {h}".encode() + eol + repr(scale).encode() + eol
    body = b"".join(struct.pack(order + "f", v) for y in reversed(range(h)) for x in range(w)
                    for v in values(x, y)[:1 if grey else 3])
    return head + body


def hdr_seeds():
    w, h = 5, 3

    def value(x, y):
        return (0.5 * x, 0.25 * y + 0.1, 3.0 - x)
    good_exr = exr(w, h, value)
    strings = [("cierzo:spp", "string", b"64"), ("cierzo:estimator", "string", b"mis"),
               ("owner", "string", b"fuzz")]
    rgb = lambda f, t=FLOAT, names="RGB": [(c, t, lambda x, y, k=k: f(x, y)[k]) for k, c in enumerate(names)]
    return {
        "rgb_le.pfm": pfm(w, h, value),
        "rgb_be.pfm": pfm(w, h, value, scale=1.0),
        "grey.pfm": pfm(w, h, value, grey=True),
        "scaled.pfm": pfm(w, h, value, scale=-2.5),
        "crlf.pfm": pfm(w, h, value, eol=b"\r\n"),
        "comment.pfm": pfm(w, h, value, comment=b"# written for the fuzzer\n"),
        "nonfinite.pfm": pfm(w, h, lambda x, y: (float("nan"), float("inf"), -1.0)),
        "truncated.pfm": pfm(w, h, value)[:-5],
        "extra_bytes.pfm": pfm(w, h, value) + b"\0\0\0\0",
        "lying_size.pfm": b"PF\n100000 100000\n-1.0\n" + b"\0" * 64,
        "zero_scale.pfm": b"PF\n1 1\n0\n" + b"\0" * 12,
        "float.exr": good_exr,
        "zip.exr": exr_file(7, 18, rgb(lambda x, y: (0.1 * x, 0.1 * y, 0.2)), compression=3),
        "zips_half.exr": exr_file(w, h, rgb(value, HALF), compression=2),
        "layers.exr": exr_file(w, h, rgb(lambda x, y: (1.0, 0.5, 0.25))
                               + [("variance.R", FLOAT, lambda x, y: 0.01 * x),
                                  ("count", UINT, lambda x, y: x + y), ("A", HALF, lambda x, y: 1.0)],
                               attrs=strings),
        "tiled.exr": exr_file(w, h, rgb(lambda x, y: (0.5, 0.5, 0.5)), tile=(2, 2)),
        "tiled_zip.exr": exr_file(9, 9, rgb(lambda x, y: (0.1 * x, 0.2, 0.3), HALF), tile=(4, 8),
                                  compression=3),
        "window.exr": exr_file(w, h, rgb(lambda x, y: (0.5, 0.5, 0.5)), origin=(-3, 7)),
        "nonfinite.exr": exr(w, h, lambda x, y: (float("nan"), float("-inf"), -2.0)),
        "no_blue.exr": exr_file(w, h, rgb(lambda x, y: (0.5, 0.5), names="RG")),
        "truncated.exr": good_exr[:-10],
        "lying_size.exr": good_exr.replace(struct.pack("<iiii", 0, 0, w - 1, h - 1),
                                           struct.pack("<iiii", 0, 0, 99999, 99999)),
        "not_hdr.txt": b"PF\n",
    }


# ---- Rank messages (integrators/rank_messages.cpp) -------------------------------------
# Each message starts with its kind (a uint32), then its fields as they lie in memory
# (x86-64 and aarch64: little-endian, no padding in these): the harness's render is a
# 24 x 20 image, its units a batch of light paths then four tiles (16 x 16, 8 x 16, 16 x 4,
# 8 x 4), its bands one tile each.
KIND = {name: 0x52455131 + i for i, name in enumerate(["request", "control", "report", "splats",
                                                       "state", "results"])}
RAYS = struct.pack("<4Q", 100, 200, 50, 7)


def pixel_sums(n, paths):
    """n PixelSums (3 sums, 3 sums of squares as doubles, then the finite and non-finite path
    counts), each holding `paths` paths of a small radiance."""
    return b"".join(struct.pack("<6d2Q", *(0.5 * paths * (1 + (i + c) % 3) for c in range(3)),
                                *(0.25 * paths * (1 + (i + c) % 3) ** 2 for c in range(3)), paths, 0)
                    for i in range(n))


def rank_seeds():
    def kind(name):
        return struct.pack("<I", KIND[name])

    def unit(tile, pass_, s0, s1):
        return struct.pack("<iiqq", tile, pass_, s0, s1)

    def result(tile, pixels):
        return unit(tile, 1, 1, 2) + RAYS + struct.pack("<Q", pixels) + pixel_sums(pixels, 1)
    return {
        "request.bin": kind("request") + struct.pack("<ii", 4, 1),
        "request_idle.bin": kind("request") + struct.pack("<ii", 0, 0),
        "control_answer.bin": (kind("control") + struct.pack("<iiiiqQ", 1, 2, 3, 0, 0, 2)
                               + unit(1, 2, 2, 4) + unit(4, 3, 4, 8)),
        "control_news.bin": kind("control") + struct.pack("<iiiiqQ", 0, 5, 4, 1, 7, 0),
        "report.bin": kind("report") + struct.pack("<ii2QQQ", 2, 0, 12345, 0, 10, 20) + RAYS,
        "splats.bin": (kind("splats") + struct.pack("<ii", 1, 0) + RAYS + struct.pack("<Q", 3)
                       + struct.pack("<Ifff", 5, 0.5, 0.25, 0.0) + struct.pack("<Ifff", 479, 1e30, 0, 0)
                       + struct.pack("<Ifff", 480, float("nan"), 1, 2)),
        "splats_none.bin": kind("splats") + struct.pack("<ii", 0, 0) + RAYS + struct.pack("<Q", 0),
        "state_fresh.bin": kind("state") + struct.pack("<qqQQQ", -1, 0, 0, 0, 0),
        "state_final.bin": kind("state") + struct.pack("<qqQQQ", -2, 3, 1, 256, 0) + pixel_sums(256, 8),
        "state_pending.bin": (kind("state") + struct.pack("<qqQQQ", 2, 0, 0, 256, 1) + pixel_sums(256, 4)
                              + b"\1" + pixel_sums(256, 8)),
        "results_one.bin": kind("results") + result(4, 32),
        "results_two.bin": kind("results") + result(3, 64) + result(4, 32),
        "results_light_unit.bin": kind("results") + unit(0, 0, 0, 1) + RAYS + struct.pack("<Q", 0),
        "truncated_control.bin": (kind("control") + struct.pack("<iiiiqQ", 1, 2, 3, 0, 0, 5)
                                  + unit(1, 2, 2, 4)),
        "wrong_kind.bin": struct.pack("<I", 0x12345678) + struct.pack("<ii", 4, 1),
        "empty.bin": b"",
    }


# ---- Checkpoints ------------------------------------------------------------------------
# A checkpoint seed that does not start with OpenEXR's signature describes a render state
# (fuzz_render_targets.cpp, described_checkpoint): width - 1 and height - 1 (a byte each),
# flags (1: a pass in progress, 2: a guided estimator, 4: the guide's bytes end the input),
# the done tiles of the pass in progress (a bit each), spp, spp done, the pass's end, seed
# (uint32 each), rays (4 uint64), batches and non-finite splats (uint32), seconds (double),
# a count of edits, each a pixel (uint16), a field (uint8) and 64 bits; then the guide.

def described(w, h, flags=0, done=0, spp=16, spp_done=8, pending_end=0, batches=0, nonfinite=0,
              seconds=1.5, edits=(), guide=b""):
    return (struct.pack("<BBBBIIII4QIIdB", w - 1, h - 1, flags, done, spp, spp_done, pending_end, 7,
                        1000, 2000, 300, 0, batches, nonfinite, seconds, len(edits))
            + b"".join(struct.pack("<HBQ", *e) for e in edits) + guide)


def checkpoint_seeds():
    return {
        "state_whole.bin": described(8, 6),
        "state_pending.bin": described(24, 20, flags=1, done=0b0101, spp=64, spp_done=16, pending_end=32),
        "state_pending_none_done.bin": described(17, 3, flags=1, done=0, spp=8, spp_done=4, pending_end=8),
        "state_batches.bin": described(5, 5, spp=8, spp_done=8, batches=4, nonfinite=3),
        "state_nonfinite_paths.bin": described(4, 4, edits=[(3, 7, 2), (3, 6, 6)]),
        "state_pixel_short.bin": described(4, 4, edits=[(5, 6, 7)]),
        "state_done_over_spp.bin": described(3, 2, spp=4, spp_done=8),
        "state_fresh.bin": described(1, 1, spp=1, spp_done=0),
        "not_a_checkpoint.txt": b"not a checkpoint\n",
    }


def exr_attribute(data, name):
    """The value of one header attribute of an OpenEXR file (None if it has none)."""
    at = 8
    while data[at] != 0:
        key_end = data.index(b"\0", at)
        type_end = data.index(b"\0", key_end + 1)
        size = struct.unpack_from("<i", data, type_end + 1)[0]
        if data[at:key_end] == name:
            return data[type_end + 5:type_end + 5 + size]
        at = type_end + 5 + size
    return None


def rendered_seeds(cierzo):
    """Renders a tiny scene with cierzo twice and keeps what it writes: a checkpoint, the path
    guide of a guided render's checkpoint in a described state, and a float EXR with
    variance layers and a PFM."""
    ckpt, hdr = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        (tmp / "tiny.json").write_text("""{"render": {"width": 12, "height": 10, "spp": 4},
 "camera": {"position": [0, 0, -3], "look_at": [0, 0, 0]},
 "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": {"kd": 0.5}},
             {"type": "plane", "normal": [0, 1, 0], "distance": 1, "material": {"emission": 1}}]}
""")

        def render(*args):
            subprocess.run([str(cierzo), "render", str(tmp / "tiny.json"), "--quiet", "--threads", "1",
                            *args], check=True, cwd=tmp)
        render("--checkpoint", str(tmp / "plain.exr"), "--out", str(tmp / "plain_out.exr"), "--variance")
        render("--checkpoint", str(tmp / "guided.exr"), "--out", str(tmp / "guided_out.pfm"),
               "--estimator", "mis", "--guiding", "sdtree", "--spp", "16")
        plain, guided = (tmp / "plain.exr").read_bytes(), (tmp / "guided.exr").read_bytes()
        ckpt["rendered.exr"] = plain
        ckpt["rendered_truncated.exr"] = plain[:len(plain) // 2]
        # (the guided file itself is not kept: 100 KB of guide whose every change its checksum
        # refuses; the described state reaches the guide's reader with the same bytes)
        guide = exr_attribute(guided, b"cierzo:guide")
        if guide:
            ckpt["state_guided.bin"] = described(4, 3, flags=6, spp=16, spp_done=16, guide=guide)
        hdr["rendered_variance.exr"] = (tmp / "plain_out.exr").read_bytes()
        hdr["rendered.pfm"] = (tmp / "guided_out.pfm").read_bytes()
    return ckpt, hdr


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cierzo", type=pathlib.Path, help="a built cierzo program: also "
                        "write the seeds it renders (checkpoints, an EXR with layers, a PFM)")
    args = parser.parse_args()
    scenes = scene_seeds()
    scenes.update(image_scene_seeds())
    folders = [(PLY_DIR, ply_seeds()), (OBJ_DIR, obj_seeds()), (SCENE_DIR, scenes),
               (MTL_DIR, mtl_seeds()), (IMAGE_DIR, image_seeds()), (HDR_DIR, hdr_seeds()),
               (CHECKPOINT_DIR, checkpoint_seeds()), (RANK_DIR, rank_seeds()),
               (FIXTURES, fixtures()), (TEXTURES, texture_fixtures())]
    if args.cierzo:
        ckpt, hdr = rendered_seeds(args.cierzo.resolve())
        folders += [(CHECKPOINT_DIR, ckpt), (HDR_DIR, hdr)]
    for folder, files in folders:
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (folder / name).write_bytes(data)
    for name, target in TEXTURE_LINKS.items():
        link = TEXTURES / name
        if link.is_symlink() or link.exists():
            link.unlink()
        os.symlink(target, link)
    for json_file in sorted((ROOT / "scenes").glob("*.json")):
        shutil.copy(json_file, SCENE_DIR / ("scenes_" + json_file.name))


if __name__ == "__main__":
    main()
