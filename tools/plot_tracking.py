#!/usr/bin/env python3
"""Plots a flight's tracking.csv (written by `iapsim run` / `iapsim evaluate`) like the seed's Figs. 11-14:
setpoint against actual per axis, and the errors per axis.

usage: plot_tracking.py TRACKING_CSV OUT_DIR [TITLE]   -> OUT_DIR/tracking_pose.png, OUT_DIR/tracking_error.png
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")  # headless: CI and `make run` have no display
import matplotlib.pyplot as plt
import numpy as np

AXES = [("x", "m"), ("y", "m"), ("z", "m"), ("roll", "deg"), ("pitch", "deg"), ("yaw", "deg")]


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    csv_path, out_dir = sys.argv[1], sys.argv[2]
    title = sys.argv[3] if len(sys.argv) == 4 else os.path.basename(out_dir)
    # loadtxt parses in C (numpy >= 1.23); genfromtxt took 0.1-0.3 s a file
    with open(csv_path) as f:
        names = f.readline().strip().split(",")
    values = np.loadtxt(csv_path, delimiter=",", skiprows=1, ndmin=2)
    if values.shape[0] < 2:
        sys.exit(f"{csv_path}: fewer than two samples")
    data = np.rec.fromarrays(values.T, names=names)
    t = data["t_s"]

    def series(name, unit, ref):
        column = f"{name}_ref_{unit}" if ref else f"{name}_{unit}"
        values = data[column]
        # angles: continuous through ±180° for plotting
        return np.degrees(np.unwrap(np.radians(values))) if unit == "deg" else values

    fig, axes = plt.subplots(3, 2, figsize=(11, 8), sharex=True)
    for i, (name, unit) in enumerate(AXES):
        ax = axes[i % 3][i // 3]
        ax.plot(t, series(name, unit, True), "--", color="tab:red", label="setpoint")
        ax.plot(t, series(name, unit, False), color="tab:blue", label="simulated")
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(True, alpha=0.3)
    axes[0][0].legend(loc="best")
    for ax in axes[2]:
        ax.set_xlabel("t [s]")
    fig.suptitle(f"{title}: setpoint and simulated pose (NED, ZYX Euler angles)")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "tracking_pose.png"), dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(2, 1, figsize=(11, 6), sharex=True)
    for name, unit in AXES[:3]:
        axes[0].plot(t, data[f"{name}_{unit}"] - data[f"{name}_ref_{unit}"], label=name)
    for name, unit in AXES[3:]:
        error = (data[f"{name}_{unit}"] - data[f"{name}_ref_{unit}"] + 180.0) % 360.0 - 180.0
        axes[1].plot(t, error, label=name)
    axes[0].set_ylabel("position error [m]")
    axes[1].set_ylabel("attitude error [deg]")
    axes[1].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best")
    fig.suptitle(f"{title}: tracking error (simulated - setpoint)")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "tracking_error.png"), dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
