#!/usr/bin/env bash
# End-to-end test of the iapsim program as a user runs it: run (one process started by hand too), info, export,
# topics, echo, bench record, rl collect, eval and train (two PPO workers), bad configuration, SIGTERM of a
# running launcher (clean stop, no process left behind).
# usage: cli_test.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
# shellcheck source=tests/support/script.sh
source "$(dirname "$0")/support/script.sh"

# usage: a mistyped command is answered with the closest ones (exit 2, as any usage error); --version
expect_exit 2 "'swep' is not a command; did you mean sweep?" "$iapsim" swep x.yaml
expect_exit 2 "did you mean run or rl?" "$iapsim" rn
expect_exit 2 "the commands are run, replay," "$iapsim" fly
expect_exit 2 "scenario is required" "$iapsim" run
expect_exit 2 "iapsim rl: 'tran' is not a command; did you mean train?" "$iapsim" rl tran DIR
"$iapsim" --version | grep -qx "iapsim [0-9]*\.[0-9]*\.[0-9]*" || fail "--version: $("$iapsim" --version)"

# every subcommand answers --help
for cmd in run replay info "bag reindex" export video topics echo urdf bench sweep rl "rl eval" "rl collect" \
  "rl train" vio; do
  # shellcheck disable=SC2086  # "rl eval" is a subcommand and its subcommand
  "$iapsim" $cmd --help > "$work/help.out" || fail "$cmd --help"
  grep -q "^Examples:" "$work/help.out" || fail "$cmd --help shows no examples"
done
# and the defaults
"$iapsim" topics --help | grep -q -- "--listen FLOAT=1 " || fail "topics --help shows no default: $("$iapsim" topics --help)"
if "$iapsim" sweep --help | grep -q "=0"; then fail "sweep --help shows a 0 that stands for 'not set': $("$iapsim" sweep --help)"; fi
"$iapsim" rl train --help | grep -Eq -- "--ppo-workers INT:INT in \[1 - 4096\]=1( |$)" ||
  fail "rl train --help shows no default: $("$iapsim" rl train --help)"
"$iapsim" vio --help | grep -Eq -- "--mode TEXT:\{vio,vio_uwb,virpo,all,anchors\}=vio( |$)" ||
  fail "vio --help shows no default: $("$iapsim" vio --help)"

# a short lockstep run with a complete run directory
"$iapsim" run "$src/configs/scenarios/bus_demo.yaml" --duration 1 --seed 3 --out "$work/run" > "$work/run.out"
grep -q "run complete: $work/run" "$work/run.out" || fail "no completion line: $(cat "$work/run.out")"
for f in scenario.resolved.yaml run.bag metrics.json log.txt logs/physics.log; do
  [ -s "$work/run/$f" ] || fail "run directory lacks $f"
done
grep -q "seed: 3" "$work/run/scenario.resolved.yaml" || fail "--seed not in the resolved scenario"

# one process started by hand (host: external, as under a debugger) on the default shared-memory bus: the
# launcher prints its command (the run folder's path quoted: it has a space) and waits for it, and the run
# records the same bag (after a start with the wrong secret, refused)
"$iapsim" run "$src/configs/scenarios/bus_demo.yaml" --duration 1 --seed 3 --set processes.control.host=external \
  --out "$work/by hand" > "$work/by_hand.out" 2>&1 &
run=$!
for _ in $(seq 200); do [ -x "$work/by hand/external/control.sh" ] && break; sleep 0.05; done
# first with another run's secret: the launcher refuses it, and it says so and exits 1 at once (not after its
# hang_timeout_s); the run waits on for the real one
set +e
IAPSIM_RUN_SECRET=$(printf '%064d' 0) timeout 60 "$work/by hand/external/control.sh" > "$work/by_hand_refused.log" 2>&1
code=$?
set -e
[ $code -eq 1 ] || fail "control with another run's secret exited $code: $(cat "$work/by_hand_refused.log")"
grep -q "refused 'control': not a process of its run, or another run's secret" "$work/by_hand_refused.log" ||
  fail "control with another run's secret: $(cat "$work/by_hand_refused.log")"
"$work/by hand/external/control.sh" > "$work/by_hand_control.log" 2>&1 || fail "control by hand: $(cat "$work/by_hand_control.log")"
wait_code $run
[ "$code" -eq 0 ] || fail "a run with a process started by hand exited $code: $(cat "$work/by_hand.out")"
grep -q "waiting up to 600 s for 'control', started elsewhere:" "$work/by_hand.out" || fail "no command: $(cat "$work/by_hand.out")"
grep -qF -- "--scenario '$work/by hand/scenario.resolved.yaml' --node control" "$work/by_hand.out" ||
  fail "the command does not quote the run folder: $(cat "$work/by_hand.out")"
cmp "$work/run/run.bag" "$work/by hand/run.bag" || fail "the bag with control started by hand differs"

"$iapsim" info "$work/run/run.bag" > "$work/info.out"
grep -Eq "^/iap/state +iapsim_msgs/IapState +1001 +1000.00" "$work/info.out" || fail "info: $(cat "$work/info.out")"
"$iapsim" export "$work/run/run.bag" --topic /iap/state --format tum --pose-field 'bodies[0].pose_W' -o "$work/gt.tum"
[ "$(wc -l < "$work/gt.tum")" -eq 1001 ] || fail "tum export has $(wc -l < "$work/gt.tum") lines"
"$iapsim" export "$work/run/run.bag" --topic /iap/uwb --format csv > "$work/uwb.csv"
head -1 "$work/uwb.csv" | grep -q "^time_s,header.seq,header.stamp" || fail "csv header: $(head -1 "$work/uwb.csv")"
[ "$(wc -l < "$work/uwb.csv")" -eq 202 ] || fail "csv has $(wc -l < "$work/uwb.csv") lines"

# replay: the recorded UWB ranges played into a new run under another name
"$iapsim" replay "$work/run/run.bag" --scenario "$src/configs/scenarios/bus_demo.yaml" --topics /iap/uwb \
  --map /iap/uwb:=/old/uwb --duration 1 --out "$work/replayed" > /dev/null
