#!/usr/bin/env bash
# Installs every Debian package iapsim needs to build, test and run.
# Idempotent: packages already present are skipped, so a second run is quick and changes nothing.
# Fails loudly: any apt error stops the script with a non-zero exit and says which step failed.
set -euo pipefail

packages=(
  # toolchain
  cmake ninja-build g++ make pkg-config
  # core libraries
  libeigen3-dev libboost-dev libyaml-cpp-dev libcli11-dev libspdlog-dev nlohmann-json3-dev
  # bus: ZeroMQ + ROS1 wire format, bag files, message definitions for gencpp
  libzmq3-dev cppzmq-dev librosbag-storage-dev libbz2-dev pluginlib-dev libclass-loader-dev librcpputils-dev librcutils-dev
  libstd-msgs-dev libgeometry-msgs-dev libsensor-msgs-dev libnav-msgs-dev libros-rosgraph-msgs-dev
  ros-std-msgs ros-geometry-msgs ros-sensor-msgs ros-nav-msgs ros-rosgraph-msgs
  python3-genmsg python3-gencpp python3-rosbag python3-yaml python3-numpy python3-matplotlib
  # physics
  libbullet-dev libbullet-extras-dev liburdfdom-dev libtinyxml2-dev libassimp-dev
  # rendering: OSMesa (llvmpipe), EGL and GL headers, libdeflate for PNG encoding, decoding and video through OpenCV
  libosmesa6-dev libegl-dev libgl-dev libdeflate-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-videoio-dev
  # visual-inertial odometry (vio/): Lucas-Kanade tracking and fundamental-matrix RANSAC; Ceres for the
  # sliding-window estimator
  libopencv-video-dev libopencv-calib3d-dev libceres-dev
  # learning (rl/): HDF5 for the offline data sets (D4RL's layout), h5py to read them in Python, pybind11
  # for the environments' Python module
  libhdf5-dev python3-h5py pybind11-dev python3-dev
  # libtorch (CPU) for the learned policies, and an optimised BLAS under it (libtorch links libblas.so.3,
  # Debian's reference BLAS unless this provides it: about 2.5x faster for a training step, shared NOTES)
  libtorch-dev libopenblas0-pthread
  # Gloo's headers, which libtorch's c10d ProcessGroupGloo needs: PPO's workers all-reduce through it
  libgloo-dev
  # `iapsim sweep --slurm` (sbatch, squeue, scancel), and the one-node cluster of tools/slurm_local_cluster.sh
  # its tests and benchmark bring up
  slurm-client slurmctld slurmd munge
  # the live ROS bridge (rosbridge/): roscpp and topic_tools' ShapeShifter, tf2_msgs for /tf, roscore for a
  # run's private master, rospy for the test's ROS node
  libroscpp-dev libtopic-tools-dev libtf2-msgs-dev ros-core python3-rospy python3-rosgraph-msgs python3-tf2-msgs
  # tests and benchmarks (MuJoCo: the reference beside iapsim in `iapsim bench physics`; check_urdf for the
  # URDF that `iapsim urdf --ros` writes)
  libgtest-dev libgmock-dev libbenchmark-dev libmujoco-dev liburdfdom-tools
)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q '^install ok installed$' || missing+=("$p")
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  sudo="sudo"
fi

echo "install-deps: installing ${#missing[@]} packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -q || { echo "install-deps: apt-get update failed" >&2; exit 1; }
$sudo apt-get install -y -q --no-install-recommends "${missing[@]}" \
  || { echo "install-deps: apt-get install failed for: ${missing[*]}" >&2; exit 1; }
echo "install-deps: done"
