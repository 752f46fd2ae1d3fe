#!/usr/bin/python3
"""Regenerates every image, table and plot of papers/ from the current build.

    /usr/bin/python3 papers/scripts/regenerate.py [--quick] [--only PART ...]

Parts, in order: figures (every scene by both integrators, tone-mapped, kept as JPEG), series (the
report's resolution and paths-per-pixel table), threads (the thread table, oversubscribed
2x and 4x), converge (error against time per integrator, knob, material and light), beyond
(the estimators beyond the report's: report, nee and mis per scene, both integrators),
report (the tables and figures of REPORT.md, between its BEGIN/END markers). --quick divides every
path count by about 16, for checking the script; the committed results are never --quick.

Renders and tone mapping go through the Python module `cierzo` of build/ (or an installed
one), the convergence sweeps through build/cierzo converge.

Measurements land in papers/data/ (CSV, JSON), images in papers/images/, plots in
papers/plots/; HDR renders go to papers/out/ (not kept in git).
"""
import argparse
import csv
import json
import math
import os
import re
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
PAPERS = os.path.join(ROOT, "papers")
DATA, IMAGES, PLOTS, OUT = (os.path.join(PAPERS, d) for d in ("data", "images", "plots", "out"))
CIERZO = os.path.join(ROOT, "build", "cierzo")
# The Python module `cierzo` of the same build (or one installed with pip): renders and tone
# mapping run in this process, the sweeps through the program (their tables and CSV)
sys.path.insert(0, os.path.join(ROOT, "build", "python", "module"))
INTEGRATORS = ("scalar", "wavefront")

# The report's figures: scene, what it shows, tone-mapping operator
FIGURES = [
    ("cornell", "The default box: five diffuse planes, red and green side walls, an emitting ceiling", "clamp-gamma"),
    ("emitting_spheres", "Two emitting spheres", "clamp-gamma"),
    ("mirror_spheres", "Perfect specular spheres", "clamp-gamma"),
    ("glass_spheres", "Refracting spheres", "clamp-gamma"),
    ("diffuse_spheres", "Diffuse spheres", "clamp-gamma"),
    ("phong_spheres", "Phong specular spheres, s = 10 and s = 200", "clamp-gamma"),
    ("four_lobes", "One sphere with all four lobes", "clamp-gamma"),
    ("point_lights", "Three point lights, no emitters", "clamp-gamma"),
    ("quadrics", "Quadrics: ellipsoid, cylinder, cone", "clamp-gamma"),
    ("bunny", "The Stanford bunny (PLY)", "clamp-gamma"),
    ("vertex_colors", "A PLY mesh with vertex colours", "clamp-gamma"),
    ("textures", "The sin, sin² and sin·cos textures", "clamp-gamma"),
    ("hard_shadow", "Hard shadow from a point light", "clamp-gamma"),
    ("small_emitter", "A small emitting sphere in place of the point light", "clamp-gamma"),
    ("soft_shadow", "Soft shadow under the emitting ceiling", "clamp-gamma"),
    ("bleeding", "Colour bleeding, a sphere light set into the ceiling", "clamp-gamma"),
    ("caustic", "A refracting sphere's caustic", "clamp-gamma"),
    ("smooth_normals", "A coarse OBJ torus (576 triangles), flat on the left, smooth shading normals on the right", "clamp-gamma"),
]
FIGURE_SPP = 256  # the wavefront images; the scalar reference renders the scene's own 64


def run(cmd, **kw):
    print("+", " ".join(cmd), file=sys.stderr, flush=True)
    return subprocess.run(cmd, check=True, **kw)


def render(scene, integrator, out, stats, **overrides):
    """Renders scenes/SCENE.json (keywords override it as cierzo.render's do), writes the
    image to `out` (with its variance layers if variance=True) and the statistics, the
    dict of `cierzo render --stats`, to `stats`; returns them."""
    import cierzo
    path = os.path.join(ROOT, "scenes", scene + ".json")
    print("+ render", path, integrator, overrides, file=sys.stderr, flush=True)
    image, *variance, st = cierzo.render(path, integrator=integrator, **overrides)
    cierzo.write_exr(out, image, variance=variance[0] if variance else None)
    with open(stats, "w") as f:
        json.dump(st, f, indent=2)
    return st


