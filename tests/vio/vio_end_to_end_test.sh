#!/usr/bin/env bash
# `iapsim vio` end to end, as a user runs it: a short rendered run of the seed's stereo data set (all three
# sub-aircraft) with the three iapsim_vio processes estimating live over the bus (three_star_vio.yaml), the
# offline estimator over its bag in all three modes (VIRPO's byte for byte what the processes published) (ATE,
# determinism, one sub-aircraft alone, UWB, the anchor sweep, VIRPO's constraints, a settings file), and the errors a user meets (a bag without images, a camera model
# that is not the scenario's, a scenario without cameras, an unknown sub-aircraft, VIRPO with one
# sub-aircraft, a misspelt setting), each a clear message and exit code 2.
# usage: vio_end_to_end_test.sh BUILD_BIN_DIR SOURCE_DIR
set -euo pipefail
# shellcheck source=tests/support/script.sh
source "$(dirname "$0")/../support/script.sh"

"$iapsim" vio --help > /dev/null || fail "vio --help"

# 1.5 s of the figure-eight with every stereo pair, no videos (they are for people); the scenario's own
# timeouts allow for a loaded 2-core machine, where the renderer's seven images a frame can take seconds
"$iapsim" run "$src/configs/scenarios/three_star_vio.yaml" --duration 1.5 --out "$work/run" \
  --set 'evaluation.videos=[]' > "$work/run.out" || fail "run: $(cat "$work/run.out")"

# the three modes at once (vio_all/vio, vio_uwb, virpo) and the table of their ATEs
"$iapsim" vio "$work/run" --mode all --out "$work/all" > "$work/vio.out" || fail "vio: $(cat "$work/vio.out")"
grep -q "iap/sub3" "$work/vio.out" || fail "no table row for sub3: $(cat "$work/vio.out")"
grep -q "| iap/sub1 VIO | iap/sub1 VIO+UWB | iap/sub1 VIRPO |" "$work/all/table.md" || fail "$(cat "$work/all/table.md")"
for png in ate_boxplot.png trajectories.png; do  # Fig. 17's box plots and the trajectories
  [ -s "$work/all/$png" ] || fail "no $png: $(cat "$work/vio.out")"
done
/usr/bin/python3 - "$work/all/table.json" << 'PY' || fail "table.json: $(cat "$work/all/table.json")"
import json, sys
table = json.load(open(sys.argv[1]))
assert sorted(table) == ["iap/platform", "iap/sub1", "iap/sub2", "iap/sub3"], sorted(table)
for body, row in table.items():
    assert all(0 < row[mode] < 0.03 for mode in ("vio", "vio_uwb", "virpo")), (body, row)
    assert abs(row["virpo_gain_over_vio_uwb"] - (1 - row["virpo"] / row["vio_uwb"])) < 1e-12, (body, row)
PY
ln -s "$work/all/vio" "$work/vio"
ln -s "$work/all/vio_uwb" "$work/uwb"
/usr/bin/python3 - "$work/vio/vio.json" << 'PY' || fail "vio.json: $(cat "$work/vio/vio.json")"
import json, sys
report = json.load(open(sys.argv[1]))
subs = report["sub_aircraft"]
assert sorted(subs) == ["iap/sub1", "iap/sub2", "iap/sub3"], sorted(subs)
for name, sub in subs.items():
    assert sub["frames"] == 31, (name, sub["frames"])            # 20 Hz over [0, 1.5] s
    assert sub["failures"] == 0, (name, sub["last_failure"])
    assert sub["ate"]["matched"] == 31, (name, sub["ate"])
    # measured 4-8 mm over 3 s; the bound leaves room, and a broken estimator drifts metres
    assert sub["ate"]["rmse_m"] < 0.03, (name, sub["ate"])
    assert sub["ate_aligned"]["rmse_m"] <= sub["ate"]["rmse_m"] + 1e-12, (name, sub)
    assert sub["ms_per_frame"]["solve"] > 0, (name, sub)
    assert sub["rpe_1s"]["pairs"] == 11, (name, sub["rpe_1s"])   # stamps 0..0.5 s with a partner 1 s later
    assert sub["rpe_1s"]["translation_rmse_m"] < 0.03, (name, sub["rpe_1s"])
