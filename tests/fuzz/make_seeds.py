#!/usr/bin/python3
"""Writes the seed files of the fuzz corpora (docs/fuzzing.md): small PLY files in every
format and layout the reader supports, small OBJ files of every form the OBJ reader accepts
and some it refuses (some with an MTL library after a "#%mtl" line), MTL libraries, small
images in every format the texture decoder reads (and broken ones), the mesh fixtures that seed scenes refer to, and small
scene files covering every key of docs/scene-format.md. The scenes of scenes/ are copied as
well. Run from anywhere; files are (over)written in tests/fuzz/. The fuzzers' own finds are
added later with -merge=1."""
import math
import pathlib
import shutil
import struct
import zlib

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
PLY_DIR = HERE / "corpus" / "ply"
OBJ_DIR = HERE / "corpus" / "obj"
SCENE_DIR = HERE / "corpus" / "scene"
MTL_DIR = HERE / "corpus" / "mtl"
IMAGE_DIR = HERE / "corpus" / "image"
FIXTURES = HERE / "scene_root" / "meshes"

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


def exr(w, h, pixel):
    """An uncompressed scanline OpenEXR of float R, G, B (stored B, G, R: sorted by name)."""
    def attr(name, kind, value):
        return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value
    chlist = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R")) + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (b"\x76\x2f\x31\x01" + struct.pack("<I", 2) + attr("channels", "chlist", chlist)
              + attr("compression", "compression", b"\0") + attr("dataWindow", "box2i", box)
              + attr("displayWindow", "box2i", box) + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    chunks, offset = [], len(header) + 8 * h
    offsets = b""
    for y in range(h):
        data = b"".join(struct.pack("<f", pixel(x, y)[c]) for c in (2, 1, 0) for x in range(w))
        chunk = struct.pack("<ii", y, len(data)) + data
        offsets += struct.pack("<Q", offset)
        offset += len(chunk)
        chunks.append(chunk)
    return header + offsets + b"".join(chunks)


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
    }
    return seeds


def fixtures():
    ico_v, ico_f, ico_c = icosahedron()
    return {
        "quad.ply": ply("ascii", [("vertex", XYZ + RGB, [v + c for v, c in zip(QUAD_V, QUAD_C)]),
                                  ("face", TRI, faces([[0, 1, 2, 3]]))]),
        "icosphere.ply": ply("ascii", [("vertex", XYZ + RGB, [v + c for v, c in zip(ico_v, ico_c)]),
                                       ("face", TRI, faces(ico_f))]),
        "tetra_be.ply": ply("binary_big_endian", [("vertex", XYZ, TETRA_V), ("face", TRI, faces(TETRA_F))]),
        "icosphere.obj": obj_seeds()["ico_normals.obj"],
    }


def main():
    for folder, files in [(PLY_DIR, ply_seeds()), (OBJ_DIR, obj_seeds()), (SCENE_DIR, scene_seeds()),
                          (MTL_DIR, mtl_seeds()), (IMAGE_DIR, image_seeds()), (FIXTURES, fixtures())]:
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (folder / name).write_bytes(data)
    for json_file in sorted((ROOT / "scenes").glob("*.json")):
        shutil.copy(json_file, SCENE_DIR / ("scenes_" + json_file.name))


if __name__ == "__main__":
    main()
