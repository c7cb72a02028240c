#!/usr/bin/env bash
# The ROS bridge (issue 21) end to end, with ROS nodes that are not part of iapsim:
# - realtime: the bridge's private roscore; ros_square_node (plain roscpp) reads the odometry, answers with
#   setpoints and sees the IAP reach every corner of its square; a rospy node receives /clock and the
#   odometry, whose bytes equal the bus's (as recorded in run.bag); every setpoint reaches the controller
#   and the bridge reports the round trips; /tf and /tf_static compose to the sub-aircraft's recorded poses, and
#   robot_description is set;
# - lockstep: the node answers every odometry (`answers`), so two runs give the same bag;
# - bad configurations are refused naming the key, a dead roscore ends the run naming it, and no roscore
#   outlives its run.
# usage: ros_bridge_test.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
# shellcheck source=tests/support/script.sh
source "$(dirname "$0")/support/script.sh"
scenario=$src/configs/scenarios/three_star_ros_square.yaml
python=/usr/bin/python3  # Debian's, with rospy and rosbag
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -9 "$pid" 2> /dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

wait_for_master() {  # RUN_DIR: waits until the bridge has written its private master's URI
  for _ in $(seq 1 300); do
    [ -s "$1/ros/master_uri" ] && return 0
    sleep 0.1
  done
  fail "no $1/ros/master_uri after 30 s: $(tail -5 "$1/log.txt" 2> /dev/null)"
}
square_node() {  # RUN_DIR LOG: the square node on that run's master, until odometry stops for 2 s
  ROS_MASTER_URI=$(cat "$1/ros/master_uri") ROS_IP=127.0.0.1 ROS_HOME=$work/ros_home \
    timeout 120 "$bin/ros_square_node" odom:=/iap/odom setpoint:=/iap/setpoint _hold_s:=0.5 _idle_exit_s:=2 > "$2" 2>&1
}
metric() {  # RUN_DIR PYTHON_EXPRESSION over the ros process's report `r`
  $python -c "import json,sys; r=json.load(open('$1/metrics.json'))['processes']['ros']['process']; print($2)"
}

# --- realtime ---------------------------------------------------------------------------------------------
run=$work/realtime
"$iapsim" run "$scenario" --out "$run" --set duration_s=20 > "$work/realtime.log" 2>&1 &
pids+=($!)
launcher=$!
wait_for_master "$run"
cat > "$work/capture.py" << 'EOF'
# the bytes of N messages of /iap/odom as a rospy node receives them, whether /clock came, and /tf,
# /tf_static and robot_description (as JSON)
import json
import sys
import rospy
from rospy.msg import AnyMsg
from rosgraph_msgs.msg import Clock
from tf2_msgs.msg import TFMessage
out, wanted = open(sys.argv[1], "wb"), int(sys.argv[2])
seen = {"odom": 0, "clock": 0, "tf": [], "tf_static": []}
def on_odom(message):
    if seen["odom"] < wanted:
        out.write(len(message._buff).to_bytes(4, "little") + message._buff)
    seen["odom"] += 1
def on_clock(message):
    seen["clock"] += 1
def transforms(message):
    return [{"stamp": t.header.stamp.to_nsec(), "parent": t.header.frame_id, "child": t.child_frame_id,
             "p": [t.transform.translation.x, t.transform.translation.y, t.transform.translation.z],
             "q": [t.transform.rotation.w, t.transform.rotation.x, t.transform.rotation.y, t.transform.rotation.z]}
            for t in message.transforms]
def on_tf(message):
    if len(seen["tf"]) < 50:
        seen["tf"].append(transforms(message))
def on_tf_static(message):
    seen["tf_static"] = transforms(message)
rospy.init_node("capture", anonymous=True, disable_signals=True)
rospy.Subscriber("/iap/odom", AnyMsg, on_odom, tcp_nodelay=True)
rospy.Subscriber("/clock", Clock, on_clock)
rospy.Subscriber("/tf", TFMessage, on_tf)
rospy.Subscriber("/tf_static", TFMessage, on_tf_static)
while (seen["odom"] < wanted or len(seen["tf"]) < 50) and not rospy.is_shutdown():
    rospy.rostime.wallsleep(0.05)