"$iapsim" info "$work/replayed/run.bag" > "$work/replayed.out"
grep -Eq "^/old/uwb +iapsim_msgs/UwbRanges +201 " "$work/replayed.out" || fail "replay: $(cat "$work/replayed.out")"
# restamp: false keeps the recorded header stamps (played at the same re-based times): the first
# replayed message carries the recording's first stamp, not its own play time
stamp_of_first() { "$iapsim" export "$1" --topic "$2" --format csv 2> /dev/null | sed -n 2p | cut -d, -f3; }
"$iapsim" replay "$work/run/run.bag" --scenario "$src/configs/scenarios/bus_demo.yaml" --topics /iap/uwb \
  --map /iap/uwb:=/old/uwb --duration 1 --out "$work/replayed_kept" \
  --set processes.replayer.params.restamp=false > /dev/null
recorded=$(stamp_of_first "$work/run/run.bag" /iap/uwb)
[ "$(stamp_of_first "$work/replayed_kept/run.bag" /old/uwb)" = "$recorded" ] || fail "restamp false changed the stamp"
[ "$(stamp_of_first "$work/replayed/run.bag" /old/uwb)" != "$recorded" ] || fail "restamp kept the recorded stamp"
# replay of a pose file: the poses need a topic; a bad line is named with its file and line number
replay_square=(--scenario "$src/configs/scenarios/three_square_replay.yaml" --duration 1 --out "$work/replayed_file")
printf 't_s,x_m,y_m,z_m,qx,qy,qz,qw\n5.0,0,0,-2,0,0,0,1\n5.02,0,0,-2,0,0,0.5,1\n' > "$work/cmd.csv"
expect_exit 2 "a csv pose file needs --topic" "$iapsim" replay "$work/cmd.csv" "${replay_square[@]}"
expect_exit 2 "are for a bag" "$iapsim" replay "$work/cmd.csv" "${replay_square[@]}" --topic /iap/pose_cmd --as-pose
expect_exit 2 "cmd.csv:3: quaternion (qx qy qz qw) has norm 1.11803" \
  "$iapsim" replay "$work/cmd.csv" "${replay_square[@]}" --topic /iap/pose_cmd
expect_exit 2 "reference.shaping.max_rate_dps: expected 3 positive numbers" "$iapsim" replay "$work/cmd.csv" \
  "${replay_square[@]}" --topic /iap/pose_cmd --set 'processes.control.params.reference.shaping.max_rate_dps=[30, 0, 30]'
expect_exit 2 "shaping.velocity_time_constant_s: unknown key" "$iapsim" replay "$work/cmd.csv" "${replay_square[@]}" \
  --topic /iap/pose_cmd --set processes.control.params.reference.shaping.velocity_time_constant_s=0.1

# the flight envelope: a replayed pose command 1e6 m away (and one tilted 80 degrees) is refused and
# counted, and the IAP holds where the last admitted command put it
printf 't_s,x_m,y_m,z_m,qx,qy,qz,qw\n0.2,0,0,-2,0,0,0,1\n0.5,1000000,0,-2,0,0,0,1\n0.8,0,0,-2,0.6428,0,0,0.7660\n' \
  > "$work/far.csv"
"$iapsim" replay "$work/far.csv" --scenario "$src/configs/scenarios/three_square_replay.yaml" --duration 2 \
  --topic /iap/pose_cmd --out "$work/far" --set processes.control.params.envelope.action=reject \
  > "$work/far.out" 2>&1 || fail "envelope replay: $(cat "$work/far.out")"
grep -q "outside the flight envelope ( geofence speed) was rejected" "$work/far/logs/control.log" ||
  fail "no envelope warning: $(cat "$work/far/logs/control.log")"
"$iapsim" export "$work/far/run.bag" --topic /iap/odom --format tum -o "$work/far.tum" 2> /dev/null
/usr/bin/python3 -c "
import json, sys
e = json.load(open(sys.argv[1]))['processes']['control']['process']['envelope']
assert e['commands'] == 3 and e['rejected'] == 2 and e['outside_geofence'] == 1 and e['too_tilted'] == 1, e
xs = [abs(float(line.split()[1])) for line in open(sys.argv[2])]
assert max(xs) < 0.1, max(xs)
" "$work/far/metrics.json" "$work/far.tum" || fail "envelope: $(cat "$work/far/metrics.json" | head -c 600)"

# bench record runs every variant of a scenario, prints the targets' verdicts and writes its figures
"$iapsim" bench record --scenario "$src/configs/scenarios/bus_demo.yaml" --repeat 1 --json "$work/bench.json" \
  > "$work/bench.out"
grep -q "targets: recorded <= 1.3x unrecorded" "$work/bench.out" || fail "bench record: $(cat "$work/bench.out")"
/usr/bin/python3 -c "
import json, sys
r = json.load(open(sys.argv[1]))['record']
assert r['unrecorded']['messages'] == 0 and r['recorded']['messages'] == 16004, r
assert r['recorded_lz4']['messages'] == 16004 and r['recorded_lz4']['bag_bytes'] < r['recorded']['bag_bytes'], r
assert r['recorded']['bag_bytes'] > 0 and len(r['recorded']['wall_s']) == 1, r
" "$work/bench.json" || fail "bench record: figures $(cat "$work/bench.json")"

# interaction control is checked before anything flies: a mode it cannot work in, a section for the other law
check_process() {  # EXEC SCENARIO NODE TEXT ARGS...: expects exit 2 and TEXT from the process's --check
  set +e
  "$bin/$1" --scenario "$src/configs/$2" --node "$3" --check "${@:5}" > "$work/check.out" 2>&1
  local code=$?
  set -e
  [ $code -eq 2 ] || fail "$1 --check ${*:5} exited $code: $(cat "$work/check.out")"
  grep -q "$4" "$work/check.out" || fail "$1 --check ${*:5}: $(cat "$work/check.out")"
}
check_control() { check_process iapsim_control regression/wall_push.yaml control "$@"; }
check_control "interaction: needs mode: track" --set processes.control.params.mode=hover
check_control "wrench_control: unknown key" --set processes.control.params.interaction=admittance

