"""What the bench/*.py scripts share: where things are, running the programs, reading what
they print and write, and the statistics of interleaved rounds.

Every script imports it as a sibling module, `import benchlib` (Python puts a script's own
folder first on sys.path, so `/usr/bin/python3 bench/NAME.py` finds it from any folder).
Python 3 standard library only: numpy and the `cierzo` module are imported by read_exr
alone, when it is called (rel_mse and rel_weights take the arrays they are given).
"""
import json
import pathlib
import re
import statistics
import struct
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
BUILD = ROOT / "build"
SCENES = ROOT / "scenes"
GENERATED = SCENES / "generated"
ATRIUM = GENERATED / "atrium"
EPSILON = 1e-2  # in the relative MSE (x - r)^2 / (r^2 + EPSILON), as cierzo converge's


def cierzo_in(build):
    """The cierzo program of a build folder."""
    return pathlib.Path(build) / "cierzo"


def embree_in(build):
    """The Embree path tracer of a build folder (bench/peers/README.md builds it)."""
    return pathlib.Path(build) / "bench" / "peers" / "embree" / "embree_pt"


CIERZO = cierzo_in(BUILD)
EMBREE = embree_in(BUILD)
# Embree's APIs (embree_pt --api) on its trees of build quality high and medium
EMBREE_TRACES = [(api, quality) for quality in ("high", "medium") for api in ("1", "16", "1M")]


# Programs


def run(cmd, **kw):
    """Runs cmd (its items made strings), raising if it fails; returns what it printed on
    stdout. kw goes to subprocess.run (input=, env=)."""
    return subprocess.run([str(c) for c in cmd], check=True, capture_output=True, text=True,
                          **kw).stdout


def require(program, message):
    """Exits with message unless program exists."""
    if not pathlib.Path(program).exists():
        sys.exit(message)


def keys(text):
    """`key: value` lines (as `cierzo trace` and embree_pt print them) as a dict of strings."""
    return dict(m.groups() for m in re.finditer(r"^(\w+): (.*)$", text, re.M))


def read_stats(path):
    """The JSON a render's --stats wrote."""
    return json.loads(pathlib.Path(path).read_text())


def render_stats(cmd, stats, **kw):
    """Runs cmd (a render or converge command that writes --stats stats) and returns the
    stats it wrote."""
    run(cmd, **kw)
    return read_stats(stats)


def runnable_isas(binary=CIERZO):
    """The wavefront ISAs that binary has and this CPU runs, widest first (`cierzo isas`:
    name, lanes, yes / yes, auto / no, why not; tab-separated)."""
    return [line.split("\t")[0] for line in run([binary, "isas"]).splitlines()
            if line.split("\t")[2] != "no"]


# The machine


def cpu_name(default="unknown CPU"):
    """The CPU's model name from /proc/cpuinfo, or default where it names none."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return default


def cpu_isa():
    """The widest x86 vector extension /proc/cpuinfo's flags name: AVX-512, AVX2 or other."""
    with open("/proc/cpuinfo") as f:
        flags = f.read()
    return "AVX-512" if "avx512f" in flags else ("AVX2" if "avx2" in flags else "other")


# Scenes and ray files


def scene_path(name):
    """A scene given as a name of scenes/ (cornell) or as a path (PATH.json)."""
    return pathlib.Path(name) if name.endswith(".json") else SCENES / f"{name}.json"


def generated_scene(name):
    """A scene of scenes/generated/ by name (mesh_200k)."""
    return GENERATED / f"{name}.json"


def ensure_scenes(names):
    """Writes those of the generated scenes `names` that are missing (scripts/make_scenes.py
    --only)."""
    missing = [n for n in names if not generated_scene(n).exists()]
    if missing:
        run([sys.executable, ROOT / "scripts" / "make_scenes.py", "--only", ",".join(missing)])


def dump_rays(scene, out, count):
    """count incoherent rays of scene into the ray file out (embree_pt --dump-rays: every ray
    after the camera's)."""
    run([EMBREE, scene, "--dump-rays", out, "--count", count])


def head_of(src, dst, count):
    """The first `count` rays of ray file src into dst (magic, uint64 count, 7 floats a ray)."""
    data = pathlib.Path(src).read_bytes()
    pathlib.Path(dst).write_bytes(data[:8] + struct.pack("<Q", count) + data[16:16 + 28 * count])


# Measurements


