#!/usr/bin/env python3
"""Plots a training log of `iapsim rl train` (td3bc/, iql/ or ppo/log.csv) like the seed's Fig. 19(a).

usage: plot_training.py LOG_CSV OUT_PNG TITLE
  -> OUT_PNG: the success rate and the mean episode return of each evaluation (PPO: also of each iteration's
     rollouts, with exploration noise), and the losses, per update (TD3-BC, IQL) or iteration (PPO).
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")  # headless: CI has no display
import matplotlib.pyplot as plt


def number(text):
    return float(text) if text != "" else math.nan  # PPO leaves evaluation columns empty between evaluations


def main(log_path, out_path, title):
    with open(log_path) as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{log_path}: no rows yet")
    column = {key: [number(row[key]) for row in rows] for key in rows[0]}
    x_name = next(iter(rows[0]))  # step (TD3-BC's updates) or iteration (PPO's)
    x = column[x_name]
    evaluated = [i for i, v in enumerate(column["success_rate"]) if not math.isnan(v)]
    fig, (success, returns, losses) = plt.subplots(1, 3, figsize=(15, 4.2))
    success.plot([x[i] for i in evaluated], [100 * column["success_rate"][i] for i in evaluated], "o-",
                 color="C0", label="evaluation (deterministic)")
    returns.plot([x[i] for i in evaluated], [column["return_mean"][i] for i in evaluated], "o-", color="C1",
                 label="evaluation")
    if "rollout_success_rate" in column:
        success.plot(x, [100 * v for v in column["rollout_success_rate"]], ".", color="C2", alpha=0.6,
                     label="rollouts (exploring)")
        returns.plot(x, column["rollout_return_mean"], ".", color="C2", alpha=0.6, label="rollouts")
    success.set(xlabel=x_name, ylabel="success (%)", ylim=(-5, 105), title="docked and hovering 1 s")
    returns.set(xlabel=x_name, ylabel="mean episode return", title="return")
    for key, label in (("critic_loss", "critic (twin TD)"), ("behaviour_loss", "behaviour cloning"),
                       ("value_loss", "value (PPO: scaled returns; IQL: expectile)"), ("approx_kl", "approx. KL")):
        if key in column:
            losses.plot(x, column[key], label=label)
    losses.set(xlabel=x_name, yscale="log", title="losses (means per row)")
    for ax in (success, returns, losses):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(out_path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