# vehicle description to URDF (type="spherical" joints, one per sub-aircraft)
"$iapsim" urdf "$src/configs/vehicles/three_star.yaml" -o "$work/three_star.urdf" 2> /dev/null
[ "$(grep -c '<joint name="sub[0-9]_joint" type="spherical">' "$work/three_star.urdf")" -eq 3 ] || fail "urdf: $(cat "$work/three_star.urdf")"
printf 'name: x\nplatform: {mass_kg: -1}\n' > "$work/bad_vehicle.yaml"
set +e
"$iapsim" urdf "$work/bad_vehicle.yaml" > /dev/null 2> "$work/bad_vehicle.err"
code=$?
set -e
[ $code -eq 2 ] || fail "bad vehicle exited $code"
grep -q "bad_vehicle.yaml:2:" "$work/bad_vehicle.err" || fail "bad vehicle: $(cat "$work/bad_vehicle.err")"

# the docking task: two short episodes collected as an HDF5 data set, evaluated into a folder; a wrong key
"$iapsim" rl collect "$work/rl/expert.hdf5" --task "$src/configs/rl/docking.yaml" --episodes 2 --threads 1 --set termination.max_steps=40 > "$work/collect.out"
grep -q "2 episodes .* 80 transitions" "$work/collect.out" || fail "rl collect: $(cat "$work/collect.out")"
[ -s "$work/rl/expert.hdf5" ] && [ ! -e "$work/rl/expert.hdf5.partial" ] || fail "rl collect left no complete file"
"$iapsim" rl eval --task "$src/configs/rl/docking.yaml" --episodes 2 --set termination.max_steps=40 --out "$work/eval" > "$work/eval.out"
grep -q "success        0.0 %" "$work/eval.out" || fail "rl eval: $(cat "$work/eval.out")"
grep -q '"timeouts": 2' "$work/eval/summary.json" || fail "rl eval: $(cat "$work/eval/summary.json")"
[ "$(wc -l < "$work/eval/traces.csv")" -eq 81 ] || fail "rl eval traces: $(wc -l < "$work/eval/traces.csv") lines"
[ -s "$work/eval/docking.png" ] || fail "rl eval drew no docking.png"
# the pipeline in miniature: expert data, four TD3-BC updates, two PPO iterations; then each learner goes on
# from its checkpoint; both policies are evaluated as TorchScript files
train=(--task "$src/configs/rl/docking.yaml" --set termination.max_steps=200 --expert-episodes 2 --eval-every 2
       --eval-episodes 1 --ppo-envs 2 --ppo-rollout-steps 20 --ppo-eval-every 1 --ppo-value-warmup 1)
"$iapsim" rl train "$work/train" "${train[@]}" --td3bc-steps 4 --ppo-iterations 2 > "$work/train.out"
for f in expert/data.hdf5 expert/summary.json td3bc/checkpoint.pt td3bc/policy.pt td3bc/log.csv td3bc/curves.png \
         ppo/checkpoint.pt ppo/policy.pt ppo/log.csv ppo/curves.png; do
  [ -s "$work/train/$f" ] || fail "rl train wrote no $f: $(cat "$work/train.out")"
done
"$iapsim" rl train "$work/train" "${train[@]}" --td3bc-steps 6 --ppo-iterations 3 > "$work/train.out"
grep -q "expert: .* is there, kept" "$work/train.out" || fail "rl train redid the expert: $(cat "$work/train.out")"
grep -q "td3bc: resuming from .* at update 4" "$work/train.out" || fail "rl train did not resume: $(cat "$work/train.out")"
[ "$(cut -d, -f1 "$work/train/td3bc/log.csv" | tr '\n' ' ')" = "step 2 4 6 " ] || fail "rl train log: $(cat "$work/train/td3bc/log.csv")"
grep -q "ppo: resuming from .* at iteration 2" "$work/train.out" || fail "rl train did not resume PPO: $(cat "$work/train.out")"
[ "$(cut -d, -f1 "$work/train/ppo/log.csv" | tr '\n' ' ')" = "iteration 1 2 3 " ] || fail "rl train PPO log: $(cat "$work/train/ppo/log.csv")"
# IQL on the same data: its files and a resumed run; then the whole pipeline with --offline iql, PPO from IQL
"$iapsim" rl train "$work/train" "${train[@]}" --stage iql --iql-steps 2 > "$work/iql.out"
"$iapsim" rl train "$work/train" "${train[@]}" --stage iql --iql-steps 4 > "$work/iql.out"
grep -q "iql: resuming from .* at update 2" "$work/iql.out" || fail "rl train did not resume IQL: $(cat "$work/iql.out")"
[ "$(cut -d, -f1 "$work/train/iql/log.csv" | tr '\n' ' ')" = "step 2 4 " ] && head -1 "$work/train/iql/log.csv" | grep -q ",value_loss," ||
  fail "rl train IQL log: $(cat "$work/train/iql/log.csv")"
for f in iql/checkpoint.pt iql/policy.pt iql/log.csv iql/curves.png; do
  [ -s "$work/train/$f" ] || fail "rl train --stage iql wrote no $f: $(cat "$work/iql.out")"
done
"$iapsim" rl train "$work/train_iql" "${train[@]}" --offline iql --iql-steps 2 --ppo-iterations 1 > "$work/train_iql.out"
grep -q "ppo: from $work/train_iql/iql/policy.pt" "$work/train_iql.out" || fail "--offline iql: $(cat "$work/train_iql.out")"
[ ! -e "$work/train_iql/td3bc" ] || fail "--offline iql ran TD3-BC: $(cat "$work/train_iql.out")"
# PPO with two workers (this process and one it starts, gradients all-reduced through Gloo): the same seed
# gives the same log twice, and a resumed run continues it exactly (the wall times aside)
workers=("${train[@]}" --stage ppo --ppo-init "$work/train/td3bc/policy.pt" --ppo-workers 2)
for run in a b; do
  "$iapsim" rl train "$work/workers_$run" "${workers[@]}" --ppo-iterations 3 > "$work/workers_$run.out" ||
    fail "rl train with 2 workers: $(cat "$work/workers_$run.out" "$work/workers_$run/ppo/worker-1.log")"