out.close()
seen["robot_description"] = rospy.get_param("/three_star/robot_description", "")
json.dump(seen, open(sys.argv[1] + ".json", "w"))
print("odom", seen["odom"], "clock", seen["clock"])
EOF
ROS_MASTER_URI=$(cat "$run/ros/master_uri") ROS_IP=127.0.0.1 ROS_HOME=$work/ros_home \
  timeout 60 $python "$work/capture.py" "$work/odom.bin" 400 > "$work/capture.log" 2>&1 &
pids+=($!)
capture=$!
square_node "$run" "$work/square.log" || fail "the square node did not fly its square: $(cat "$work/square.log")"
grep -q "square done" "$work/square.log" || fail "no 'square done': $(cat "$work/square.log")"
wait_code $launcher
[ $code -eq 0 ] || fail "realtime run exited $code: $(tail -20 "$work/realtime.log")"
wait_code $capture
[ $code -eq 0 ] || fail "capture node exited $code: $(cat "$work/capture.log")"
grep -qE "^odom [0-9]+ clock [1-9]" "$work/capture.log" || fail "no /clock in ROS: $(cat "$work/capture.log")"
$python - "$work/odom.bin" "$run/run.bag" << 'EOF' || fail "bridged bytes differ from the bus's"
# every odometry message a ROS node received is, byte for byte, one the bus carried (run.bag records it)
import sys
import rosbag
recorded = {raw[1] for _, raw, _ in rosbag.Bag(sys.argv[2]).read_messages(topics=["/three_star/odom"], raw=True)}
data, received = open(sys.argv[1], "rb").read(), []
while data:
    size = int.from_bytes(data[:4], "little")
    received.append(data[4:4 + size])
    data = data[4 + size:]
