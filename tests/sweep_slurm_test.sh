#!/usr/bin/env bash
# `iapsim sweep --slurm` on a one-node Slurm cluster the test brings up itself (munge, slurmctld, slurmd on
# 127.0.0.1, tools/slurm_local_cluster.sh), stopped afterwards by pid (issue 22): the same sweep on the local
# pool and as a job array gives the same table; a task killed outright is a failed run with its reason, and
# --resume reruns only it; Ctrl-C cancels the array and leaves nothing running; sbatch's refusal is reported.
# And a graph with a process started by srun inside an allocation (host: srun) records the one-host bag, and
# PPO's workers as srun's tasks train as the same workers started locally.
# usage: sweep_slurm_test.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
# shellcheck source=tests/support/script.sh
source "$(dirname "$0")/support/script.sh"
cluster=$src/tools/slurm_local_cluster.sh
trap '"$cluster" stop "$work/cluster"; rm -rf "$work"' EXIT
cluster_env=$(timeout 60 "$cluster" start "$work/cluster") || fail "the local cluster did not start: $(tail -n 5 "$work"/cluster/*.log)"
eval "$cluster_env"

# the spiral in the realistic profile (turbulence, noise and model mismatch drawn from the seed) at three
# mean winds, two seeds each: the tracking errors differ from run to run, and each is deterministic
cat > "$work/wind.yaml" << EOF
name: wind
scenario: $src/configs/regression/three_star_spiral.yaml
set: {fidelity: realistic, duration_s: 1, lead_in_s: 0}
grid:
  processes.physics.params.air.wind_W_mps: [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [4.0, 0.0, 0.0]]
