#!/usr/bin/python3
"""Plots every papers/data/converge_*.csv (written by `cierzo converge`): error against paths
per pixel and against wall time on log-log axes, one line per configuration, with the
1/sqrt(N) slope of an unbiased Monte Carlo estimator drawn through the first
configuration's middle point.

    /usr/bin/python3 papers/scripts/plot_converge.py [CSV ...]

Writes papers/plots/converge_NAME.png (RMSE against paths per pixel and seconds) for each file; the error is the
*_corrected one (the reference's own noise removed).
"""
import csv
import glob
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

PAPERS = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))

# Sweeps of one knob are named after its CSV column; other sweeps compare integrators
KNOB_SWEEPS = {"survival_cap", "pool", "isa", "diffuse_sampling"}


def label_of(name, row):
    if name in KNOB_SWEEPS:
        return f"{name.replace('_', ' ')} {row[name]}"
    return f"{row['integrator']} ({row['isa']})"


def plot(path):
    name = os.path.basename(path)[len("converge_"):-len(".csv")]
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return
    groups = {}
    for r in rows:
        groups.setdefault(label_of(name, r), []).append(r)
    fig, (by_spp, by_time) = plt.subplots(1, 2, figsize=(10, 4.2), dpi=110)
    for label, g in groups.items():
        good = [r for r in g if float(r["seconds"]) > 0 and float(r["rmse_corrected"]) > 0]
        by_spp.plot([float(r["spp"]) for r in good], [float(r["rmse_corrected"]) for r in good],
                    marker="o", markersize=3, label=label)
        by_time.plot([float(r["seconds"]) for r in good],
                     [float(r["rmse_corrected"]) for r in good], marker="o", markersize=3,
                     label=label)
    # The 1/sqrt(N) slope through the first configuration's middle point: against paths per
    # pixel, and against time at a fixed cost per path
    first = [r for r in next(iter(groups.values())) if float(r["rmse_corrected"]) > 0]
    if len(first) >= 2:
        mid = first[len(first) // 2]
        e0 = float(mid["rmse_corrected"])
        for ax, key in ((by_spp, "spp"), (by_time, "seconds")):
            x0 = float(mid[key])
            xs = [float(first[0][key]), float(first[-1][key])]
            ax.plot(xs, [e0 * (x / x0) ** -0.5 for x in xs], "k--", linewidth=0.8,
                    label="slope −1/2 (1/√N)")
    r0 = rows[0]
    fig.suptitle(f"{r0['scene']}, {r0['width']}×{r0['height']}, {r0['threads']} threads: "
                 f"{name.replace('_', ' ')}", fontsize=10)
    by_spp.set_xlabel("paths per pixel")
    by_time.set_xlabel("wall time (s), median of the repeats")
    for ax in (by_spp, by_time):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylabel("RMSE against the reference")
        ax.grid(True, which="both", linewidth=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    out = os.path.join(PAPERS, "plots", f"converge_{name}.png")
    fig.savefig(out)
    plt.close(fig)
    print(f"wrote {out}", file=sys.stderr)


def main():
    paths = sys.argv[1:] or sorted(glob.glob(os.path.join(PAPERS, "data", "converge_*.csv")))
    os.makedirs(os.path.join(PAPERS, "plots"), exist_ok=True)
    for p in paths:
        plot(p)


if __name__ == "__main__":
    main()