assert len(received) == 400, len(received)
missing = [m for m in received if m not in recorded]
assert not missing, f"{len(missing)} of {len(received)} not on the bus"
EOF
$python - "$work/odom.bin.json" "$run/run.bag" << 'EOF' || fail "/tf does not put the bodies where the bus has them"
# /tf and /tf_static compose, frame by frame, to the sub-aircraft's recorded odometry (W -> three_star/subI)
import json
import sys
import rosbag
def multiply(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return [w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2]
def rotate(q, v):
    return multiply(multiply(q, [0.0] + v), [q[0], -q[1], -q[2], -q[3]])[1:]
seen = json.load(open(sys.argv[1]))
assert "sub1_roll" in seen["robot_description"], "no robot_description"
static = {t["child"]: t for t in seen["tf_static"]}
assert static["W"]["parent"] == "world", static
odom = {}
for topic, message, _ in rosbag.Bag(sys.argv[2]).read_messages(
        topics=["/three_star/sub1/odom", "/three_star/sub2/odom", "/three_star/sub3/odom"]):
    odom[(topic.split("/")[2], message.header.stamp.to_nsec())] = message.pose.pose
checked = 0
for message in seen["tf"]:
    frames = dict(static, **{t["child"]: t for t in message})
    for sub in ("sub1", "sub2", "sub3"):
        frame, p, q = "three_star/" + sub, [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
        while frame != "W":
            t = frames[frame]
            p = [a + b for a, b in zip(rotate(t["q"], p), t["p"])]
            q = multiply(t["q"], q)
            frame = t["parent"]
        pose = odom[(sub, message[0]["stamp"])]
        expected_q = [pose.orientation.w, pose.orientation.x, pose.orientation.y, pose.orientation.z]
        position = [pose.position.x, pose.position.y, pose.position.z]
        assert max(abs(a - b) for a, b in zip(p, position)) < 1e-9, (p, position)
        assert abs(abs(sum(a * b for a, b in zip(q, expected_q))) - 1.0) < 1e-9, (q, expected_q)
        checked += 1
assert checked == 150, checked
EOF
[ "$(metric "$run" "r['to_ros']['/iap/odom']['round_trip']['unanswered']")" = 0 ] ||
  fail "unanswered odometry: $(metric "$run" "r")"
answered=$(metric "$run" "r['to_ros']['/iap/odom']['round_trip']['answered']")
[ "$answered" -gt 1000 ] || fail "only $answered round trips: $(metric "$run" "r")"
forwarded=$(metric "$run" "r['from_ros']['/iap/setpoint']['forwarded']")
received=$($python -c "import json; print(json.load(open('$run/metrics.json'))['processes']['control']['bus']['topics']['/three_star/ros_setpoint']['received'])")
[ "$forwarded" = "$received" ] || fail "$forwarded setpoints forwarded, $received reached the controller"

# --- lockstep: the node is a participant, so two runs are the same run --------------------------------------
for i in 1 2; do
  "$iapsim" run "$scenario" --out "$work/lockstep$i" --set mode=lockstep --set duration_s=12 \
    > "$work/lockstep$i.log" 2>&1 &
  pids+=($!)
  launcher=$!
  wait_for_master "$work/lockstep$i"
  if [ $i = 1 ]; then  # another subscriber of the odometry first (as rviz): not taken for the answering node
    ROS_MASTER_URI=$(cat "$work/lockstep1/ros/master_uri") ROS_IP=127.0.0.1 ROS_HOME=$work/ros_home \
      timeout 60 $python "$work/capture.py" "$work/lockstep_odom.bin" 100 > "$work/lockstep_capture.log" 2>&1 &
    pids+=($!)
    sleep 3
  fi
  square_node "$work/lockstep$i" "$work/square$i.log" || fail "lockstep $i: $(cat "$work/square$i.log")"
  wait_code $launcher
  [ $code -eq 0 ] || fail "lockstep run $i exited $code: $(tail -20 "$work/lockstep$i.log")"
done
cmp "$work/lockstep1/run.bag" "$work/lockstep2/run.bag" || fail "two lockstep runs with a ROS node differ"
[ "$(metric "$work/lockstep1" "r['to_ros']['/iap/odom']['round_trip']['before_first_answer']")" = 0 ] ||
  fail "lockstep forwarded odometry before the node listened"

# --- bad configurations, a dead master, no orphans ---------------------------------------------------------
expect_exit 2 "give clock.ack_timeout_s and this process's hang_timeout_s more" \
  "$bin/iapsim_ros_bridge" --scenario "$scenario" --node ros --check --set mode=lockstep \
  --set processes.ros.hang_timeout_s=5
# the rviz example's configuration (a render process's camera mounts on /tf_static) checks
"$iapsim" run "$src/configs/scenarios/three_star_ros_rviz.yaml" --check > "$work/check.log" 2>&1 ||
  fail "three_star_ros_rviz.yaml: $(cat "$work/check.log")"
expect_exit 2 "mounts come from an iapsim_sensors or iapsim_render process" \
  "$bin/iapsim_ros_bridge" --scenario "$src/configs/scenarios/three_star_ros_rviz.yaml" --node ros --check \
  --set 'processes.ros.params.tf.mounts_from=[physics]'
expect_exit 2 "to_ros[0].type: 'nav_msgs/Odom' is not a message type iapsim knows" \
  "$bin/iapsim_ros_bridge" --scenario "$scenario" --node ros --check \
  --set processes.ros.params.to_ros.0.type=nav_msgs/Odom
expect_exit 2 "answers: '/iap/odometry' is not the ROS name of a to_ros topic" \
  "$bin/iapsim_ros_bridge" --scenario "$scenario" --node ros --check \
  --set processes.ros.params.from_ros.0.answers=/iap/odometry
run=$work/dead_master
"$iapsim" run "$scenario" --out "$run" --set duration_s=30 > "$work/dead_master.log" 2>&1 &
pids+=($!)
launcher=$!
wait_for_master "$run"
sleep 1
port=$(sed -E 's#.*:([0-9]+)/#\1#' "$run/ros/master_uri")
pkill -TERM -f "roscore -p $port" || fail "no roscore on port $port"
wait_code $launcher
[ $code -ne 0 ] || fail "the run went on without its ROS master"
grep -qF "ROS master (roscore, http://127.0.0.1:$port/)" "$work/dead_master.log" ||
  fail "the run's end does not name the ROS master: $(tail -10 "$work/dead_master.log")"
sleep 0.5
for uri in "$work"/*/ros/master_uri; do  # roscore and rosmaster name the port, rosout its log folder
  port=$(sed -E 's#.*:([0-9]+)/#\1#' "$uri")
  if pgrep -f -- "-p $port" > /dev/null || pgrep -f "$(dirname "$uri")/" > /dev/null; then
    fail "a ROS process of $(dirname "$(dirname "$uri")") outlived its run: $(pgrep -af -- "-p $port")"
  fi
done
echo "ros bridge: realtime square with $answered round trips, lockstep reproducible, errors named"
