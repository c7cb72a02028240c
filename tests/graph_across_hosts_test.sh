#!/usr/bin/env bash
# A graph across hosts (issue 22): the sensors process of a lockstep run in a second network namespace (a
# veth pair with private addresses the test makes), started by hand as `host: external` asks, over tcp with
# the run's CURVE keys. The bag is byte-identical to the one-host run's; a remote process that vanishes ends
# the run within its hang_timeout_s; one whose launcher vanishes stops by itself; one without the run's
# secret is refused. Needs CAP_NET_ADMIN (root): without it the test is skipped (exit 77), saying why.
# usage: graph_across_hosts_test.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
# shellcheck source=tests/support/script.sh
source "$(dirname "$0")/support/script.sh"
scenario=$src/configs/scenarios/three_star_sensors.yaml
ns=iapsim-$$
host_if=iapsim-a$$
remote_if=iapsim-b$$
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -9 "$pid" 2> /dev/null || true; done
  ip netns pids "$ns" 2> /dev/null | xargs -r kill -9 2> /dev/null || true
  ip netns del "$ns" 2> /dev/null || true  # takes its end of the veth pair, and so the pair, with it
  rm -rf "$work"
}
trap cleanup EXIT
if ! ip netns add "$ns" 2> "$work/netns.err"; then
  echo "SKIP: cannot make a network namespace (needs root or CAP_NET_ADMIN): $(cat "$work/netns.err")"
  exit 77
fi
# a /30 of 10.213.0.0/16 that no interface of this host has yet
for third in $(seq $(($$ % 200)) 255) $(seq 0 255); do
  ip -4 -o addr | grep -q " 10\.213\.$third\." || break
done
host_ip=10.213.$third.1
remote_ip=10.213.$third.2
ip link add "$host_if" type veth peer name "$remote_if"
ip link set "$remote_if" netns "$ns"
ip addr add "$host_ip/30" dev "$host_if"
ip link set "$host_if" up
ip netns exec "$ns" ip addr add "$remote_ip/30" dev "$remote_if"
ip netns exec "$ns" ip link set "$remote_if" up
ip netns exec "$ns" ip link set lo up

# waits for RUN/external/NAME.sh (the launcher writes it once the run folder is ready); prints its path
external_script() {
  for _ in $(seq 200); do
    [ -x "$1/external/$2.sh" ] && echo "$1/external/$2.sh" && return
    sleep 0.05
  done
  fail "no $1/external/$2.sh: $(cat "$1.out" 2> /dev/null)"
}
# NAME: a 30 s run with the sensors in the namespace, in the background ($run, $remote), once both step
start_long_run() {  # NAME [--set KEY=VALUE]...
  "$iapsim" run "$scenario" --set duration_s=30 "${across[@]}" "${@:2}" --out "$work/$1" > "$work/$1.out" 2>&1 &
  run=$!
  pids+=("$run")
  ip netns exec "$ns" "$(external_script "$work/$1" sensors)" > "$work/$1_sensors.log" 2>&1 &
  remote=$!
  pids+=("$remote")
  for _ in $(seq 400); do
    grep -q "started in lockstep mode" "$work/$1_sensors.log" 2> /dev/null && return
    sleep 0.05
  done
  fail "$1: it did not start: $(cat "$work/$1.out" "$work/$1_sensors.log")"
}
across=(--set bus.transport=tcp --set "bus.tcp_address=$host_ip" --set processes.sensors.host=external
  --set "processes.sensors.address=$remote_ip")

# the reference: every process on this host
"$iapsim" run "$scenario" --set duration_s=1 --set bus.transport=tcp --out "$work/one" > "$work/one.out" 2>&1 ||
  fail "one host: $(cat "$work/one.out")"