done
grep -q "ppo: from .*, 2 workers x 2 environments x 20 steps" "$work/workers_a.out" || fail "workers: $(cat "$work/workers_a.out")"
"$iapsim" rl train "$work/workers_c" "${workers[@]}" --ppo-iterations 2 > /dev/null || fail "workers: 2 iterations"
"$iapsim" rl train "$work/workers_c" "${workers[@]}" --ppo-iterations 3 > "$work/workers_c.out" || fail "workers: resume"
grep -q "ppo: resuming from .* at iteration 2" "$work/workers_c.out" || fail "workers: $(cat "$work/workers_c.out")"
for run in b c; do
  cmp <(cut -d, -f1-16 "$work/workers_a/ppo/log.csv") <(cut -d, -f1-16 "$work/workers_$run/ppo/log.csv") ||
    fail "2 workers: $run's log differs: $(cat "$work/workers_a/ppo/log.csv" "$work/workers_$run/ppo/log.csv")"
done
[ "$(wc -l < "$work/workers_a/ppo/log.csv")" -eq 4 ] || fail "workers: $(cat "$work/workers_a/ppo/log.csv")"
! pgrep -f -- "--ppo-rendezvous $work" > /dev/null || fail "a PPO worker is left running"
# a worker that dies mid-training ends the training at once, naming its log (not after Gloo's 600 s timeout)
"$iapsim" rl train "$work/workers_killed" "${workers[@]}" --ppo-iterations 100000 > "$work/workers_killed.out" 2>&1 &
trainer=$!
for _ in $(seq 1 600); do
  worker=$(pgrep -f -- "--ppo-rendezvous $work/workers_killed/.* --ppo-rank 1" || true)
  [ -n "$worker" ] && grep -q "^1," "$work/workers_killed/ppo/log.csv" 2> /dev/null && break
  sleep 0.1
done
[ -n "$worker" ] || fail "no PPO worker found running: $(cat "$work/workers_killed.out")"
kill -9 "$worker"
set +e
timeout 120 tail --pid="$trainer" -f /dev/null
waited=$?
wait "$trainer"
code=$?
set -e
[ $waited -eq 0 ] || fail "rl train went on for 120 s after its worker was killed"
[ $code -ne 0 ] || fail "rl train succeeded without its worker"
grep -qF "ppo: worker 1 was killed by signal 9; see $work/workers_killed/ppo/worker-1.log" "$work/workers_killed.out" ||
  fail "a killed worker: $(cat "$work/workers_killed.out")"
for policy in td3bc iql ppo; do
  "$iapsim" rl eval --task "$src/configs/rl/docking.yaml" --policy "$work/train/$policy/policy.pt" --episodes 1 \
    --set termination.max_steps=20 > "$work/eval_$policy.out" || fail "rl eval of the $policy policy: $(cat "$work/eval_$policy.out")"
done
set +e
"$iapsim" rl train "$work/train_bad" "${train[@]}" --stage ppo 2> "$work/train_bad.err"
code=$?
set -e
[ $code -eq 2 ] || fail "rl train --stage ppo without a TD3-BC policy exited $code"
grep -q "td3bc/policy.pt: no policy to start PPO from" "$work/train_bad.err" || fail "PPO without a start: $(cat "$work/train_bad.err")"
printf 'not a module' > "$work/bad.pt"
set +e
"$iapsim" rl eval --task "$src/configs/rl/docking.yaml" --policy "$work/bad.pt" --episodes 1 2> "$work/bad_pt.err"
code=$?
set -e
[ $code -eq 2 ] || fail "rl eval of a bad policy exited $code"
grep -q "bad.pt: not a TorchScript policy" "$work/bad_pt.err" || fail "bad policy: $(cat "$work/bad_pt.err")"
set +e
"$iapsim" rl eval --task "$src/configs/rl/docking.yaml" --episodes 1 --set reward.bonus=1 2> "$work/rl_bad.err"
code=$?
set -e
[ $code -eq 2 ] || fail "rl eval with a wrong key exited $code"
grep -q "docking.yaml: reward.bonus" "$work/rl_bad.err" || fail "rl eval wrong key: $(cat "$work/rl_bad.err")"

# bad configuration: exit code 2 and file:line in the message
sed 's/^duration_s: 5.0/duration_s: soon/' "$src/configs/scenarios/bus_demo.yaml" > "$work/bad.yaml"
set +e
"$iapsim" run "$work/bad.yaml" --out "$work/bad" 2> "$work/bad.err"
code=$?
set -e
[ $code -eq 2 ] || fail "bad configuration exited $code"
grep -q "$work/bad.yaml:[0-9]*:[0-9]*: duration_s: expected a number" "$work/bad.err" || fail "message: $(cat "$work/bad.err")"
# --check validates the whole graph and runs nothing; a usage error exits 2 as a bad configuration does
"$iapsim" run "$src/configs/scenarios/bus_demo.yaml" --check --out "$work/checked" > "$work/check_only.out" 2>&1 \
  || fail "run --check of a valid scenario: $(cat "$work/check_only.out")"
grep -q "valid" "$work/check_only.out" || fail "run --check said: $(cat "$work/check_only.out")"
[ ! -e "$work/checked" ] || fail "run --check made a run directory"
set +e
"$iapsim" run "$work/bad.yaml" --check > /dev/null 2>&1
code_check=$?
"$iapsim" run --no-such-option "$src/configs/scenarios/bus_demo.yaml" > /dev/null 2>&1
code_usage=$?
"$iapsim" > /dev/null 2>&1
code_none=$?
set -e
[ $code_check -eq 2 ] || fail "run --check of a bad scenario exited $code_check"
[ $code_usage -eq 2 ] || fail "an unknown option exited $code_usage"
[ $code_none -eq 2 ] || fail "iapsim without a command exited $code_none"

# output that is not a terminal (a CI log): a plain progress line every 5 s, with the time still to go
"$iapsim" run "$src/configs/scenarios/bus_demo.yaml" --mode realtime --duration 6 --out "$work/slow" \
  > "$work/slow.out" 2>&1 || fail "realtime run: $(cat "$work/slow.out")"