centre = report["centre"]                                       # the platform, from the three and the joints
assert centre["body"] == "iap/platform" and centre["ate"]["matched"] == 31, centre
assert centre["ate"]["rmse_m"] < 0.03, centre
PY
for f in iap_sub1_estimate.tum iap_sub1_truth.tum iap_sub3_estimate.tum iap_platform_estimate.tum iap_platform_truth.tum; do
  [ "$(grep -vc '^#' "$work/vio/$f")" -eq 31 ] || fail "$f: $(wc -l < "$work/vio/$f") lines"
done

# the same bag gives byte-identical estimates, each mode alone as in the pass of --mode all (which tracks each
# image once for the three); one sub-aircraft alone gives its own the same way
"$iapsim" vio "$work/run/run.bag" --out "$work/again" > /dev/null
"$iapsim" vio "$work/run" --mode virpo --out "$work/virpo_alone" > /dev/null
"$iapsim" vio "$work/run" --sub iap/sub2 --out "$work/sub2" > /dev/null
for sub in iap_sub1 iap_sub2 iap_sub3; do
  cmp -s "$work/vio/${sub}_estimate.tum" "$work/again/${sub}_estimate.tum" || fail "$sub differs between two runs"
  cmp -s "$work/all/virpo/${sub}_estimate.tum" "$work/virpo_alone/${sub}_estimate.tum" ||
    fail "$sub: VIRPO in the pass of --mode all differs from VIRPO alone"
done
/usr/bin/python3 - "$work/all" "$work/again/vio.json" << 'PY' || fail "the pass of --mode all: $(cat "$work/all/vio/vio.json")"
import json, os, sys
for mode in ("vio", "vio_uwb", "virpo"):
    report = json.load(open(os.path.join(sys.argv[1], mode, "vio.json")))
    assert report["mode"] == mode and report["pass"] == ["vio", "vio_uwb", "virpo"], report
    assert report["wall_s"] > 0 and report["real_time_factor"] > 0, report
assert "pass" not in json.load(open(sys.argv[2])), "a run of one mode is not a pass of several"
PY
cmp -s "$work/vio/iap_sub2_estimate.tum" "$work/sub2/iap_sub2_estimate.tum" || fail "sub2 alone differs"
for other in iap_sub1 iap_sub3 iap_platform; do
  [ ! -e "$work/sub2/${other}_estimate.tum" ] || fail "--sub iap/sub2 estimated $other too"
done

# with the UWB ranges to the scenario's anchors (Table X): every range of the run joins the estimate
/usr/bin/python3 - "$work/uwb/vio.json" << 'PY' || fail "vio_uwb: $(cat "$work/uwb/vio.json")"
import json, sys
report = json.load(open(sys.argv[1]))
assert report["mode"] == "vio_uwb", report["mode"]
for name, sub in report["sub_aircraft"].items():
    # 4 anchors at 50 Hz over [0, 1.5] s: all before the last frame join the estimate; those stamped with the
    # last frame itself only when the bag holds them before that frame's images
    assert 4 * 75 <= sub["ranges_used"] <= 4 * 76, (name, sub["ranges_used"])
    assert sub["failures"] == 0 and sub["ate"]["rmse_m"] < 0.03, (name, sub)
PY

# Table VII's sweep on one sub-aircraft: VIO, then the first 1..4 anchors; no anchors is VIO, all four VIO+UWB
"$iapsim" vio "$work/run" --mode anchors --sub iap/sub1 --out "$work/anchors" > "$work/anchors.out" ||
  fail "anchors: $(cat "$work/anchors.out")"
