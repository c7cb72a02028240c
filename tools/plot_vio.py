#!/usr/bin/env python3
"""Plots what `iapsim vio --mode all` and `--mode anchors` write, like the seed's Fig. 17 and Table VII.

usage: plot_vio.py modes FOLDER    FOLDER/{vio,vio_uwb,virpo}/vio.json and their TUM files ->
                                   FOLDER/ate_boxplot.png  (position error at every image stamp, quartiles,
                                                           by body and mode: Fig. 17's box plots)
                                   FOLDER/trajectories.png (top view and height over time of each body's
                                                           truth and estimates)
       plot_vio.py anchors FOLDER  FOLDER/table.json -> FOLDER/anchors.png (ATE RMSE by anchor count)

The errors are the ATE's own: each estimate against the truth at the same stamp, as `iapsim vio` reports
its ATE RMSE (each estimate is tied to its first ground truth; no alignment).
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")  # headless: CI has no display
import matplotlib.pyplot as plt
import numpy as np

MODES = [("vio", "VIO"), ("vio_uwb", "VIO+UWB"), ("virpo", "VIRPO")]
COLOURS = {"vio": "tab:blue", "vio_uwb": "tab:orange", "virpo": "tab:green"}


def read_tum(path):
    """{stamp in ns: (x, y, z)} of a TUM file (stamps in s with 9 decimals, as iapsim writes them)."""
    out = {}
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            fields = line.split()
            out[int(round(float(fields[0]) * 1e9))] = np.array([float(v) for v in fields[1:4]])
    return out


def body_tracks(folder, mode):
    """{body: (t_s, estimate Nx3, truth Nx3)} at the stamps both have, from FOLDER/MODE/vio.json."""
    report_dir = os.path.join(folder, mode)
    report = json.load(open(os.path.join(report_dir, "vio.json")))
    entries = dict(report["sub_aircraft"])
    if "centre" in report:
        entries[report["centre"]["body"]] = report["centre"]
    tracks = {}
    for body, entry in entries.items():
        estimate = read_tum(os.path.join(report_dir, entry["estimate_tum"]))
        truth = read_tum(os.path.join(report_dir, entry["truth_tum"]))
        stamps = sorted(set(estimate) & set(truth))
        if len(stamps) < 2:
            sys.exit(f"{report_dir}: {body}: fewer than two stamps with both an estimate and the truth")
        tracks[body] = (np.array(stamps) * 1e-9, np.array([estimate[t] for t in stamps]),
                        np.array([truth[t] for t in stamps]))
    return tracks


def plot_modes(folder):
    tracks = {mode: body_tracks(folder, mode) for mode, _ in MODES}
    bodies = list(tracks["vio"])

    fig, ax = plt.subplots(figsize=(2.2 + 1.8 * len(bodies), 4.2))
    width = 0.26
    for m, (mode, label) in enumerate(MODES):
        errors = [np.linalg.norm(tracks[mode][b][1] - tracks[mode][b][2], axis=1) for b in bodies]
        positions = np.arange(len(bodies)) + (m - 1) * width
        boxes = ax.boxplot(errors, positions=positions, widths=width * 0.85, patch_artist=True, showfliers=False,
                           medianprops={"color": "black"})
        for box in boxes["boxes"]:
            box.set_facecolor(COLOURS[mode])
            box.set_alpha(0.75)
        ax.plot([], [], "s", color=COLOURS[mode], label=label)
    ax.set_xticks(np.arange(len(bodies)))
    ax.set_xticklabels(bodies)
    ax.set_ylabel("position error (m)")
    ax.set_title("ATE per image stamp (boxes: quartiles, whiskers: 1.5 IQR)")
    ax.grid(axis="y", alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "ate_boxplot.png"), dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(2, len(bodies), figsize=(3.6 * len(bodies), 7), squeeze=False)
    for b, body in enumerate(bodies):
        top, height = axes[0][b], axes[1][b]
        t, _, truth = tracks["vio"][body]
        # NED: north (x) up the page, east (y) to the right, height = -z
        top.plot(truth[:, 1], truth[:, 0], color="black", lw=1.6, label="truth")
        height.plot(t, -truth[:, 2], color="black", lw=1.6, label="truth")
        for mode, label in MODES:
            t, estimate, _ = tracks[mode][body]
            top.plot(estimate[:, 1], estimate[:, 0], color=COLOURS[mode], lw=0.9, label=label)
            height.plot(t, -estimate[:, 2], color=COLOURS[mode], lw=0.9, label=label)
        top.set_title(body)
        top.set_xlabel("east y (m)")
        top.set_ylabel("north x (m)")
        top.set_aspect("equal", adjustable="datalim")
        height.set_xlabel("t (s)")
        height.set_ylabel("height -z (m)")
        for ax in (top, height):
            ax.grid(alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "trajectories.png"), dpi=110)
    plt.close(fig)


def plot_anchors(folder):
    table = json.load(open(os.path.join(folder, "table.json")))
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for body, row in table.items():
        counts = sorted(int(k.split("_")[1]) for k in row if k.startswith("anchors_"))
        ax.plot(counts, [row["anchors_%d" % n] for n in counts], "o-", label=body)
    ax.set_xlabel("number of UWB anchors")
    ax.set_ylabel("ATE RMSE (m)")
    ax.set_xticks(counts)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "anchors.png"), dpi=110)
    plt.close(fig)


def main():
    if len(sys.argv) != 3 or sys.argv[1] not in ("modes", "anchors"):
        sys.exit(__doc__)
    (plot_modes if sys.argv[1] == "modes" else plot_anchors)(sys.argv[2])


if __name__ == "__main__":
    main()
