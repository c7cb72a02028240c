#!/usr/bin/env bash
# The docking policy in the multi-process graph (iapsim_policy, configs/scenarios/docking_approach.yaml) flies
# as it does in the in-process environment: from the scenario's own start, noise-free, the expert's latch
# closes at the same control step and the episode ends at the same step in both; from eq. (23)'s random
# starts (`iapsim rl eval --graph`), noise-free, the expert's and a learned policy's episodes end alike at
# the same steps (a learned policy reads every observation, which the expert does not), with runs side by
# side; a failing run ends the evaluation with its reason; a bad policy parameter is a configuration error
# that names it.
# usage: policy_graph_test.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
# shellcheck source=tests/support/script.sh
source "$(dirname "$0")/../support/script.sh"

# the task with its observation noise off, and what else the sed expressions given say
noise_free() {
  sed -e "s|^scenario: .*|scenario: $src/configs/scenarios/docking_approach.yaml|" \
      -e 's|^  position_m: .*|  position_m: 0.0|' -e 's|^  attitude_deg: .*|  attitude_deg: 0.0|' \
      -e 's|^  velocity_mps: .*|  velocity_mps: 0.0|' -e 's|^  rate_radps: .*|  rate_radps: 0.0|' \
      -e 's|^  acceleration_mps2: .*|  acceleration_mps2: 0.0|' "$@" "$src/configs/rl/docking.yaml"
}

# eq. (23)'s box shrunk to the scenario's start (B 1.4 m behind A, level, at rest)
noise_free -e 's|b_offset_min_m: .*|b_offset_min_m: [0.0, -1.4, 0.0]|' \
  -e 's|b_offset_max_m: .*|b_offset_max_m: [0.0, -1.4, 0.0]|' -e 's|tilt_max_deg: .*|tilt_max_deg: 0.0|' \
  -e 's|yaw_max_deg: .*|yaw_max_deg: 0.0|' -e 's|speed_max_mps: .*|speed_max_mps: 0.0|' \
  -e 's|rate_max_deg_s: .*|rate_max_deg_s: 0.0|' > "$work/task.yaml"

"$iapsim" rl eval --task "$work/task.yaml" --episodes 1 --threads 1 --out "$work/env" > "$work/env.out"
# episode,seed,outcome,steps,docked_step,return
IFS=, read -r _ _ env_outcome env_steps env_docked _ < <(sed -n 2p "$work/env/episodes.csv")
[ "$env_outcome" = success ] || fail "the expert did not dock in the environment: $(cat "$work/env.out")"

"$iapsim" run "$src/configs/scenarios/docking_approach.yaml" --set "processes.policy.params.task=$work/task.yaml" \
  --set recording.enabled=false --out "$work/graph" > "$work/graph.out"
read -r outcome steps docked < <(/usr/bin/python3 -c "
import json, sys
p = json.load(open(sys.argv[1]))['processes']['policy']['process']
print(p['outcome'], p.get('outcome_step', -1), p.get('docked_step', -1))" "$work/graph/metrics.json")
echo "environment: $env_outcome at step $env_steps, docked at $env_docked; graph: $outcome at step $steps, docked at $docked"
[ "$outcome" = success ] || fail "the expert did not dock in the graph: $(cat "$work/graph/metrics.json")"
[ "$docked" -eq "$env_docked" ] || fail "the latch closed at step $docked in the graph, $env_docked in the environment"
[ "$steps" -eq "$env_steps" ] || fail "the episode ended at step $steps in the graph, $env_steps in the environment"

# eq. (23)'s starts, the noise off, flown in both by `rl eval --graph` (with a --set the process must see too)
noise_free > "$work/random_starts.yaml"
# a learned policy of two TD3-BC updates (it flies badly, the same way in both)
"$iapsim" rl train "$work/train" --task "$src/configs/rl/docking.yaml" --set termination.max_steps=50 \
  --expert-episodes 6 --td3bc-steps 2 --eval-every 2 --eval-episodes 1 --ppo-iterations 0 > /dev/null
for policy in expert "$work/train/td3bc/policy.pt"; do
  "$iapsim" rl eval --task "$work/random_starts.yaml" --policy "$policy" --episodes 3 --graph \
    --set termination.max_steps=1400 --out "$work/eval" > "$work/eval.out" 2> /dev/null
  grep -q "3 of 3 episodes end alike" "$work/eval.out" || fail "rl eval --graph of $policy: $(cat "$work/eval.out")"
  paste -d, "$work/eval/episodes.csv" "$work/eval/graph_episodes.csv" | tail -n +2 |
    while IFS=, read -r e _ outcome steps docked _ _ _ graph_outcome graph_steps graph_docked; do
      echo "$(basename "$policy") episode $e: $outcome at step $steps / $graph_steps, docked at $docked / $graph_docked (environment / graph)"
      [ "$outcome $steps $docked" = "$graph_outcome $graph_steps $graph_docked" ] || fail "episode $e differs"
    done
  grep -q '"graph"' "$work/eval/summary.json" || fail "summary.json has no graph figures"
done

set +e
# a run of the graph that fails (here: the policy process at a rate of its own, which the environment does
# not read) ends the evaluation with the episode, the reason and where the run's output is
"$iapsim" rl eval --task "$src/configs/rl/docking.yaml" --episodes 3 --graph --set 'scenario_set=["processes.policy.rate_hz=5"]' \
  --set termination.max_steps=100 --out "$work/bad_eval" > /dev/null 2> "$work/bad_eval.err"
code=$?
[ $code -eq 1 ] || fail "a failing graph run exited $code"
grep -q "in the graph: iapsim run exited with status 2: .*rate_hz: must be 0.*run.out)" "$work/bad_eval.err" ||
  fail "failing graph run: $(cat "$work/bad_eval.err")"
"$iapsim" run "$src/configs/scenarios/docking_approach.yaml" --set processes.policy.params.policy=nothing.pt \
  --set recording.enabled=false --out "$work/bad" 2> "$work/bad.err" > /dev/null
code=$?
set -e
[ $code -eq 2 ] || fail "a missing policy file exited $code"
grep -q "policy: no file 'nothing.pt'" "$work/bad.err" || fail "missing policy: $(cat "$work/bad.err")"
echo "ok"