seeds: [1, 2]
metrics: [tracking.position_rmse_m.x, tracking.position_rmse_m.z, tracking.attitude_rmse_deg.pitch]
keep_bags: false
EOF
"$iapsim" sweep "$work/wind.yaml" --out "$work/local" --jobs 2 > "$work/local.out" || fail "local: $(cat "$work/local.out")"
"$iapsim" sweep "$work/wind.yaml" --out "$work/slurm" --slurm > "$work/slurm.out" || fail "slurm: $(cat "$work/slurm.out")"
grep -q "submitted Slurm job array [0-9]* (6 tasks" "$work/slurm.out" || fail "slurm: $(cat "$work/slurm.out")"
grep -q "6 of 6 runs finished" "$work/slurm.out" || fail "slurm: $(cat "$work/slurm.out")"
# the same table but for the wall times; and one whose runs are told apart (not six copies of one number)
python3 - "$work/local/results.csv" "$work/slurm/results.csv" << 'PY' || fail "the local and Slurm tables differ"
import csv, sys
local, slurm = ([{k: v for k, v in row.items() if k != "wall_s"} for row in csv.DictReader(open(f))] for f in sys.argv[1:])
assert local == slurm, (local, slurm)
assert len({row["tracking.position_rmse_m.x"] for row in slurm}) == 6, slurm
PY
diff "$work/local/summary.csv" "$work/slurm/summary.csv" > "$work/diff" || fail "summaries differ: $(cat "$work/diff")"
[ -s "$work/slurm/plot_processes.physics.params.air.wind_W_mps.png" ] || fail "no plot: $(ls "$work/slurm")"
for run in "$work"/slurm/runs/*; do
  [ ! -e "$run/run.bag" ] || fail "keep_bags: false left $run/run.bag"
done

# a task killed outright (its sweep-task, SIGKILL) while the other two run: a failed run with the reason, the
# sweep exits 1, and --resume --slurm runs only that one
cat > "$work/seeds.yaml" << EOF
scenario: $src/configs/scenarios/bus_demo.yaml
set: {duration_s: 3}
seeds: [1, 2, 3]
EOF
"$iapsim" sweep "$work/seeds.yaml" --out "$work/seeds" --slurm > "$work/seeds.out" 2>&1 &
sweep=$!
task=""
for _ in $(seq 300); do
  task=$(pgrep -f "sweep-task $work/seeds " | head -1) && [ -n "$task" ] && break
  sleep 0.05
done
[ -n "$task" ] || fail "no task started: $(cat "$work/seeds.out")"
kill -9 "$task"
wait_code $sweep
[ $code -eq 1 ] || fail "a sweep with a killed task exited $code: $(cat "$work/seeds.out")"
grep -q "2 of 3 runs finished" "$work/seeds.out" || fail "killed: $(cat "$work/seeds.out")"
grep -q ",failed,,,.*ended without recording an outcome" "$work/seeds/results.csv" ||
  fail "the killed run's row: $(cat "$work/seeds/results.csv")"
"$iapsim" sweep "$work/seeds.yaml" --out "$work/seeds" --resume --slurm > "$work/seeds2.out" ||
  fail "resume: $(cat "$work/seeds2.out")"
grep -q "2 finished before, 1 to run" "$work/seeds2.out" || fail "resume: $(cat "$work/seeds2.out")"
[ "$(grep -c ',completed,0,' "$work/seeds/results.csv")" -eq 3 ] || fail "results: $(cat "$work/seeds/results.csv")"

# Ctrl-C while the array runs: cancelled, reported as interrupted, nothing left running or queued
sed -i 's/duration_s: 3/duration_s: 30/' "$work/seeds.yaml"
"$iapsim" sweep "$work/seeds.yaml" --out "$work/long" --slurm > "$work/long.out" 2>&1 &
sweep=$!
for _ in $(seq 300); do
  pgrep -f "$work/long/runs" > /dev/null && break
  sleep 0.05
done
kill -INT $sweep
wait_code $sweep
[ $code -eq 130 ] || fail "an interrupted sweep exited $code: $(cat "$work/long.out")"
grep -q "cancelling Slurm job" "$work/long.out" || fail "interrupted: $(cat "$work/long.out")"
[ "$(grep -c ',interrupted,' "$work/long/results.csv")" -eq 3 ] || fail "results: $(cat "$work/long/results.csv")"
if pgrep -f "$work/long" > /dev/null; then fail "processes of the cancelled sweep are still running"; fi
[ -z "$(squeue --noheader)" ] || fail "jobs left queued: $(squeue)"

# sbatch refuses: its message, exit 1, and the sweep can be resumed elsewhere
set +e
"$iapsim" sweep "$work/seeds.yaml" --out "$work/refused" --slurm --partition no_such_partition > /dev/null 2> "$work/refused.err"
code=$?
set -e
[ $code -eq 1 ] || fail "a refused array exited $code"
grep -q "sbatch failed .*[Ii]nvalid partition" "$work/refused.err" || fail "refused: $(cat "$work/refused.err")"
[ -s "$work/refused/sweep.json" ] || fail "a refused sweep cannot be resumed"

# a graph with its sensors as a job step of the allocation the run is in (host: srun, on the node's
# NodeAddr over tcp): the bag is the one-host run's, byte for byte
graph=("$src/configs/scenarios/three_star_sensors.yaml" --set duration_s=1 --set bus.transport=tcp)
node=$(sinfo --noheader -o %n | head -1)
"$iapsim" run "${graph[@]}" --out "$work/graph_one" > "$work/graph_one.out" 2>&1 || fail "one host: $(cat "$work/graph_one.out")"
step=(--set processes.sensors.host=srun --set "processes.sensors.slurm_node=$node")
salloc --nodes=1 --quiet "$iapsim" run "${graph[@]}" "${step[@]}" --out "$work/graph_srun" > "$work/graph_srun.out" 2>&1 ||
  fail "srun: $(cat "$work/graph_srun.out")"
grep -q "started sensors (pid [0-9]*, a job step on $node)" "$work/graph_srun/log.txt" || fail "srun: $(cat "$work/graph_srun/log.txt")"
cmp "$work/graph_one/run.bag" "$work/graph_srun/run.bag" || fail "the bag of the graph with a job step differs"
expect_exit 2 "processes.sensors.host: srun starts the process in the Slurm allocation iapsim run is in, and there is none" \
  env -u SLURM_JOB_ID "$iapsim" run "${graph[@]}" "${step[@]}"
expect_exit 2 "processes.sensors.slurm_node: 'no_such_node' is not a node of the cluster" \
  salloc --nodes=1 --quiet "$iapsim" run "${graph[@]}" --set processes.sensors.host=srun --set processes.sensors.slurm_node=no_such_node

# PPO's workers as the tasks of `srun --ntasks=2`: the log of two workers this process starts itself
rl=(--task "$src/configs/rl/docking.yaml" --set termination.max_steps=200 --expert-episodes 2 --eval-every 2
    --eval-episodes 1 --ppo-envs 2 --ppo-rollout-steps 20 --ppo-eval-every 1 --td3bc-steps 2)
"$iapsim" rl train "$work/rl" "${rl[@]}" --ppo-iterations 0 > "$work/rl.out" || fail "td3bc: $(cat "$work/rl.out")"
rl+=(--ppo-iterations 2)
"$iapsim" rl train "$work/rl_local" "${rl[@]}" --stage ppo --ppo-init "$work/rl/td3bc/policy.pt" --ppo-workers 2 \
  > "$work/rl_local.out" || fail "2 local workers: $(cat "$work/rl_local.out")"
# (Gloo on the interface GLOO_SOCKET_IFNAME names, as PyTorch's workers)
GLOO_SOCKET_IFNAME=lo srun --ntasks=2 --quiet "$iapsim" rl train "$work/rl_srun" "${rl[@]}" --stage ppo \
  --ppo-init "$work/rl/td3bc/policy.pt" --ppo-workers 2 > "$work/rl_srun.out" 2>&1 || fail "srun: $(cat "$work/rl_srun.out")"
[ "$(grep -c "ppo: from" "$work/rl_srun.out")" -eq 1 ] || fail "srun: not one first worker: $(cat "$work/rl_srun.out")"
cmp <(cut -d, -f1-16 "$work/rl_local/ppo/log.csv") <(cut -d, -f1-16 "$work/rl_srun/ppo/log.csv") ||
  fail "srun's workers differ from local ones: $(cat "$work/rl_local/ppo/log.csv" "$work/rl_srun/ppo/log.csv")"
expect_exit 2 "--ppo-workers 3: srun started 2 tasks" \
  srun --ntasks=2 --quiet "$iapsim" rl train "$work/rl_srun" "${rl[@]}" --stage ppo --ppo-init "$work/rl/td3bc/policy.pt" --ppo-workers 3
expect_exit 2 "--stage all under srun --ntasks=2" srun --ntasks=2 --quiet "$iapsim" rl train "$work/rl_all" "${rl[@]}" --ppo-workers 2
[ -z "$(squeue --noheader)" ] || fail "jobs left queued: $(squeue)"

echo "sweep_slurm_test: all checks passed"