grep -Eq "^iapsim run: t = [0-9.]+ of 6.0 s, [0-9.]+x real time, about [0-9]+ s to go$" "$work/slow.out" ||
  fail "no progress line: $(cat "$work/slow.out")"

# a realtime run: inspect it live, then stop it with SIGTERM
"$iapsim" run "$src/configs/scenarios/bus_demo.yaml" --mode realtime --duration 60 --out "$work/live" \
  > "$work/live.out" 2>&1 &
launcher=$!
started=false
for _ in $(seq 300); do  # up to 30 s on a loaded machine
  if [ -f "$work/live/log.txt" ] && grep -q "clock started" "$work/live/log.txt"; then started=true; break; fi
  sleep 0.1
done
$started || fail "the realtime run did not start its clock: $(cat "$work/live.out")"
"$iapsim" topics --run "$work/live" --listen 1 > "$work/topics.out" || fail "topics: $(cat "$work/topics.out") $(cat "$work/live.out")"
grep -Eq "^/iap/state +iapsim_msgs/IapState +physics" "$work/topics.out" || fail "topics: $(cat "$work/topics.out")"
set +e
timeout 10 "$iapsim" echo /iap/state --run "$work/live" -n 2 > "$work/echo.out" 2> "$work/echo.err"
code=$?
set -e
[ $code -eq 0 ] || fail "echo exited $code (124: timed out): $(cat "$work/echo.err"); the run said: $(cat "$work/live.out")"
[ "$(grep -c '^---' "$work/echo.out")" -eq 2 ] || fail "echo: $(cat "$work/echo.out")"
grep -q "frame_id: W" "$work/echo.out" || fail "echo: $(cat "$work/echo.out")"
# runs/latest names the newest run, an --out one too
[ "$(readlink runs/latest)" = "$(realpath "$work/live")" ] || fail "runs/latest -> $(readlink runs/latest), not $work/live"
# an echo of a topic nobody publishes gives up once the run is over
"$iapsim" echo /no/such/topic --run "$work/live" > /dev/null 2> "$work/echo_wait.err" &
echo_wait=$!

kill -TERM $launcher
start=$(date +%s%N)
set +e
wait $launcher
code=$?
set -e
elapsed_ms=$(( ($(date +%s%N) - start) / 1000000 ))
[ $code -eq 130 ] || fail "SIGTERM: launcher exited $code: $(cat "$work/live.out")"
# the contract is that a stop never hangs: the launcher asks, then sends SIGTERM, then SIGKILL, within
# about 6 s whatever the processes do (a loaded machine takes longer than an idle one)
[ $elapsed_ms -lt 10000 ] || fail "SIGTERM: stopping took $elapsed_ms ms"
for _ in $(seq 50); do kill -0 $echo_wait 2> /dev/null || break; sleep 0.1; done
if kill -0 $echo_wait 2> /dev/null; then kill $echo_wait; fail "echo still waits 5 s after the run ended"; fi
wait_code $echo_wait
[ $code -eq 1 ] || fail "echo of a run that ended exited $code: $(cat "$work/echo_wait.err")"
grep -q "the run in $work/live has ended" "$work/echo_wait.err" || fail "echo: $(cat "$work/echo_wait.err")"
# after the echo has given up: its command line names the run too
if pgrep -f -- "$work/live" > /dev/null; then fail "processes left behind: $(pgrep -af -- "$work/live")"; fi
"$iapsim" info "$work/live/run.bag" > /dev/null || fail "the stopped run's bag is not readable"
expect_exit 1 "has ended" "$iapsim" echo /iap/state --run "$work/live"

# a tracked flight: `run` evaluates it, `evaluate` recomputes its metrics and plots, `regress` rejects a bad suite
"$iapsim" run "$src/configs/regression/three_star_spiral.yaml" --duration 2 --out "$work/spiral" \
  > "$work/spiral.out" 2>&1 || fail "spiral run: $(cat "$work/spiral.out")"
grep -q "position RMSE" "$work/spiral.out" || fail "run printed no tracking metrics: $(cat "$work/spiral.out")"
"$iapsim" evaluate "$work/spiral" > "$work/evaluate.out" 2>&1 || fail "evaluate: $(cat "$work/evaluate.out")"
grep -q "position RMSE" "$work/evaluate.out" || fail "evaluate: $(cat "$work/evaluate.out")"
for png in tracking_pose.png tracking_error.png; do
  [ -s "$work/spiral/$png" ] || fail "no $png"
done
# a lead-in: the IAP hovers at the trajectory's start for 0.5 s first; the run lasts that much longer, the
# trajectory and the evaluation start after it (the same references at the same scenario times)
"$iapsim" run "$src/configs/regression/three_star_spiral.yaml" --duration 2 --set lead_in_s=0.5 \
  --out "$work/spiral_led_in" > "$work/led_in.out" 2>&1 || fail "led-in run: $(cat "$work/led_in.out")"
/usr/bin/python3 - "$work/spiral" "$work/spiral_led_in" <<'PY' || fail "lead-in"
import csv, json, sys
plain, led_in = (json.load(open(d + '/metrics.json')) for d in sys.argv[1:])
assert (led_in['lead_in_s'], led_in['sim_time_s']) == (0.5, 2.5), (led_in['lead_in_s'], led_in['sim_time_s'])
assert led_in['tracking']['samples'] == plain['tracking']['samples'] == 401, led_in['tracking']['samples']
rows = [list(csv.DictReader(open(d + '/tracking.csv'))) for d in sys.argv[1:]]
for a, b in zip(*rows):
    assert a['t_s'] == b['t_s'] and a['x_ref_m'] == b['x_ref_m'] and a['y_ref_m'] == b['y_ref_m'], (a, b)
PY
# a gust's start_s is scenario time too: one at 0.3 s leaves the flight as it is in still air until then
for gust in none '[{start_s: 0.3, rise_s: 0.1, hold_s: 0.5, amplitude_W_mps: [0, 5, 0]}]'; do
  gusts=$([ "$gust" = none ] && echo '[]' || echo "$gust")
  "$iapsim" run "$src/configs/regression/three_star_spiral.yaml" --duration 1 --set lead_in_s=0.5 \
    --set "processes.physics.params.air={gusts: $gusts}" --out "$work/gust_$([ "$gust" = none ] && echo no || echo yes)" \
    > "$work/gust.out" 2>&1 || fail "gust run: $(cat "$work/gust.out")"