grep -q "| number of anchors | 0 | 1 | 2 | 3 | 4 | decreasing |" "$work/anchors/table.md" || fail "$(cat "$work/anchors/table.md")"
[ -s "$work/anchors/anchors.png" ] || fail "no anchors.png: $(cat "$work/anchors.out")"
cmp -s "$work/anchors/anchors_0/iap_sub1_estimate.tum" "$work/vio/iap_sub1_estimate.tum" || fail "0 anchors is not VIO"
cmp -s "$work/anchors/anchors_4/iap_sub1_estimate.tum" "$work/uwb/iap_sub1_estimate.tum" || fail "4 anchors is not VIO+UWB"
/usr/bin/python3 - "$work/anchors" << 'PY' || fail "anchors: $(cat "$work/anchors/table.json")"
import json, os, sys
table = json.load(open(os.path.join(sys.argv[1], "table.json")))
assert sorted(table) == ["iap/sub1"], sorted(table)
for n in range(5):
    sub = json.load(open(os.path.join(sys.argv[1], "anchors_%d" % n, "vio.json")))["sub_aircraft"]["iap/sub1"]
    assert 75 * n <= sub["ranges_used"] <= 76 * n, (n, sub["ranges_used"])
    assert table["iap/sub1"]["anchors_%d" % n] == sub["ate"]["rmse_m"], (n, table)
PY

# VIRPO: ranges, the attitude estimate at every window frame and each other sub-aircraft's joint; the same bag
# gives the same estimates again (the sub-aircraft step in lockstep, whatever the threads do)
printf 'virpo:\n  sigma_attitude_rad: 0.04\n' > "$work/virpo.yaml"
"$iapsim" vio "$work/run" --mode virpo --config "$work/virpo.yaml" --out "$work/virpo" > /dev/null
"$iapsim" vio "$work/run" --mode virpo --set virpo.sigma_attitude_rad=0.04 --out "$work/virpo_again" > /dev/null
# what the processes published live is what the offline runner computes from their bag, to the last digit
"$iapsim" vio "$work/run" --mode virpo --config "$src/configs/vio/virpo_simulated.yaml" --out "$work/simulated" \
  > /dev/null
for sub in sub1 sub2 sub3; do
  "$iapsim" export "$work/run/run.bag" --topic "/iap/$sub/vio/odom" --format tum -o "$work/bus_$sub.tum" 2> /dev/null
  [ "$(grep -vc '^#' "$work/bus_$sub.tum")" -eq 31 ] || fail "/iap/$sub/vio/odom: $(cat "$work/bus_$sub.tum")"
  cmp -s <(grep -v '^#' "$work/bus_$sub.tum") <(grep -v '^#' "$work/simulated/iap_${sub}_estimate.tum") ||
    fail "$sub: the vio process published other estimates than iapsim vio computes from the bag"
done
# and the platform's instance, from the three and its own attitude estimate, is the offline runner's centre
"$iapsim" export "$work/run/run.bag" --topic /iap/vio/odom --format tum -o "$work/bus_platform.tum" 2> /dev/null
cmp -s <(grep -v '^#' "$work/bus_platform.tum") <(grep -v '^#' "$work/simulated/iap_platform_estimate.tum") ||
  fail "the platform's vio process published another centre than iapsim vio computes"
# the run's own evaluation of the live estimates (evaluation.odometry) is the offline runner's, to the digit
/usr/bin/python3 - "$work/run/metrics.json" "$work/simulated/vio.json" << 'PY' || fail "evaluation.odometry"
import json, sys
odometry, offline = json.load(open(sys.argv[1]))["odometry"], json.load(open(sys.argv[2]))
for sub in ("sub1", "sub2", "sub3"):
    live, off = odometry["/iap/%s/vio/odom" % sub], offline["sub_aircraft"]["iap/" + sub]
    assert live["truth"] == "/iap/%s/odom" % sub and live["estimate_tum"] == "iap_%s_vio_odom.tum" % sub, live
    assert live["ate"] == off["ate"] and live["rpe_1s"]["pairs"] == off["rpe_1s"]["pairs"], (sub, live, off)
    for key in ("translation_rmse_m", "rotation_rmse_deg"):  # the truth's rotation there went through a matrix
        assert abs(live["rpe_1s"][key] - off["rpe_1s"][key]) < 1e-9, (sub, key, live, off)
assert odometry["/iap/vio/odom"]["ate"] == offline["centre"]["ate"], (odometry["/iap/vio/odom"], offline["centre"])
PY
cmp -s <(grep -v '^#' "$work/run/iap_vio_odom.tum") <(grep -v '^#' "$work/simulated/iap_platform_estimate.tum") ||
  fail "evaluation.odometry's TUM file of /iap/vio/odom is not the estimate"
