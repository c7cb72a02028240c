#!/usr/bin/env python3
"""Plots an `iapsim rl eval --out DIR` evaluation like the seed's Fig. 19(b).

usage: plot_docking.py DIR TITLE
  -> DIR/docking.png: the radial and axial docking errors d_xz and d_y of the traced episodes over time (each
     to the step its latch closed, marked), and the docking step of every successful episode.
"""
import csv
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")  # headless: CI has no display
import matplotlib.pyplot as plt


def main(folder, title):
    traces = defaultdict(lambda: defaultdict(list))
    with open(os.path.join(folder, "traces.csv")) as f:
        for row in csv.DictReader(f):
            trace = traces[int(row["episode"])]
            for key in ("t_s", "radial_error_m", "axial_error_m", "latched"):
                trace[key].append(float(row[key]))
    docked, outcomes = [], defaultdict(int)
    with open(os.path.join(folder, "episodes.csv")) as f:
        for row in csv.DictReader(f):
            outcomes[row["outcome"]] += 1
            if row["outcome"] == "success":
                docked.append(int(row["docked_step"]))

    fig, (radial, axial, steps) = plt.subplots(1, 3, figsize=(15, 4.2))
    for episode, trace in sorted(traces.items()):
        color = f"C{episode % 10}"
        radial.plot(trace["t_s"], [1e3 * v for v in trace["radial_error_m"]], color=color, lw=0.9)
        axial.plot(trace["t_s"], [1e3 * v for v in trace["axial_error_m"]], color=color, lw=0.9)
        if 1.0 in trace["latched"]:
            k = trace["latched"].index(1.0)
            axial.plot(trace["t_s"][k], 1e3 * trace["axial_error_m"][k], "k|", ms=12)
    radial.set(yscale="log", xlabel="t (s)", ylabel="d_xz (mm)", title="radial error (cone apex to face axis)")
    axial.set(yscale="symlog", xlabel="t (s)", ylabel="d_y (mm)", title="axial error (| latch closed)")
    for ax in (radial, axial):
        ax.grid(alpha=0.3, which="both")
    if docked:
        steps.hist(docked, bins=20, color="C0")
    total = sum(outcomes.values())
    summary = ", ".join(f"{name} {count}" for name, count in sorted(outcomes.items()))
    steps.set(xlabel="control step at which the latch closed", ylabel="episodes",
              title=f"{len(docked)} of {total} docked ({summary})")
    steps.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(os.path.join(folder, "docking.png"), dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
