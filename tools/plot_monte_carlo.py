#!/usr/bin/env python3
"""Plots the error bands of a flight's Monte Carlo draws (`iapsim regress --monte-carlo N`): per axis, the
median of the draws' tracking errors over time and the shaded band between their 5th and 95th percentiles
(numpy's linear interpolation, as the metrics' p5/p95), with the worst draw's envelope dotted.

usage: plot_monte_carlo.py OUT_PNG TITLE TRACKING_CSV...   (each draw's tracking.csv, as plot_tracking.py reads)
"""
import sys

import matplotlib

matplotlib.use("Agg")  # headless: CI and `make run` have no display
import matplotlib.pyplot as plt
import numpy as np

POSITION = [("x", "m"), ("y", "m"), ("z", "m")]
ATTITUDE = [("roll", "deg"), ("pitch", "deg"), ("yaw", "deg")]


def errors(csv_path):
    with open(csv_path) as f:
        names = f.readline().strip().split(",")
    values = np.loadtxt(csv_path, delimiter=",", skiprows=1, ndmin=2)
    data = np.rec.fromarrays(values.T, names=names)
    out = {"t_s": data["t_s"]}
    for name, unit in POSITION:
        out[name] = data[f"{name}_{unit}"] - data[f"{name}_ref_{unit}"]
    for name, unit in ATTITUDE:
        out[name] = (data[f"{name}_{unit}"] - data[f"{name}_ref_{unit}"] + 180.0) % 360.0 - 180.0
    return out


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    out_png, title, paths = sys.argv[1], sys.argv[2], sys.argv[3:]
    draws = [errors(path) for path in paths]
    # the draws share the control grid; a shorter one (a run that ended early) bounds the common span
    samples = min(len(draw["t_s"]) for draw in draws)
    if samples < 2:
        sys.exit("fewer than two samples in a draw")
    t = draws[0]["t_s"][:samples]

    fig, axes = plt.subplots(3, 2, figsize=(11, 8), sharex=True)
    for column, group in enumerate([POSITION, ATTITUDE]):
        for row, (name, unit) in enumerate(group):
            ax = axes[row][column]
            stack = np.stack([draw[name][:samples] for draw in draws])
            p5, p50, p95 = np.percentile(stack, [5, 50, 95], axis=0)
            ax.fill_between(t, p5, p95, color="tab:blue", alpha=0.25, linewidth=0, label="p5-p95")
            ax.plot(t, p50, color="tab:blue", linewidth=1.0, label="median")
            ax.plot(t, stack.min(axis=0), ":", color="tab:gray", linewidth=0.8, label="min/max")
            ax.plot(t, stack.max(axis=0), ":", color="tab:gray", linewidth=0.8)
            ax.set_ylabel(f"{name} error [{unit}]")
            ax.grid(True, alpha=0.3)
    axes[0][0].legend(loc="best")
    for ax in axes[2]:
        ax.set_xlabel("t [s]")
    fig.suptitle(f"{title}: tracking error over {len(draws)} draws (simulated - setpoint)")
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