# the same with the sensors in the namespace: the launcher prints the command, and the bag is the same bytes
"$iapsim" run "$scenario" --set duration_s=1 "${across[@]}" --out "$work/two" > "$work/two.out" 2>&1 &
run=$!
pids+=("$run")
script=$(external_script "$work/two" sensors)
grep -q "started elsewhere:" "$work/two.out" || fail "no command printed: $(cat "$work/two.out")"
grep -qF "$(sed -n 's/^exec \(.*\) "\$@"$/\1/p' "$script")" "$work/two.out" || fail "the printed command is not the script's"
ip netns exec "$ns" "$script" > "$work/sensors.log" 2>&1 || fail "sensors in $ns: $(cat "$work/sensors.log")"
grep -q "on tcp://$remote_ip:" "$work/sensors.log" || fail "sensors did not bind $remote_ip: $(cat "$work/sensors.log")"
wait_code "$run"
[ "$code" -eq 0 ] || fail "across hosts exited $code: $(cat "$work/two.out")"
cmp "$work/one/run.bag" "$work/two/run.bag" || fail "the bags differ"
python3 - "$work/two/metrics.json" << 'PY' || fail "metrics: $(cat "$work/two/metrics.json")"
import json, sys
sensors = json.load(open(sys.argv[1]))["processes"]["sensors"]
assert sensors["exit"] == "said bye (started elsewhere)", sensors["exit"]
assert sensors["cpu_s"]["user"] + sensors["cpu_s"]["system"] > 0, sensors["cpu_s"]
PY

# the remote process vanishes mid-run (SIGKILL in its namespace): the run ends within its hang_timeout_s,
# naming it, and leaves a readable bag. The lockstep clock's ack timeout (2 s by default, as hang_timeout_s)
# is set longer, so the launcher's supervision is what ends the run: with both at 2 s the physics process,
# waiting for the step's acknowledgement, failed first in one CI run of many
start_long_run vanish --set clock.ack_timeout_s=5
killed_at=$(date +%s%N)
{ kill -9 "$remote" && wait "$remote"; } 2> /dev/null || true  # (bash would report the kill)
wait_code "$run"
ended_s=$((($(date +%s%N) - killed_at) / 1000000000))
[ "$code" -eq 1 ] || fail "vanished: exit $code: $(cat "$work/vanish.out")"
grep -q "process 'sensors' (started elsewhere) is not responding" "$work/vanish.out" || fail "vanished: $(cat "$work/vanish.out")"
# the contract of every death (README, Tests): over within 10 s (here hang_timeout_s, 2 s, then the stop)
[ "$ended_s" -le 10 ] || fail "the run took $ended_s s to end after the remote process vanished"
"$iapsim" info "$work/vanish/run.bag" > /dev/null || fail "vanished: the bag does not read"

# the launcher vanishes: its local processes follow it (PR_SET_PDEATHSIG), the remote one stops once the
# launcher has been silent for its hang_timeout_s
start_long_run orphan
{ kill -9 "$run" && wait "$run"; } 2> /dev/null || true
for _ in $(seq 100); do
  kill -0 "$remote" 2> /dev/null || break
  sleep 0.1
done
! kill -0 "$remote" 2> /dev/null || fail "the remote process outlived its launcher by 10 s"
wait_code "$remote"
[ "$code" -eq 1 ] || fail "orphan: exit $code"
grep -q "the launcher has been silent" "$work/orphan_sensors.log" || fail "orphan: $(cat "$work/orphan_sensors.log")"
! pgrep -f -- "--run-dir $work/orphan" > /dev/null || fail "processes of the run are left: $(pgrep -af -- "--run-dir $work/orphan")"

# without the run's secret the remote process gets nowhere: refused at the handshake, the launcher says so
"$iapsim" run "$scenario" --set duration_s=1 "${across[@]}" --set processes.sensors.startup_timeout_s=3 \
  --out "$work/intruder" > "$work/intruder.out" 2>&1 &
run=$!
pids+=("$run")
IAPSIM_RUN_SECRET=$(printf '0%.0s' $(seq 64)) ip netns exec "$ns" "$(external_script "$work/intruder" sensors)" \
  > "$work/intruder_sensors.log" 2>&1 || true
wait_code "$run"
[ "$code" -eq 1 ] || fail "intruder: exit $code: $(cat "$work/intruder.out")"
grep -q "'sensors' did not become ready within 3" "$work/intruder.out" || fail "intruder: $(cat "$work/intruder.out")"
grep -q "control channel: refused a peer" "$work/intruder/log.txt" ||
  fail "intruder: no refusal in the log: $(cat "$work/intruder/log.txt")"
echo "PASS"
