#!/usr/bin/env bash
# End-to-end test of `iapsim sweep` as a user runs it (issue 22): a grid over seeds on the local pool, the
# tables, a run that fails (reported with its reason, never dropped), --resume after a failure and after an
# interrupted sweep (only what did not finish runs again), a sweep left in place, a bad sweep file.
# usage: sweep_test.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
# shellcheck source=tests/support/script.sh
source "$(dirname "$0")/support/script.sh"

# 3 values x 2 seeds of the bus demo, two at a time
cat > "$work/noise.yaml" << EOF
name: noise
scenario: $src/configs/scenarios/bus_demo.yaml
set: {duration_s: 0.3}
grid:
  processes.uwb.params.noise_m: [0.05, 0.1, 0.2]
seeds: [1, 2]
metrics: [sim_time_s, messages_lost]
EOF
"$iapsim" sweep "$work/noise.yaml" --list > "$work/list.out"
[ "$(grep -c ' processes.uwb.params.noise_m=' "$work/list.out")" -eq 6 ] || fail "list: $(cat "$work/list.out")"
"$iapsim" sweep "$work/noise.yaml" --out "$work/noise" --jobs 2 > "$work/noise.out" || fail "sweep: $(cat "$work/noise.out")"
grep -q "6 of 6 runs finished" "$work/noise.out" || fail "sweep: $(cat "$work/noise.out")"
head -1 "$work/noise/results.csv" | grep -q "^id,group,processes.uwb.params.noise_m,seed,status,exit_code,wall_s,sim_time_s,messages_lost,reason$" ||
  fail "results header: $(head -1 "$work/noise/results.csv")"
[ "$(grep -c ',completed,0,' "$work/noise/results.csv")" -eq 6 ] || fail "results: $(cat "$work/noise/results.csv")"
# each run is a whole run directory, with the id --list gave it
while read -r _ id _; do
  [ -s "$work/noise/runs/$id/metrics.json" ] || fail "run $id has no metrics.json"
  grep -q "^$id," "$work/noise/results.csv" || fail "run $id is not in the table"
done < <(tail -n +2 "$work/list.out")
first=$(sed -n 2p "$work/noise/results.csv" | cut -d, -f1)
grep -q "noise_m: 0.05" "$work/noise/runs/$first/scenario.resolved.yaml" || fail "run $first lacks its swept value"
grep -q "seed: 1" "$work/noise/runs/$first/scenario.resolved.yaml" || fail "run $first lacks its seed"
# per group: the two seeds' statistics
[ "$(wc -l < "$work/noise/summary.csv")" -eq 4 ] || fail "summary: $(cat "$work/noise/summary.csv")"
grep -q "^[0-9a-f]*,0.1,2,2,0,0.3,0.3,0.3,0,0,0$" "$work/noise/summary.csv" || fail "summary: $(cat "$work/noise/summary.csv")"
grep -q "## sim_time_s" "$work/noise/summary.md" || fail "summary.md: $(cat "$work/noise/summary.md")"
[ -s "$work/noise/plot_processes.uwb.params.noise_m.png" ] || fail "no plot: $(ls "$work/noise")"
# a finished sweep is not overwritten
expect_exit 2 "holds a sweep: --resume" "$iapsim" sweep "$work/noise.yaml" --out "$work/noise"
# --resume of a finished sweep runs nothing
"$iapsim" sweep "$work/noise.yaml" --out "$work/noise" --resume > "$work/again.out"
grep -q "6 finished before, 0 to run" "$work/again.out" || fail "resume: $(cat "$work/again.out")"

# a run that fails (its controller killed at step 100): reported with its reason, the sweep exits 1; --resume
# runs only that one again
cat > "$work/kill.yaml" << EOF
scenario: $src/configs/scenarios/bus_demo.yaml
set: {duration_s: 0.3}
grid:
  processes.control.params.kill_at_step: [-1, 100]
EOF
set +e
"$iapsim" sweep "$work/kill.yaml" --out "$work/kill" > "$work/kill.out"
code=$?
set -e
[ $code -eq 1 ] || fail "a sweep with a failed run exited $code: $(cat "$work/kill.out")"
grep -q "1 of 2 runs finished" "$work/kill.out" || fail "kill: $(cat "$work/kill.out")"
grep -E ",100,,failed,1,[0-9.]+,.*control" "$work/kill/results.csv" > /dev/null ||
  fail "the failed run's row: $(cat "$work/kill/results.csv")"
grep -q "failed (exit 1): .*control" "$work/kill/summary.md" || fail "summary.md: $(cat "$work/kill/summary.md")"
set +e
"$iapsim" sweep "$work/kill.yaml" --out "$work/kill" --resume > "$work/kill2.out"
set -e
grep -q "1 finished before, 1 to run" "$work/kill2.out" || fail "resume: $(cat "$work/kill2.out")"

# interrupted (SIGINT to the sweep alone, as a scheduler would send it) once its first run finished: the
# second stops cleanly, the third never starts, nothing is left running, and --resume runs those two
cat > "$work/seeds.yaml" << EOF
scenario: $src/configs/scenarios/bus_demo.yaml
set: {duration_s: 2}
seeds: [1, 2, 3]
EOF
"$iapsim" sweep "$work/seeds.yaml" --out "$work/seeds" --jobs 1 > "$work/seeds.out" 2>&1 &
sweep=$!
for _ in $(seq 300); do
  [ "$(find "$work/seeds/runs" -name sweep_run.json 2> /dev/null | wc -l)" -ge 1 ] && break
  sleep 0.1
done
kill -INT $sweep
wait_code $sweep
[ $code -eq 130 ] || fail "an interrupted sweep exited $code: $(cat "$work/seeds.out")"
grep -q "interrupted: .*--resume" "$work/seeds.out" || fail "interrupted: $(cat "$work/seeds.out")"
grep -q "1 of 3 runs finished" "$work/seeds.out" || fail "interrupted: $(cat "$work/seeds.out")"
if pgrep -f "$work/seeds/runs" > /dev/null; then fail "processes of the interrupted sweep are still running"; fi
"$iapsim" sweep "$work/seeds.yaml" --out "$work/seeds" --resume > "$work/seeds2.out" || fail "resume: $(cat "$work/seeds2.out")"
grep -q "1 finished before, 2 to run" "$work/seeds2.out" || fail "resume: $(cat "$work/seeds2.out")"
[ "$(grep -c ',completed,0,' "$work/seeds/results.csv")" -eq 3 ] || fail "results: $(cat "$work/seeds/results.csv")"

# a bad sweep file: its line and key
printf 'scenario: %s\ngrid: {processes.uwb.params.noise_m: 0.1}\n' "$src/configs/scenarios/bus_demo.yaml" > "$work/bad.yaml"
expect_exit 2 "bad.yaml:2" "$iapsim" sweep "$work/bad.yaml" --out "$work/bad"
printf 'scenario: %s\ngrid: {no_such_key: [1]}\n' "$src/configs/scenarios/bus_demo.yaml" > "$work/typo.yaml"
expect_exit 2 "no_such_key" "$iapsim" sweep "$work/typo.yaml" --out "$work/typo"
[ ! -e "$work/typo" ] || fail "a bad sweep created its folder"

echo "sweep_test: all checks passed"
