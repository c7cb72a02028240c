"""The iapsim_rl Python module: it steps the same environments as the C++ program (its observations equal
those `iapsim rl collect` writes for the same seed), its vector repeats itself on any thread count, and bad
input is a Python exception with the reason.

usage: python_module_test.py BUILD_BIN_DIR SOURCE_DIR (the module on PYTHONPATH)"""
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

import iapsim_rl

bin_dir, source_dir = sys.argv[1], sys.argv[2]
task = os.path.join(source_dir, "configs/rl/docking.yaml")
short = ["termination.max_steps=120"]


def check(condition, what):
    if not condition:
        raise AssertionError(what)


# 1. One expert episode from Python against the C++ program's data set of the same episode
with tempfile.TemporaryDirectory() as folder:
    data_file = os.path.join(folder, "expert.hdf5")
    subprocess.run([os.path.join(bin_dir, "iapsim"), "rl", "collect", data_file, "--task", task, "--episodes", "1",
                    "--seed", "4", "--threads", "1", "--set", short[0]], check=True, stdout=subprocess.DEVNULL)
    with h5py.File(data_file, "r") as data:
        observations = data["observations"][()]
        actions = data["actions"][()]
        rewards = data["rewards"][()]
        timeouts = data["timeouts"][()]

env = iapsim_rl.DockingEnv(task, overrides=short)
expert = iapsim_rl.Expert(env)
obs, info = env.reset(seed=iapsim_rl.stream_seed(4, 0))
expert.reset()
check(obs.shape == (iapsim_rl.observation_size,) and obs.dtype == np.float64, f"observation {obs.shape} {obs.dtype}")
steps, done = 0, False
while not done:
    check(np.array_equal(obs.astype(np.float32), observations[steps]), f"observation {steps} differs from C++'s")
    action = expert.act(obs)
    check(np.array_equal(action.astype(np.float32), actions[steps]), f"action {steps} differs from C++'s")
    obs, reward, terminated, truncated, info = env.step(action)
    check(np.float32(reward) == rewards[steps], f"reward {steps}: {reward} against {rewards[steps]}")
    steps += 1
    done = terminated or truncated
check(steps == len(observations) == 120 and truncated and timeouts[-1], f"{steps} steps, truncated {truncated}")
check(info["outcome"] == "timeout" and info["step"] == 120, f"info {info}")

# 2. The vector: auto-reset, final observations, the same on 1 and 2 threads
def roll_out(threads):
    envs = iapsim_rl.VectorEnv(task, num_envs=3, threads=threads, overrides=["termination.max_steps=30"])
    obs, _ = envs.reset(seed=2)
    random = np.random.default_rng(5)
    trace = [obs.copy()]
    ended = 0
    for _ in range(40):
        obs, rewards, terminated, truncated, info = envs.step(random.uniform(-0.3, 0.3, (3, 12)))
        trace += [obs.copy(), rewards.copy()]
        ended += int(truncated.sum())
        if truncated.any():
            check(info["outcome"][int(np.argmax(truncated))] == "timeout", f"outcomes {info['outcome']}")
            check(not np.array_equal(info["final_observation"][truncated], obs[truncated]), "final = reset")
    check(ended == 3, f"{ended} episodes ended in 40 steps of 30")
    return trace


one, two = roll_out(1), roll_out(2)
check(all(np.array_equal(a, b) for a, b in zip(one, two)), "1 and 2 threads differ")

# 3. Bad input
for call, error in [(lambda: env.step(np.zeros(11)), ValueError),
                    (lambda: iapsim_rl.DockingEnv(task, overrides=["reward.bonus=1"]), iapsim_rl.ConfigError),
                    (lambda: iapsim_rl.VectorEnv(task, num_envs=0), ValueError)]:
    try:
        call()
        check(False, "no exception")
    except error as raised:
        check(str(raised) != "", "an empty message")
try:
    iapsim_rl.DockingEnv(task, overrides=["reward.bonus=1"])
except ValueError as raised:
    check("reward.bonus" in str(raised), f"message: {raised}")
print("python_module_test: all checks passed")