def cierzo_render(tmp, scene, integrator, size, spp, binary=CIERZO, isa=None, extra=()):
    """One render on one thread, size x size, spp paths per pixel (with --isa isa when
    given, then extra): its rays/s per thread, image mean (RGB), BVH stats and ray group."""
    out, stats = pathlib.Path(tmp) / "img.pfm", pathlib.Path(tmp) / "stats.json"
    s = render_stats([binary, "render", scene, "--width", size, "--height", size, "--spp", spp,
                      "--threads", 1, "--integrator", integrator,
                      *(["--isa", isa] if isa is not None else []),
                      "--quiet", "--out", out, "--stats", stats, *extra], stats)
    return {"rays_per_s": s["rays_per_second_per_thread"], "mean": pfm_mean(out),
            "bvh": s.get("bvh"), "ray_group": s.get("ray_group")}


def cierzo_build(tmp, scene):
    """The BVH stats (--stats bvh) of loading scene and building its tree on 2 threads (a
    1 x 1 render of one path)."""
    stats = pathlib.Path(tmp) / "build.json"
    return render_stats([CIERZO, "render", scene, "--width", 1, "--height", 1, "--spp", 1,
                         "--threads", 2, "--quiet", "--out", pathlib.Path(tmp) / "b.pfm",
                         "--stats", stats], stats)["bvh"]


def cierzo_trace(scene, rays, extra=(), binary=CIERZO):
    """`cierzo trace` of a ray file: rays/s, hits and the sum of hit distances."""
    k = keys(run([binary, "trace", scene, "--rays", rays, *extra]))
    return {"rays_per_s": float(k["rays_per_second"]), "hits": int(k["hits"]),
            "sum_t": float(k["sum_t"])}


def embree_render(tmp, scene, size, spp):
    """The Embree path tracer's render, size x size, spp paths per pixel: rays/s and image
    mean (RGB)."""
    out = pathlib.Path(tmp) / "embree.pfm"
    k = keys(run([EMBREE, scene, "--width", size, "--height", size, "--spp", spp, "--out", out]))
    return {"rays_per_s": float(k["rays_per_second"]),
            "mean": [float(x) for x in k["mean_rgb"].split()]}


def embree_trace(scene, rays, api, quality):
    """embree_pt --trace-rays of a ray file through one API on a tree of one build quality:
    rays/s and hits."""
    k = keys(run([EMBREE, scene, "--trace-rays", rays, "--api", api, "--quality", quality]))
    return {"rays_per_s": float(k["rays_per_second"]), "hits": int(k["hits"])}


def rounds(n):
    """range(n), saying on stderr which round starts."""
    for r in range(n):
        print(f"round {r + 1}/{n}", file=sys.stderr)
        yield r


def median_ratio(a, b):
    """The median of each round's own ratio a / b (two lists of one value a round)."""
    return statistics.median(x / y for x, y in zip(a, b))


class Samples(dict):
    """Measurements by key, one a round in the order taken; each a dict with "rays_per_s"
    where rates, mrays and ratio read them."""

    def add(self, key, value):
        self.setdefault(key, []).append(value)

    def rates(self, key):
        """Every round's rays/s."""
        return [s["rays_per_s"] for s in self[key]]

    def mrays(self, key):
        """The median rays/s, in millions."""
        return statistics.median(self.rates(key)) / 1e6

    def ratio(self, a, b):
        """The median of each round's own rays/s ratio a / b."""
        return median_ratio(self.rates(a), self.rates(b))


# Images


def pfm_mean(path):
    """Mean RGB of a PFM image."""
    data = pathlib.Path(path).read_bytes()
    header = data.split(b"\n", 3)
    w, h = map(int, header[1].split())
    scale = float(header[2])
    n = w * h * 3
    floats = struct.unpack(("<" if scale < 0 else ">") + f"{n}f", header[3][: 4 * n])
    return [sum(floats[c::3]) / (w * h) for c in range(3)]


def read_exr(path):
    """An EXR image as a numpy array (height x width x channels), by the cierzo module."""
    import numpy as np
    import cierzo
    return np.asarray(cierzo.read_exr(str(path)))


def rel_weights(ref):
    """Each pixel's weight in the relative MSE against ref: 1 / (ref^2 + EPSILON)."""
    return 1.0 / (ref * ref + EPSILON)


def rel_mse(img, ref, region=None):
    """The relative MSE (x - r)^2 / (r^2 + EPSILON) of img against ref, averaged over pixels
    and RGB; over region (x0, y0, x1, y1, fractions of the image) when given."""
    a, r = img[..., :3], ref[..., :3]
    if region:
        h, w = r.shape[:2]
        x0, y0, x1, y1 = region
        a = a[int(y0 * h):int(y1 * h), int(x0 * w):int(x1 * w)]
        r = r[int(y0 * h):int(y1 * h), int(x0 * w):int(x1 * w)]
    return float(((a - r) ** 2 / (r * r + EPSILON)).mean())


# Results


def write_json(path, data, indent=2):
    """data as JSON into path (its folder made if missing), ending in a newline."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=indent) + "\n")