def publish(exr, name, op="clamp-gamma"):
    """Tone-maps an HDR render to papers/out/NAME.png and keeps it as papers/images/NAME.jpg
    (JPEG quality 92: noisy renders compress badly as PNG, and the EXR stays in out/)."""
    import cierzo
    from PIL import Image  # Debian's python3-pil, a dependency of python3-matplotlib
    png = os.path.join(OUT, name + ".png")
    cierzo.write_ldr(png, cierzo.tonemap(cierzo.read_exr(exr), op=op))
    Image.open(png).convert("RGB").save(os.path.join(IMAGES, name + ".jpg"), quality=92)


def figures(args):
    """Every figure scene: the wavefront image (FIGURE_SPP paths) and the scalar reference
    (the scene's 64), with a different seed, and their times and rays/s."""
    rows = []
    spp = max(4, FIGURE_SPP // args.divisor)
    for scene, caption, op in FIGURES:
        exr = os.path.join(OUT, scene + ".exr")
        w = render(scene, "wavefront", exr, os.path.join(OUT, scene + ".wavefront.json"),
                   spp=spp, variance=True)
        publish(exr, scene, op)
        s = render(scene, "scalar", os.path.join(OUT, scene + ".scalar.exr"),
                   os.path.join(OUT, scene + ".scalar.json"),
                   spp=max(4, 64 // args.divisor), seed=2)
        rows.append({"scene": scene, "caption": caption, "wavefront": w, "scalar": s})
    with open(os.path.join(DATA, "figures.json"), "w") as f:
        json.dump(rows, f, indent=1)


def series(args):
    """The report's first table: time against resolution (250 paths per pixel) and against
    paths per pixel (500x500), for both integrators, on the default scene."""
    points = [(100, 250), (500, 250), (1000, 250), (500, 100), (500, 500), (500, 1000)]
    rows = []
    for size, spp in points:
        spp_run = max(1, spp // args.divisor)
        for integrator in INTEGRATORS:
            name = f"cornell_{size}_{spp}_{integrator}"
            st = render("cornell", integrator, os.path.join(OUT, name + ".exr"),
                        os.path.join(OUT, name + ".json"),
                        width=size, height=size, spp=spp_run)
            rows.append({"size": size, "spp": spp_run, "integrator": integrator,
                         "seconds": st["seconds"], "rays": st["rays"]["total"],
                         "threads": st["threads"], "isa": st["isa"],
                         "relative_error": st["mean_relative_error"]})
            if integrator == "wavefront" and size == 500:
                publish(os.path.join(OUT, name + ".exr"), f"cornell_ppp{spp}")
            if integrator == "wavefront" and spp == 250:
                publish(os.path.join(OUT, name + ".exr"), f"cornell_res{size}")
    write_csv(os.path.join(DATA, "series.csv"), rows)


def threads(args):
    """The thread table: 1 .. hardware threads, then oversubscribed 2x and 4x, at 500x500
    and 500 paths per pixel."""
    hw = len(os.sched_getaffinity(0))  # the CPUs this process may run on
    counts = sorted(set(list(range(1, hw + 1)) + [2 * hw, 4 * hw]))
    spp = max(1, 500 // args.divisor)
    rows = []
    for integrator in INTEGRATORS:
        for t in counts:
            name = f"cornell_threads{t}_{integrator}"
            st = render("cornell", integrator, os.path.join(OUT, name + ".exr"),
                        os.path.join(OUT, name + ".json"),
                        spp=spp, threads=t)
            rows.append({"integrator": integrator, "threads": t, "hardware_threads": hw,
                         "spp": spp, "seconds": st["seconds"], "rays": st["rays"]["total"],
                         "isa": st["isa"]})
    write_csv(os.path.join(DATA, "threads.csv"), rows)


# Convergence sweeps: name, scene, extra converge arguments
SWEEP_SPP = "1,2,4,8,16,32,64,128,256,512,1024"
def cpu_isas():
    """The wavefront instruction sets this CPU runs, best first."""
    flags = set()
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("flags"):
                flags.update(line.split(":", 1)[1].split())
    wanted = [("avx512", {"avx512f", "avx512bw", "avx512dq", "avx512vl", "avx512cd", "fma"}),
              ("avx2", {"avx2", "fma"}), ("sse4.2", {"sse4_2"})]
    return [isa for isa, need in wanted if need <= flags]


CPU_ISAS = cpu_isas()

SWEEPS = [
    ("integrators", "cornell", ["--integrator", "scalar,wavefront"]),
    ("survival_cap", "cornell", ["--integrator", "wavefront", "--survival-cap",
                                 "0.5,0.7,0.8,0.9,0.95"]),
    ("pool", "cornell", ["--integrator", "wavefront", "--pool", "64,128,256,512,1024,4096"]),
    ("isa", "cornell", ["--integrator", "wavefront", "--isa", ",".join(CPU_ISAS)]),
    ("diffuse_sampling", "cornell", ["--integrator", "wavefront", "--diffuse-sampling",
                                     "uniform,cosine"]),
]
MATERIAL_SCENES = ["diffuse_spheres", "mirror_spheres", "glass_spheres", "phong_spheres",
                   "four_lobes"]
LIGHT_SCENES = ["point_lights", "hard_shadow", "small_emitter", "soft_shadow", "bleeding"]
SWEEP_SIZE = 200
REFERENCE_SPP = 8192
SWEEP_REPEATS = 3  # the time is the median of 3 renders, the error their mean


def converge(args):
    """Error against time. Each sweep renders its scene at SWEEP_SIZE² against a reference
    of REFERENCE_SPP paths per pixel (rendered once per scene and kept in papers/out/)."""
    spp = ",".join(str(max(1, int(s) // args.divisor)) for s in SWEEP_SPP.split(","))
    spp = ",".join(dict.fromkeys(spp.split(",")))  # --quick may repeat values
    ref_spp = max(64, REFERENCE_SPP // args.divisor)
    sweeps = list(SWEEPS)
    sweeps += [("material_" + s, s, ["--integrator", "wavefront"]) for s in MATERIAL_SCENES]
    sweeps += [("light_" + s, s, ["--integrator", "wavefront"]) for s in LIGHT_SCENES]
    for name, scene, extra in sweeps:
        if args.sweep and name not in args.sweep:
            continue
        ref = os.path.join(OUT, f"reference_{scene}_{SWEEP_SIZE}_{ref_spp}.exr")
        reference = (["--reference", ref] if os.path.exists(ref)
                     else ["--reference-spp", str(ref_spp), "--save-reference", ref])
        run([CIERZO, "converge", os.path.join(ROOT, "scenes", scene + ".json"), "--width",
             str(SWEEP_SIZE), "--height", str(SWEEP_SIZE), "--spp", spp, "--quiet",
             "--repeats", str(SWEEP_REPEATS),
             "--out", os.path.join(DATA, f"converge_{name}.csv"), *reference, *extra])
    run(["/usr/bin/python3", os.path.join(PAPERS, "scripts", "plot_converge.py")])


# Beyond the report: the three estimators on the scenes where they differ most, and on scenes
# where they should not (emitters that cannot be sampled: soft_shadow's ceiling is a plane)
BEYOND_SCENES = ["small_emitter", "bleeding", "soft_shadow", "four_lobes", "caustic",
                 "quad_light", "box"]
BEYOND_SIZE = 128
BEYOND_SPP = "4,8,16,32,64,128,256"
BEYOND_REFERENCE_SPP = 4096
BEYOND_RATIO_SPP = 64  # whole renders of both integrators for the wavefront/scalar ratio
BEYOND_RATIO_ROUNDS = 3


def beyond(args):
    """Each BEYOND_SCENES scene with the report, nee and mis estimators: an error-against-time
    sweep of the wavefront (two passes, in opposite estimator orders) against one mis
    reference of BEYOND_REFERENCE_SPP paths per pixel (all three are unbiased; mis converges
    fastest), and interleaved whole renders of both integrators for their speed ratio."""
    spp = ",".join(dict.fromkeys(str(max(1, int(s) // args.divisor)) for s in BEYOND_SPP.split(",")))
    ref_spp = max(64, BEYOND_REFERENCE_SPP // args.divisor)
    for scene in BEYOND_SCENES:
        if args.sweep and scene not in args.sweep:
            continue
        ref = os.path.join(OUT, f"reference_mis_{scene}_{BEYOND_SIZE}_{ref_spp}.exr")
        reference = (["--reference", ref] if os.path.exists(ref)
                     else ["--reference-spp", str(ref_spp), "--reference-estimator", "mis",
                           "--save-reference", ref])
        common = [CIERZO, "converge", os.path.join(ROOT, "scenes", scene + ".json"), "--width",
                  str(BEYOND_SIZE), "--height", str(BEYOND_SIZE), "--quiet",
                  "--repeats", str(SWEEP_REPEATS)]
        # Two passes, the estimators in opposite orders, so a machine that slows down or
        # speeds up during a sweep favours none of them (the table averages the passes)
        for suffix, order in (("", "report,nee,mis"), ("_reverse", "mis,nee,report")):
            run(common + ["--estimator", order, "--spp", spp, "--integrator", "wavefront",
                          "--out", os.path.join(DATA, f"beyond_{scene}{suffix}.csv"),
                          *reference])
            reference = ["--reference", ref]
        # The wavefront/scalar speed ratio: interleaved rounds of whole renders
        rows = []
        for rnd in range(BEYOND_RATIO_ROUNDS):
            for est in ("report", "nee", "mis"):
                for integrator in INTEGRATORS:
                    st = render(scene, integrator, os.path.join(OUT, "beyond_ratio.exr"),
                                os.path.join(OUT, "beyond_ratio.json"),
                                width=BEYOND_SIZE, height=BEYOND_SIZE,
                                spp=max(1, BEYOND_RATIO_SPP // args.divisor), estimator=est)
                    rows.append({"round": rnd, "estimator": est, "integrator": integrator,
                                 "seconds": st["seconds"], "rays": st["rays"]["total"],
                                 "threads": st["threads"], "isa": st["isa"]})
        write_csv(os.path.join(DATA, f"beyond_ratio_{scene}.csv"), rows)
    plot_beyond()


def plot_beyond():
    """papers/plots/beyond.png: relative MSE against seconds per scene, one line per estimator."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    scenes = [s for s in BEYOND_SCENES if os.path.exists(os.path.join(DATA, f"beyond_{s}.csv"))]
    if not scenes:
        return
    cols = 4
    rowsn = (len(scenes) + cols - 1) // cols
    fig, axes = plt.subplots(rowsn, cols, figsize=(3.2 * cols, 3.0 * rowsn), dpi=110, squeeze=False)
    for ax in axes.flat[len(scenes):]:
        ax.axis("off")
    for ax, scene in zip(axes.flat, scenes):
        rows = read_csv(os.path.join(DATA, f"beyond_{scene}.csv"))  # the first pass
        for est in ("report", "nee", "mis"):
            g = [r for r in rows if r["estimator"] == est and float(r["rel_mse_corrected"]) > 0]
            ax.loglog([float(r["seconds"]) for r in g], [float(r["rel_mse_corrected"]) for r in g],
                      marker="o", markersize=3, label=est)
        ax.set_title(scene, fontsize=9)
        ax.set_xlabel("seconds", fontsize=8)
        ax.set_ylabel("relative MSE", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, which="both", linewidth=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(PLOTS, "beyond.png"))
    plt.close(fig)


def beyond_rows(name):
    """The rows of papers/data/NAME.csv and of its reverse-order pass, if there is one."""
    rows = read_csv(os.path.join(DATA, name + ".csv"))
    reverse = os.path.join(DATA, name + "_reverse.csv")
    return rows + (read_csv(reverse) if os.path.exists(reverse) else [])


def beyond_table():
    """Per scene and estimator, at the largest point of the wavefront sweep (the two passes
    averaged: relative MSE, seconds, rays): relative MSE, time, efficiency 1/(relMSE·s) and
    against the report's, wavefront rays/s per core (shadow rays counted), and the
    wavefront/scalar speed ratio (median of BEYOND_RATIO_ROUNDS interleaved rounds of
    BEYOND_RATIO_SPP paths per pixel)."""
    def mean(xs):
        return sum(xs) / len(xs)
    out = []
    largest = BEYOND_SPP.split(",")[-1]
    for scene in BEYOND_SCENES:
        if not os.path.exists(os.path.join(DATA, f"beyond_{scene}.csv")):
            continue
        rows = [r for r in beyond_rows(f"beyond_{scene}") if r["spp"] == largest]
        ratio_rows = read_csv(os.path.join(DATA, f"beyond_ratio_{scene}.csv"))
        eff = {}
        for est in ("report", "nee", "mis"):
            g = [r for r in rows if r["estimator"] == est]
            rel = mean([float(r["rel_mse_corrected"]) for r in g])
            sec = mean([float(r["seconds"]) for r in g])
            eff[est] = (rel, sec, mean([float(r["rays"]) for r in g]) / sec / int(g[0]["threads"]))
        base = 1.0 / (eff["report"][0] * eff["report"][1])
        for est in ("report", "nee", "mis"):
            rel, sec, per_core = eff[est]
            e = 1.0 / (rel * sec)
            # The median over rounds of scalar seconds / wavefront seconds
            by = {(x["round"], x["integrator"]): float(x["seconds"]) for x in ratio_rows
                  if x["estimator"] == est}
            ratios = sorted(by[(r, "scalar")] / by[(r, "wavefront")]
                            for r in {x["round"] for x in ratio_rows})
            ratio = ratios[len(ratios) // 2]
            out.append([scene, est, f"{rel:.2e}", f"{sec:.2f} s", f"{e:.3g}", f"{e / base:.2f}×",
                        f"{per_core / 1e6:.1f} M",
                        f"{ratio:.1f}×"])
    isa = read_csv(os.path.join(DATA, f"beyond_{BEYOND_SCENES[0]}.csv"))[0]["isa"]
    return table(["scene", "estimator", f"relMSE at {largest} spp", "time", "efficiency",
                  "vs report", f"wavefront ({isa}) rays/s per core", "wavefront / scalar"], out)


def write_csv(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


# ---- The tables of REPORT.md ------------------------------------------------------------

def table(header, rows):
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def seconds(s):
    return f"{s:.2f} s" if s < 100 else f"{s:.0f} s"


def series_table():
    rows = read_csv(os.path.join(DATA, "series.csv"))
    wavefront = {(r["size"], r["spp"]): r for r in rows if r["integrator"] == "wavefront"}
    out = []
    for r in rows:
        if r["integrator"] != "scalar":
            continue
        w = wavefront[(r["size"], r["spp"])]
        ts, tw = float(r["seconds"]), float(w["seconds"])
        out.append([f"{r['size']}×{r['size']}", r["spp"], seconds(ts), seconds(tw),
                    f"{ts / tw:.1f}×", f"{float(w['rays']) / tw / 1e6:.0f} M",
                    f"{float(w['relative_error']):.4f}"])
    isa = next(iter(wavefront.values()))["isa"]
    return table(["image", "paths per pixel", "scalar", f"wavefront ({isa})", "speed-up",
                  "wavefront rays/s", "relative error"], out)


def threads_table():
    rows = read_csv(os.path.join(DATA, "threads.csv"))
    hw = int(rows[0]["hardware_threads"])
    by = {(r["integrator"], int(r["threads"])): float(r["seconds"]) for r in rows}
    counts = sorted({int(r["threads"]) for r in rows})
    out = []
    for t in counts:
        label = f"{t}" + (f" ({t // hw}× oversubscribed)" if t > hw else "")
        cells = [label]
        for integrator in INTEGRATORS:
            s = by[(integrator, t)]
            cells += [seconds(s), f"{by[(integrator, 1)] / s:.2f}×"]
        out.append(cells)
    return table(["threads", "scalar", "speed-up", "wavefront", "speed-up"], out)


def figures_table():
    with open(os.path.join(DATA, "figures.json")) as f:
        rows = json.load(f)
    out = []
    for r in rows:
        w, s = r["wavefront"], r["scalar"]
        out.append([r["scene"], f"{w['spp']}", seconds(w["seconds"]),
                    f"{w['rays_per_second'] / w['threads'] / 1e6:.1f} M",
                    f"{s['spp']}", seconds(s["seconds"]),
                    f"{s['rays_per_second'] / s['threads'] / 1e6:.1f} M",
                    f"{(w['rays_per_second'] / s['rays_per_second']):.1f}×"])
    return table(["scene", "wavefront spp", "time", "rays/s/thread", "scalar spp", "time",
                  "rays/s/thread", "rays/s ratio"], out)


def figures_gallery():
    lines = []
    for scene, caption, _ in FIGURES:
        lines.append(f"| ![{caption}](images/{scene}.jpg) | **{scene}**: {caption} |")
    return "| image | scene |\n|---|---|\n" + "\n".join(lines)


def converge_table():
    """Per sweep and config: MSE slope against paths per pixel, seconds per path per pixel,
    and the relative MSE and efficiency at the largest point."""
    out = []
    for name in sorted(f[len("converge_"):-4] for f in os.listdir(DATA)
                       if f.startswith("converge_") and f.endswith(".csv")):
        rows = read_csv(os.path.join(DATA, f"converge_{name}.csv"))
        groups = {}
        for r in rows:
            key = (r["integrator"], r["isa"], r["pool"], r["survival_cap"], r["diffuse_sampling"],
                   r.get("estimator", "report"))
            groups.setdefault(key, []).append(r)
        for key, g in groups.items():
            xs = [float(r["spp"]) for r in g]
            ys = [float(r["mse_corrected"]) for r in g]
            last = g[-1]
            out.append([name, f"{key[0]} {key[1]}", key[2], key[3], key[4],
                        f"{slope(xs, ys):.2f}", f"{float(last['seconds']) / float(last['spp']) * 1e3:.2f} ms",
                        f"{float(last['rel_mse_corrected']):.2e}", f"{float(last['efficiency']):.3g}"])
    return table(["sweep", "integrator", "pool", "survival cap", "diffuse", "MSE slope",
                  "time per spp", "relMSE at max spp", "efficiency 1/(relMSE·s)"], out)


def slope(xs, ys):
    pts = [(math.log(x), math.log(y)) for x, y in zip(xs, ys) if x > 0 and y > 0]
    n = len(pts)
    if n < 2:
        return float("nan")
    sx = sum(p[0] for p in pts); sy = sum(p[1] for p in pts)
    sxx = sum(p[0] ** 2 for p in pts); sxy = sum(p[0] * p[1] for p in pts)
    return (n * sxy - sx * sy) / (n * sxx - sx * sx)


def report(args):
    """Replaces each `<!-- BEGIN name -->...<!-- END name -->` block of REPORT.md."""
    blocks = {"figures": figures_gallery, "figures-table": figures_table,
              "series-table": series_table, "threads-table": threads_table,
              "converge-table": converge_table, "beyond-table": beyond_table}
    path = os.path.join(PAPERS, "REPORT.md")
    with open(path) as f:
        text = f.read()
    for name, make in blocks.items():
        try:
            body = make()
        except FileNotFoundError as e:
            print(f"report: skipping {name}: {e}", file=sys.stderr)
            continue
        pattern = re.compile(rf"(<!-- BEGIN {name} -->\n).*?(<!-- END {name} -->)", re.S)
        if not pattern.search(text):
            sys.exit(f"{path}: no '<!-- BEGIN {name} -->' block")
        text = pattern.sub(lambda m: m.group(1) + body + "\n" + m.group(2), text)
    with open(path, "w") as f:
        f.write(text)


PARTS = {"figures": figures, "series": series, "threads": threads, "converge": converge,
         "beyond": beyond, "report": report}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="about 1/16 of the paths, to check the script")
    p.add_argument("--only", nargs="+", choices=list(PARTS), help="run only these parts")
    p.add_argument("--sweep", nargs="+", help="converge, beyond: run only these sweeps (scenes)")
    args = p.parse_args()
    args.divisor = 16 if args.quick else 1
    for d in (DATA, IMAGES, PLOTS, OUT):
        os.makedirs(d, exist_ok=True)
    if not os.access(CIERZO, os.X_OK):
        sys.exit(f"{CIERZO}: not built; run scripts/build.sh build first")
    try:
        import cierzo  # noqa: F401
    except ImportError as e:
        sys.exit(f"the Python module cierzo is not built ({e}): build/ needs python3-dev and "
                 "pybind11-dev (scripts/install_deps.sh), then scripts/build.sh build")
    start = time.time()
    for name in args.only or list(PARTS):
        t = time.time()
        PARTS[name](args)
        print(f"{name}: {time.time() - t:.0f} s", file=sys.stderr)
    print(f"done in {time.time() - start:.0f} s", file=sys.stderr)


if __name__ == "__main__":
    main()
