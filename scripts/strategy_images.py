#!/usr/bin/python3
"""Writes bdpt's strategy images: one EXR per strategy (s, t), weighted and unweighted.

For every path length L from --min-length to --max-length and every strategy of it (s light
vertices, t = L + 1 - s camera vertices, the pinhole one of them), renders the scene with
`cierzo render --estimator bdpt --min-length L --max-length L --strategy s,t`, once with the
MIS weight (DIR/L{L}_s{s}_t{t}.exr: the weighted images of a length add up to that length's
image) and once without it (DIR/L{L}_s{s}_t{t}_unweighted.exr: what the strategy alone
makes, an unbiased image of the paths it can reach). Every render has the same seed, so the
weighted images are parts of the same render. Options after `--` go to `cierzo render`
(e.g. --spp, --width, --height, --seed, --integrator).

Usage: /usr/bin/python3 scripts/strategy_images.py SCENE.json DIR [--max-length 4]
       [--min-length 2] [--cierzo build/cierzo] [-- --spp 64 ...]
"""
import argparse
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def main():
    args = sys.argv[1:]
    extra = []
    if "--" in args:
        at = args.index("--")
        args, extra = args[:at], args[at + 1:]
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("dir")
    ap.add_argument("--min-length", type=int, default=1)
    ap.add_argument("--max-length", type=int, default=4)
    ap.add_argument("--cierzo", default=str(ROOT / "build" / "cierzo"))
    a = ap.parse_args(args)
    if a.min_length < 1 or a.max_length < a.min_length or a.max_length > 16:
        sys.exit("strategy_images.py: --min-length and --max-length must satisfy "
                 "1 <= min <= max <= 16 (each length renders length + 1 strategies twice)")
    out = pathlib.Path(a.dir)
    if out.exists() and not out.is_dir():
        sys.exit(f"strategy_images.py: {out} exists and is not a folder")
    out.mkdir(parents=True, exist_ok=True)
    for length in range(a.min_length, a.max_length + 1):
        for s in range(0, length + 1):
            t = length + 1 - s
            for unweighted in (False, True):
                name = out / f"L{length}_s{s}_t{t}{'_unweighted' if unweighted else ''}.exr"
                cmd = [a.cierzo, "render", a.scene, "--estimator", "bdpt", "--min-length",
                       str(length), "--max-length", str(length), "--strategy", f"{s},{t}",
                       "--out", str(name), "--quiet"] + (["--unweighted"] if unweighted else []) + extra
                r = subprocess.run(cmd, capture_output=True, text=True)
                if r.returncode:
                    sys.exit(r.stderr.strip() or f"cierzo render failed for {name}")
                print(name)


if __name__ == "__main__":
    main()