done
/usr/bin/python3 - "$work/gust_no" "$work/gust_yes" <<'PY' || fail "the gust did not wait for the lead-in"
import csv, sys
still, gust = ([(float(r['t_s']), r['y_m']) for r in csv.DictReader(open(d + '/tracking.csv'))] for d in sys.argv[1:])
assert all(a == b for a, b in zip(still, gust) if a[0] <= 0.3), 'the flights differ before the gust'
assert any(a != b for a, b in zip(still, gust) if a[0] > 0.3), 'the gust changed nothing'
PY
# unrecorded (a timing run): no bag, so no evaluation, said so; a --video of it is refused before it flies
"$iapsim" run "$src/configs/regression/three_star_spiral.yaml" --duration 1 --out "$work/spiral_unrecorded" \
  --set recording.enabled=false > "$work/unrecorded.out" 2>&1 || fail "unrecorded run: $(cat "$work/unrecorded.out")"
grep -q "evaluation is skipped: it reads the bag, and recording.enabled is false" "$work/unrecorded.out" ||
  fail "unrecorded run: $(cat "$work/unrecorded.out")"
[ ! -e "$work/spiral_unrecorded/run.bag" ] || fail "an unrecorded run wrote a bag"
expect_exit 2 "the run was not recorded (recording.enabled is false)" "$iapsim" evaluate "$work/spiral_unrecorded"
expect_exit 2 "--video iap: the video is made from the bag, and recording.enabled is false" "$iapsim" run \
  "$src/configs/regression/three_star_spiral.yaml" --duration 1 --out "$work/unrecorded_video" \
  --set recording.enabled=false --video iap
[ ! -e "$work/unrecorded_video" ] || fail "a refused run made its directory"
# an lz4 bag is rosbag's own compression: Debian's python rosbag reads it back message for message as the
# uncompressed bag of the same run, and at most half its size (issue 21's target)
"$iapsim" run "$src/configs/regression/three_star_spiral.yaml" --duration 2 --out "$work/spiral_lz4" \
  --set recording.compression=lz4 > "$work/spiral_lz4.out" 2>&1 || fail "lz4 run: $(cat "$work/spiral_lz4.out")"
/usr/bin/python3 - "$work/spiral/run.bag" "$work/spiral_lz4/run.bag" <<'EOF' || fail "the lz4 bag read back in rosbag"
import os, sys
import rosbag
def read(path):
    with rosbag.Bag(path) as bag:
        return bag.get_compression_info().compression, [
            (topic, raw[1], stamp.to_nsec()) for topic, raw, stamp in bag.read_messages(raw=True)]
