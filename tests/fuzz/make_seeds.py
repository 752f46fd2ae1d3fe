#!/usr/bin/python3
"""Writes the seed files of the fuzz corpora (docs/fuzzing.md): small PLY files in every
format and layout the reader supports, small OBJ files of every form the OBJ reader accepts
and some it refuses, the mesh fixtures that seed scenes refer to, and small
scene files covering every key of docs/scene-format.md. The scenes of scenes/ are copied as
well. Run from anywhere; files are (over)written in tests/fuzz/. The fuzzers' own finds are
added later with -merge=1."""
import math
import pathlib
import shutil
import struct

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
PLY_DIR = HERE / "corpus" / "ply"
OBJ_DIR = HERE / "corpus" / "obj"
SCENE_DIR = HERE / "corpus" / "scene"
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
                          (FIXTURES, fixtures())]:
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (folder / name).write_bytes(data)
    for json_file in sorted((ROOT / "scenes").glob("*.json")):
        shutil.copy(json_file, SCENE_DIR / ("scenes_" + json_file.name))


if __name__ == "__main__":
    main()