/usr/bin/python3 - "$work/run/metrics.json" << 'PY' || fail "vio processes: $(cat "$work/run/metrics.json")"
import json, sys
processes = json.load(open(sys.argv[1]))["processes"]
for name in ("vio_sub1", "vio_sub2", "vio_sub3"):
    p = processes[name]["process"]
    assert p["frames"] == 31 and p["failures"] == 0 and p["kinematic_constraints"] > 0, (name, p)
    assert p["propagated"] == 301, (name, p)  # at every IMU sample (200 Hz) from the first frame on
platform = processes["vio_platform"]["process"]
assert platform["published"] == 31 and platform["stamps_without_every_sub_aircraft"] == 0, platform
assert platform["imu_propagate"] == {"published": 301, "stamps_without_every_sub_aircraft": 0}, platform
assert platform["attitude_topic"] == "/iap/attitude", platform  # the platform's own IMU (platform_imu)
PY
# the propagated estimates: at every IMU sample, at a frame's stamp the frame's estimate itself, and the
# platform's as close to the truth as the frames'
for topic in /iap/sub1/vio /iap/vio; do
  "$iapsim" export "$work/run/run.bag" --topic "$topic/odom" --format tum -o "$work/frames.tum" 2> /dev/null
  "$iapsim" export "$work/run/run.bag" --topic "$topic/imu_propagate" --format tum -o "$work/propagated.tum" 2> /dev/null
  /usr/bin/python3 - "$work/frames.tum" "$work/propagated.tum" "$work/run/metrics.json" "$topic" << 'PY' ||
import json, sys
read = lambda path: {line.split()[0]: line for line in open(path) if not line.startswith("#")}
frames, propagated = read(sys.argv[1]), read(sys.argv[2])
assert len(frames) == 31 and len(propagated) == 301, (len(frames), len(propagated))
assert all(propagated[stamp] == line for stamp, line in frames.items()), "a frame's stamp differs"
if sys.argv[4] == "/iap/vio":
    odometry = json.load(open(sys.argv[3]))["odometry"]
    carried = odometry["/iap/vio/imu_propagate"]
    assert carried["ate"]["matched"] == 301 and carried["ate"]["rmse_m"] < 0.03, carried
PY
    fail "$topic/imu_propagate"
done
/usr/bin/python3 - "$work/virpo/vio.json" "$work/uwb/vio.json" << 'PY' || fail "virpo: $(cat "$work/virpo/vio.json")"
import json, sys
report, uwb = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
assert report["mode"] == "virpo", report["mode"]
for name, sub in report["sub_aircraft"].items():
    assert sub["failures"] == 0 and sub["ate"]["rmse_m"] < 0.03, (name, sub)
    assert sub["ranges_used"] == uwb["sub_aircraft"][name]["ranges_used"], (name, sub)
    # from the second frame on, each solve's window frames (up to 11) have an attitude and a joint from each
    # of the two others (from the previous frame on)
    assert 30 <= sub["attitude_constraints"], (name, sub)
    assert 2 * 29 <= sub["kinematic_constraints"] <= 2 * sub["attitude_constraints"], (name, sub)
PY
for sub in iap_sub1 iap_sub2 iap_sub3 iap_platform; do
  cmp -s "$work/virpo/${sub}_estimate.tum" "$work/virpo_again/${sub}_estimate.tum" || fail "virpo: $sub differs"
done

# flying on the estimate: the scenario and every process's params are valid (the flight itself is long)
"$iapsim" run "$src/configs/scenarios/three_star_vio_flight.yaml" --check --out "$work/flight_check" > /dev/null ||
  fail "three_star_vio_flight.yaml does not check"
# the slow suite that flies it whole (make nightly) reads: its flights are known, an unknown one is refused
expect_exit 2 "no flight 'none' in $src/configs/regression/slow/suite.yaml" \
  "$iapsim" regress "$src/configs/regression/slow" --only none --out "$work/slow"
# the manual flights (b)-(d) of Table VIII: valid, each a pilot log replayed in its scene with Table XI's anchors
for scene in station broad_station bright_arena; do
  "$iapsim" run "$src/configs/scenarios/three_star_pilot_$scene.yaml" --check --out "$work/pilot_$scene" > /dev/null ||
    fail "three_star_pilot_$scene.yaml does not check"