plain, compressed = read(sys.argv[1]), read(sys.argv[2])
assert plain[0] == 'none' and compressed[0] == 'lz4', (plain[0], compressed[0])
assert len(plain[1]) > 10000 and compressed[1] == plain[1], (len(plain[1]), len(compressed[1]))
sizes = [os.path.getsize(p) for p in sys.argv[1:3]]
assert 2 * sizes[1] <= sizes[0], sizes
EOF
# a bag as a killed recorder leaves it (no index position in its header, the last chunk cut short): info
# reads its whole chunks and says so, `bag reindex` writes its index and keeps the original
python3 - "$work/spiral/run.bag" "$work/cut.bag" <<'EOF'
import sys
data = bytearray(open(sys.argv[1], 'rb').read())
at = data.index(b'index_pos=') + len(b'index_pos=')
data[at:at + 8] = bytes(8)
open(sys.argv[2], 'wb').write(data[:len(data) * 2 // 3])
EOF
cut_md5=$(md5sum < "$work/cut.bag")
"$iapsim" info "$work/cut.bag" > "$work/cut.out"
grep -q "^note: .*unindexed.*iapsim bag reindex" "$work/cut.out" || fail "info of a cut bag: $(cat "$work/cut.out")"
"$iapsim" bag reindex "$work/cut.bag" > "$work/reindex.out" || fail "bag reindex: $(cat "$work/reindex.out")"
grep -q "messages, indexed (the original is $work/cut.orig.bag)" "$work/reindex.out" || fail "$(cat "$work/reindex.out")"
[ "$(md5sum < "$work/cut.orig.bag")" = "$cut_md5" ] || fail "the original was not kept as it was"
"$iapsim" info "$work/cut.bag" > "$work/reindexed.out"
if grep -q "^note:" "$work/reindexed.out"; then fail "reindexed bag: $(cat "$work/reindexed.out")"; fi
[ "$(grep -c "^/iap/" "$work/reindexed.out")" -eq "$(grep -c "^/iap/" "$work/cut.out")" ] || fail "topics differ"
"$iapsim" bag reindex "$work/cut.bag" | grep -q "is indexed; nothing to do" || fail "reindex of an indexed bag"

mkdir -p "$work/suite"
printf 'flights:\n  x:\n    scenario: missing.yaml\n' > "$work/suite/suite.yaml"
set +e
"$iapsim" regress "$work/suite" --out "$work/regress" > "$work/regress.out" 2>&1
code=$?
set -e
[ $code -eq 2 ] || fail "regress with a bad suite exited $code: $(cat "$work/regress.out")"
grep -q "suite.yaml:3" "$work/regress.out" || fail "regress error names no line: $(cat "$work/regress.out")"

# the flights fly side by side (--jobs 2), each an `iapsim run` of its own, and are reported in the suite's
# order; a flight that cannot be evaluated fails with the reason and the others still fly
mkdir -p "$work/pair"
cat > "$work/pair/suite.yaml" <<EOF
flights:
  spiral:
    scenario: $src/configs/regression/three_star_spiral.yaml
    max: {position_max_m: [1.0, 1.0, 1.0]}
  hover:
    scenario: $src/configs/scenarios/three_star_hover.yaml
    max: {position_max_m: [1.0, 1.0, 1.0]}
  circle:
    scenario: $src/configs/regression/two_line_circle.yaml
    max: {position_max_m: [1.0, 1.0, 0.0]}
EOF
set +e
"$iapsim" regress "$work/pair" --fidelity ideal --jobs 2 --set duration_s=2 --out "$work/pair/out" > "$work/pair.out" 2>&1
code=$?
set -e
[ $code -eq 1 ] || fail "regress of a failing pair exited $code: $(cat "$work/pair.out")"
grep -q "^hover .*FAILED: the scenario has no evaluation section" "$work/pair.out" || fail "hover: $(cat "$work/pair.out")"
/usr/bin/python3 -c "
import json, sys
report = json.load(open(sys.argv[1]))
assert 'run_dir' not in report['hover'] and report['hover']['error'], report['hover']  # it never flew
assert report['spiral']['run_dir'].endswith('/spiral'), report['spiral']
" "$work/pair/out/regress.json" || fail "regress.json of the pair"
grep -q "^circle .*position_max_m.z .*REGRESSION" "$work/pair.out" || fail "circle: $(cat "$work/pair.out")"
[ "$(grep -E "^(spiral|hover|circle) " "$work/pair.out" | awk '!seen[$1]++ {print $1}' | tr '\n' ' ')" = "spiral hover circle " ] ||
  fail "flights reported out of order: $(cat "$work/pair.out")"
for flight in spiral circle; do  # plotted by regress's one plot server (IAPSIM_PLOT_SOCKET)
  grep -q "^run complete: $work/pair/out/$flight" "$work/pair/out/$flight/iapsim.log" || fail "$flight: no log of its run"
  [ -s "$work/pair/out/$flight/tracking_pose.png" ] || fail "$flight: no plot: $(cat "$work/pair/out/$flight/iapsim.log")"
done
# the shared plot server listens in the abstract namespace (nothing on disk) and serves this user only
/usr/bin/python3 - "$src/tools/plot_server.py" <<'PY' || fail "the plot server's listener"
import os, socket, subprocess, sys
listener = socket.socket(socket.AF_UNIX)
listener.bind("\0iapsim-plots-test-%d" % os.getpid())
listener.listen(4)
server = subprocess.Popen([sys.executable, sys.argv[1], "--listen-fd", str(listener.fileno())],
                          stdin=subprocess.PIPE, stderr=subprocess.PIPE, pass_fds=[listener.fileno()], text=True)
def ask(job):
    with socket.socket(socket.AF_UNIX) as s:
        s.connect(listener.getsockname())
        s.sendall(job.encode() + b"\n")
        return s.makefile().readline().strip()
assert ask("[]") == "error a job is [SCRIPT, ARG...]"
if os.getuid() == 0:  # another user: refused, no reply
    child = os.fork()
    if child == 0:
        os.setuid(65534)
        try:
            reply = ask("[]")
        except OSError:  # reset: closed unread
            reply = ""
        os._exit(0 if reply == "" else 1)
    assert os.waitstatus_to_exitcode(os.waitpid(child, 0)[1]) == 0, "another user was served"
server.stdin.close()
assert server.wait(timeout=30) == 0
log = server.stderr.read()
assert os.getuid() != 0 or "refused a connection of uid 65534" in log, log
PY
# a run plots through the server IAPSIM_PLOT_SOCKET names (here a stand-in that records the job it gets)
/usr/bin/python3 -c "
import socket, sys
server = socket.socket(socket.AF_UNIX)
server.bind(sys.argv[1])
server.listen(4)
server.settimeout(60)  # a run that never comes fails the check below instead of hanging it
open(sys.argv[1] + '.ready', 'w').close()
connection, _ = server.accept()
lines = connection.makefile('rw')
open(sys.argv[2], 'w').write(lines.readline())
lines.write('ok\\n')
lines.flush()
" "$work/stand_in.sock" "$work/stand_in.job" &
stand_in=$!
for _ in $(seq 100); do [ -e "$work/stand_in.sock.ready" ] && break; sleep 0.1; done
IAPSIM_PLOT_SOCKET=$work/stand_in.sock "$iapsim" run "$src/configs/regression/two_line_circle.yaml" --duration 1 \
  --out "$work/shared_plots" > "$work/shared_plots.out" 2>&1 || fail "run with a plot server: $(cat "$work/shared_plots.out")"
wait_code $stand_in
[ $code -eq 0 ] || fail "the stand-in plot server exited $code"
grep -q "plot_tracking.py" "$work/stand_in.job" || fail "the run did not plot through the shared server: $(cat "$work/stand_in.job")"
[ ! -e "$work/shared_plots/tracking_pose.png" ] || fail "the run plotted with its own server beside the shared one"
# a plot server that is not there: the run plots with its own
IAPSIM_PLOT_SOCKET=$work/no/socket "$iapsim" run "$src/configs/regression/two_line_circle.yaml" --duration 1 \
  --out "$work/own_plots" > "$work/own_plots.out" 2>&1 || fail "run with no plot server: $(cat "$work/own_plots.out")"
[ -s "$work/own_plots/tracking_pose.png" ] || fail "no plot without a plot server: $(cat "$work/own_plots.out")"
# Ctrl-C stops every flight in the air and leaves no process behind
"$iapsim" regress "$work/pair" --fidelity ideal --jobs 2 --only spiral --only circle --set duration_s=60 \
  --out "$work/pair/stopped" > "$work/stopped.out" 2>&1 &
regress=$!
for _ in $(seq 100); do
  [ -s "$work/pair/stopped/spiral/launcher.pid" ] && [ -s "$work/pair/stopped/circle/launcher.pid" ] && break
  sleep 0.1
done
launchers="$(cat "$work/pair/stopped/spiral/launcher.pid") $(cat "$work/pair/stopped/circle/launcher.pid")"
kill -INT $regress
wait_code $regress
[ $code -eq 130 ] || fail "an interrupted regress exited $code: $(cat "$work/stopped.out")"
for pid in $launchers; do
  ! kill -0 "$pid" 2> /dev/null || fail "a flight's launcher ($pid) outlived the interrupted regress"
done
! pgrep -f "$work/pair/stopped" > /dev/null || fail "processes of the interrupted regress remain: $(pgrep -af "$work/pair/stopped")"

# Monte Carlo: seeded draws of a model mismatch, their percentiles and band plot, a bound on a percentile;
# the flight names the realistic profile it flies (the arena's, which keeps the base profile's mismatch)
mkdir -p "$work/mc"
cat > "$work/mc/suite.yaml" <<EOF
monte_carlo:
  set:
    duration_s: 3
    lead_in_s: 0.5
    processes.physics.params.uncertainty: {mass: {normal: 0.05}}
flights:
  spiral:
    scenario: $src/configs/regression/three_star_spiral.yaml
    max: {position_max_m: [0.0, 0.0, 0.0]}   # the ideal bounds: not checked in Monte Carlo mode
    realistic: {fidelity: realistic_indoor}
    monte_carlo: {max: {position_max_m: [1.0, 1.0, 0.001]}}
EOF
set +e
"$iapsim" regress "$work/mc" --monte-carlo 3 --jobs 2 --out "$work/mc/out" > "$work/mc.out" 2>&1
code=$?
set -e
[ $code -eq 1 ] || fail "Monte Carlo regress with a failing bound exited $code: $(cat "$work/mc.out")"
grep -q "sweep spiral: 3 runs .* 0 finished before, 3 to run, 2 at a time" "$work/mc.out" || fail "draws not on the pool: $(cat "$work/mc.out")"
grep -q "position_max_m.z p95 .* REGRESSION" "$work/mc.out" || fail "no failed p95 check: $(cat "$work/mc.out")"
grep -q "position_max_m.x p95 .* ok" "$work/mc.out" || fail "no passed p95 check: $(cat "$work/mc.out")"
[ -s "$work/mc/out/spiral/monte_carlo_error.png" ] || fail "no band plot: $(cat "$work/mc.out")"
[ -s "$work/mc/out/spiral/draw-2/tracking.csv" ] || fail "a draw lost its tracking.csv"
[ ! -e "$work/mc/out/spiral/draw-2/run.bag" ] || fail "a draw kept its bag without --keep-bags"
/usr/bin/python3 -c "
import json, sys
out = sys.argv[1]
summary = json.load(open(out + '/spiral/metrics.json'))
assert summary['fidelity'] == 'realistic_indoor', summary['fidelity']  # the flight's realistic profile
stats = summary['tracking']['position_max_m']['z']
draws = [json.load(open(f'{out}/spiral/draw-{k}/metrics.json')) for k in (1, 2, 3)]
z = sorted(d['tracking']['position_max_m']['z'] for d in draws)
assert stats['draws'] == 3 and stats['min'] == z[0] and stats['max'] == z[2], (stats, z)
assert abs(stats['p50'] - z[1]) < 1e-12 and z[1] < stats['p95'] < z[2], (stats, z)
assert len(set(z)) == 3, z  # each seed draws another vehicle
masses = {d['processes']['physics']['process']['true_model']['iap/platform/mass_kg']['drawn'] for d in draws}
assert len(masses) == 3, masses
for k in (1, 2, 3):  # in the arena: still air
    resolved = open(f'{out}/spiral/draw-{k}/scenario.resolved.yaml').read()
    assert 'turbulence' not in resolved and 'fidelity: realistic_indoor' in resolved, k
" "$work/mc/out" || fail "Monte Carlo statistics"
# the same --out again: the finished draws are not flown again, the checks are the same
cp "$work/mc/out/spiral/metrics.json" "$work/mc/first.json"
set +e
"$iapsim" regress "$work/mc" --monte-carlo 3 --out "$work/mc/out" > "$work/mc2.out" 2>&1
set -e
grep -q "3 finished before, 0 to run" "$work/mc2.out" || fail "draws flown again: $(cat "$work/mc2.out")"
diff <(grep -v '"plot"' "$work/mc/first.json") <(grep -v '"plot"' "$work/mc/out/spiral/metrics.json") > /dev/null ||
  fail "the resumed Monte Carlo differs: $(diff "$work/mc/first.json" "$work/mc/out/spiral/metrics.json")"
expect_exit 2 "--monte-carlo" "$iapsim" regress "$work/mc" --slurm --out "$work/mc/none"
# other settings in the same --out: the draws are flown again, not taken from the folders of the same names
set +e
"$iapsim" regress "$work/mc" --monte-carlo 3 --out "$work/mc/out" --set processes.physics.params.uncertainty.mass=0.1 > "$work/mc3.out" 2>&1
set -e
grep -q "0 finished before, 3 to run" "$work/mc3.out" || fail "draws of other settings reused: $(cat "$work/mc3.out")"

# a rendered flight: the scenario's videos and one more asked for with --video, each with its sheet of frames
"$iapsim" run "$src/configs/scenarios/three_star_stereo.yaml" --duration 0.5 --out "$work/stereo" \
  --video iap/sub2/stereo/right > "$work/stereo.out" 2>&1 || fail "stereo run: $(cat "$work/stereo.out")"
for eye in iap_platform_chase iap_sub1_stereo_left iap_sub2_stereo_right; do
  head -c 12 "$work/stereo/$eye.mp4" | grep -q ftyp || fail "$eye.mp4 is not an MP4: $(cat "$work/stereo.out")"
  [ -s "$work/stereo/${eye}_frames.png" ] || fail "no ${eye}_frames.png"
done
set +e
"$iapsim" video "$work/stereo/run.bag" iap/sub9/stereo/left > "$work/video.out" 2>&1
code=$?
set -e
[ $code -eq 1 ] || fail "video of a missing camera exited $code"
grep -q "/iap/sub1/stereo/left/image_raw/compressed" "$work/video.out" || fail "video: $(cat "$work/video.out")"

# the render process's configuration is checked before anything flies
check_render() { check_process iapsim_render scenarios/three_star_stereo.yaml render "$@"; }
check_render "cameras\[0\].rate_hz: 20 must divide the render process's rate_hz 25" --set processes.render.rate_hz=25
check_render "cameras\[0\].body: no body 'iap/sub9'" \
  --set 'processes.render.params.cameras=[{name: stereo, body: iap/sub9}]'
check_render "scene: no file" --set processes.render.params.scene=missing.yaml

echo "cli_test: all checks passed"
