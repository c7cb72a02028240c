#!/usr/bin/env python3
"""Plots a training log of `iapsim rl train` (td3bc/log.csv) like the seed's Fig. 19(a).

usage: plot_training.py LOG_CSV OUT_PNG TITLE
  -> OUT_PNG: the success rate and the mean episode return of each evaluation, and the losses, per update.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")  # headless: CI has no display
import matplotlib.pyplot as plt


def main(log_path, out_path, title):
    with open(log_path) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{log_path}: no evaluations yet")
    column = {key: [float(row[key]) for row in rows] for key in rows[0]}
    step = column["step"]
    fig, (success, returns, losses) = plt.subplots(1, 3, figsize=(15, 4.2))
    success.plot(step, [100 * v for v in column["success_rate"]], "o-", color="C0")
    success.set(xlabel="update", ylabel="success (%)", ylim=(-5, 105), title="docked and hovering 1 s")
    returns.plot(step, column["return_mean"], "o-", color="C1")
    returns.set(xlabel="update", ylabel="mean episode return", title="return")
    losses.plot(step, column["critic_loss"], label="critic (twin TD)")
    losses.plot(step, column["behaviour_loss"], label="behaviour cloning")
    losses.set(xlabel="update", yscale="log", title="losses (means between evaluations)")
    losses.legend()
    for ax in (success, returns, losses):
        ax.grid(alpha=0.3)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out_path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
