#!/usr/bin/env python3
"""Plots a contact experiment's contact.csv (written by `iapsim run` / `iapsim evaluate`) like the seed's
Figs. 15 and 16.

usage: plot_contact.py CONTACT_CSV OUT_DIR peg_in_hole|wall_push [TITLE]
  -> OUT_DIR/contact_wrench.png: contact force and torque per axis, raw (every control step's true wrench,
     spikes included) and low-passed (§VI-E), with the wrench command where (21) engaged;
  -> OUT_DIR/peg_in_hole.png: pitch command and pitch, the tip's insertion depth and offset from the hole's
     axis (Fig. 15), or
     OUT_DIR/wall_push.png: wrench error and pose error per axis (Fig. 16).
"""
import os
import sys

import matplotlib

matplotlib.use("Agg")  # headless: CI and `make run` have no display
import matplotlib.pyplot as plt
import numpy as np

WRENCH = [("fx", "N"), ("fy", "N"), ("fz", "N"), ("tx", "N·m"), ("ty", "N·m"), ("tz", "N·m")]
POSE = [("x", "m"), ("y", "m"), ("z", "m"), ("roll", "deg"), ("pitch", "deg"), ("yaw", "deg")]


def wrench_figure(data, title, out_path):
    t = data["t_s"]
    fig, axes = plt.subplots(2, 3, figsize=(14, 7), sharex=True)
    for ax, (name, unit) in zip(axes.flat, WRENCH):
        raw = data[f"raw_{name}"]
        filtered = data[f"filtered_{name}"]
        # the raw wrench spikes by orders of magnitude at impacts: clip the view to what the filter passes
        span = max(np.nanmax(np.abs(filtered)), 0.5)
        ax.plot(t, raw, color="0.75", lw=0.6, label="raw")
        ax.plot(t, filtered, color="C0", lw=1.2, label="filtered (§VI-E)")
        target = data[f"target_{name}"]
        if np.isfinite(target).any():
            ax.plot(t, target, "k--", lw=1.0, label="command")
            span = max(span, np.nanmax(np.abs(target)))
        ax.set_ylim(-1.5 * span, 1.5 * span)
        ax.set_ylabel(f"{name} ({unit})")
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("t (s)")
    axes[0][0].legend(loc="best", fontsize=8)
    fig.suptitle(f"{title}: contact wrench on the platform (P, about its origin)")
    fig.tight_layout()
    fig.savefig(out_path, dpi=110)
    plt.close(fig)


def peg_figure(data, title, out_path):
    t = data["t_s"]
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(10, 7), sharex=True)
    top.plot(t, data["pitch_command_deg"], "k--", label="pitch command (admittance)")
    top.plot(t, data["pitch_deg"], color="C1", label="pitch")
    top.axhline(12.0, color="0.6", lw=0.8, ls=":", label="seed Fig. 15: about 12°")
    top.set_ylabel("pitch (deg)")
    top.legend(loc="best", fontsize=8)
    top.grid(alpha=0.3)
    bottom.plot(t, data["depth_m"] * 1000.0, color="C2", label="insertion depth (along the hole's axis)")
    bottom.plot(t, data["radial_m"] * 1000.0, color="C3", label="tip's offset from the hole's axis")
    bottom.axhline(0.0, color="0.6", lw=0.8)
    bottom.set_ylabel("tip (mm)")
    bottom.legend(loc="best", fontsize=8)
    bottom.set_xlabel("t (s)")
    bottom.grid(alpha=0.3)
    fig.suptitle(f"{title}: peg-in-hole under admittance control")
    fig.tight_layout()
    fig.savefig(out_path, dpi=110)
    plt.close(fig)


def wall_figure(data, title, out_path):
    t = data["t_s"]
    fig, axes = plt.subplots(2, 2, figsize=(13, 7), sharex=True)
    engaged = np.isfinite(data["target_fx"])
    for i, (name, unit) in enumerate(WRENCH):
        error = np.where(engaged, data[f"filtered_{name}"] - data[f"target_{name}"], np.nan)
        axes[0][i // 3].plot(t, error, label=name)
    for i, (name, unit) in enumerate(POSE):
        axes[1][i // 3].plot(t, data[f"error_{name}"], label=name)
    axes[0][0].set_ylabel("force error (N)")
    axes[0][1].set_ylabel("torque error (N·m)")
    axes[1][0].set_ylabel("position error (m)")
    axes[1][1].set_ylabel("attitude error (deg)")
    for ax in axes.flat:
        ax.legend(loc="best", fontsize=8)
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("t (s)")
    fig.suptitle(f"{title}: direct wrench control against a wall (errors: achieved − commanded)")
    fig.tight_layout()
    fig.savefig(out_path, dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) not in (4, 5) or sys.argv[3] not in ("peg_in_hole", "wall_push"):
        sys.exit(__doc__)
    csv_path, out_dir, task = sys.argv[1], sys.argv[2], sys.argv[3]
    title = sys.argv[4] if len(sys.argv) == 5 else os.path.basename(out_dir)
    # loadtxt parses in C (numpy >= 1.23); genfromtxt took 0.1-0.3 s a file
    with open(csv_path) as f:
        names = f.readline().strip().split(",")
    values = np.loadtxt(csv_path, delimiter=",", skiprows=1, ndmin=2)
    if values.shape[0] < 2:
        sys.exit(f"{csv_path}: fewer than two samples")
    data = np.rec.fromarrays(values.T, names=names)
    wrench_figure(data, title, os.path.join(out_dir, "contact_wrench.png"))
    if task == "peg_in_hole":
        peg_figure(data, title, os.path.join(out_dir, "peg_in_hole.png"))
    else:
        wall_figure(data, title, os.path.join(out_dir, "wall_push.png"))


if __name__ == "__main__":
    main()
