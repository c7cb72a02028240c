#!/usr/bin/env python3
"""Plots a sweep's metrics against each swept key (`iapsim sweep`, tools/sweep.h): one figure per key, a panel
per metric, a line per combination of the other swept keys (their mean when there are more than six), each
point the mean over the finished runs with that value (the seeds) and the shaded band their min..max. A key
whose values are not all numbers (a vector, a name) is spaced evenly and labelled with its values.

usage: plot_sweep.py SWEEP_DIR   (reads SWEEP_DIR/sweep.json and results.csv, writes SWEEP_DIR/plot_KEY.png)
"""
import csv
import json
import math
import os
import re
import sys

import matplotlib

matplotlib.use("Agg")  # headless: CI and sweeps on a cluster have no display
import matplotlib.pyplot as plt

FIXED = {"id", "group", "seed", "status", "exit_code", "wall_s", "reason"}
FINISHED = {"completed", "completed_with_losses"}
MAX_LINES = 6


def number(text):
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    directory = sys.argv[1]
    with open(os.path.join(directory, "sweep.json")) as f:
        keys = json.load(f)["swept_keys"]
    with open(os.path.join(directory, "results.csv")) as f:
        rows = [row for row in csv.DictReader(f) if row["status"] in FINISHED]
    if not keys or not rows:
        return  # nothing swept, or nothing finished: the tables say so
    metrics = [c for c in rows[0].keys() if c not in FIXED and c not in keys]
    metrics.append("wall_s")
    for key in keys:
        values = list(dict.fromkeys(row[key] for row in rows))
        numeric = all(number(v) is not None for v in values)
        position = {v: (number(v) if numeric else i) for i, v in enumerate(values)}
        others = [k for k in keys if k != key]
        lines = list(dict.fromkeys(tuple(row[k] for k in others) for row in rows))
        if len(lines) > MAX_LINES:
            lines = [None]  # too many to tell apart: every other setting pooled
        columns = min(3, len(metrics))
        panels = math.ceil(len(metrics) / columns)
        fig, axes = plt.subplots(panels, columns, figsize=(4.2 * columns, 3.2 * panels), squeeze=False)
        for m, metric in enumerate(metrics):
            ax = axes[m // columns][m % columns]
            for line in lines:
                xs, means, lows, highs = [], [], [], []
                for v in values:
                    samples = [number(row[metric]) for row in rows
                               if row[key] == v and (line is None or tuple(row[k] for k in others) == line)]
                    samples = [s for s in samples if s is not None]
                    if not samples:
                        continue
                    xs.append(position[v])
                    means.append(sum(samples) / len(samples))
                    lows.append(min(samples))
                    highs.append(max(samples))
                if not xs:
                    continue
                label = "all" if line is None else ", ".join(f"{k.split('.')[-1]}={v}" for k, v in zip(others, line))
                drawn = ax.plot(xs, means, "o-", linewidth=1.2, markersize=4, label=label or None)
                ax.fill_between(xs, lows, highs, color=drawn[0].get_color(), alpha=0.2, linewidth=0)
            ax.set_title(metric, fontsize=9)
            ax.grid(True, alpha=0.3)
            if not numeric:
                ax.set_xticks(range(len(values)))
                ax.set_xticklabels(values, fontsize=7, rotation=20)
            ax.set_xlabel(key.split(".")[-1], fontsize=8)
        for m in range(len(metrics), panels * columns):
            axes[m // columns][m % columns].axis("off")
        if others and lines != [None]:
            axes[0][0].legend(fontsize=7, loc="best")
        fig.suptitle(f"{key}: mean over seeds, band min..max ({len(rows)} finished runs)", fontsize=10)
        fig.tight_layout()
        name = re.sub(r"[^A-Za-z0-9_.-]", "_", key)
        fig.savefig(os.path.join(directory, f"plot_{name}.png"), dpi=110)
        plt.close(fig)


if __name__ == "__main__":
    main()