done

# errors
expect_exit 2 "mode virpo needs two or more sub-aircraft of vehicle 'iap' with stereo cameras (1 given)" \
  "$iapsim" vio "$work/run" --mode virpo --sub iap/sub1
expect_exit 2 "virpo.sigma_lnk_m" "$iapsim" vio "$work/run" --mode virpo --set virpo.sigma_lnk_m=0.1
"$iapsim" run "$src/configs/scenarios/three_star_sensors.yaml" --duration 0.2 --out "$work/sensors" > /dev/null
expect_exit 2 "no process renders cameras (params.cameras)" "$iapsim" vio "$work/sensors"
expect_exit 2 "no messages on /iap/sub1/stereo/left/image_raw/compressed" \
  "$iapsim" vio "$work/sensors/run.bag" --scenario "$work/run/scenario.resolved.yaml"
sed 's/hfov_deg: 90, baseline_m/hfov_deg: 80, baseline_m/' "$work/run/scenario.resolved.yaml" > "$work/other_camera.yaml"
expect_exit 2 "/iap/sub1/stereo/left/camera_info: the recorded camera (640x480, fx 320.000" \
  "$iapsim" vio "$work/run/run.bag" --scenario "$work/other_camera.yaml"
# stereo images that do not decode from the tenth frame on, while the front ends run ahead of the estimators
# on threads of their own: the run stops with the topic named, nothing left waiting
mkdir -p "$work/corrupt"
cp "$work/run/scenario.resolved.yaml" "$work/corrupt/"
/usr/bin/python3 - "$work/run/run.bag" "$work/corrupt/run.bag" << 'PY' || fail "could not corrupt the bag's images"
import sys
data = bytearray(open(sys.argv[1], "rb").read())
signature, found, at = b"\x89PNG\r\n\x1a\n", 0, 0
while (at := data.find(signature, at + 1)) >= 0:
    found += 1
    if found > 60:  # 640x480 images of tens of kilobytes: bytes 1000-1400 are inside the compressed pixels
        data[at + 1000:at + 1400] = b"\xff" * 400
assert found > 120, found
open(sys.argv[2], "wb").write(data)
PY
expect_exit 2 "image_raw/compressed: a PNG whose image data does not inflate to 640x480 RGB pixels" \
  "$iapsim" vio "$work/corrupt" --mode virpo
expect_exit 2 "no stereo camera on 'iap/sub9'" "$iapsim" vio "$work/run" --sub iap/sub9
expect_exit 2 "sub: 'sub9' has no stereo camera in this scenario" \
  "$bin/iapsim_vio" --scenario "$src/configs/scenarios/three_star_vio.yaml" --node vio_sub1 --check \
  --set processes.vio_sub1.params.sub=sub9
expect_exit 2 "processes.vio_platform.after: must name 'sensors', whose platform_imu gives the platform's attitude" \
  "$iapsim" run "$src/configs/scenarios/three_star_vio.yaml" --check --out "$work/bad_after" \
  --set 'processes.vio_platform.after=[vio_sub1, vio_sub2, vio_sub3]'
expect_exit 2 "evaluation.odometry[0].truth: is required" "$iapsim" run "$src/configs/scenarios/three_star_vio.yaml" \
  --check --out "$work/bad_odometry" --set 'evaluation.odometry=[{estimate: /iap/sub1/vio/odom}]'
expect_exit 2 "evaluation.odometry[0].estimate: expected a topic name starting with /" \
  "$iapsim" run "$src/configs/scenarios/three_star_vio.yaml" --check --out "$work/bad_odometry" \
  --set 'evaluation.odometry=[{estimate: iap/sub1/vio/odom, truth: /iap/sub1/odom}]'
expect_exit 2 "--mode: slam not in {vio,vio_uwb,virpo,all,anchors}" "$iapsim" vio "$work/run" --mode slam
expect_exit 2 "uwb.anchors: no anchor 'anchor9' in $work/run/scenario.resolved.yaml" \
  "$iapsim" vio "$work/run" --mode vio_uwb --set 'uwb.anchors=[anchor1,anchor9]' 
echo "vio offline: all checks passed"
