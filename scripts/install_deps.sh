#!/usr/bin/env bash
# Installs the Debian bookworm packages the package builds, tests and runs with.
# Idempotent: asks apt only for what dpkg does not already have.
set -euo pipefail

packages=(
  build-essential cmake pkg-config
  catkin ros-message-generation ros-message-runtime
  libroscpp-dev librosbag-dev libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev
  libcv-bridge-dev libmessage-filters-dev libimage-transport-dev libnodelet-dev
  libstd-msgs-dev libgeometry-msgs-dev libsensor-msgs-dev libstd-srvs-dev ros-std-srvs
  librostest-dev python3-rostest python3-roslaunch python3-rosmaster python3-rosnode
  python3-rostopic python3-rosservice python3-rosbag rosout rosbash
  python3-catkin-pkg python3-rospkg python3-empy python3-nose
  libopencv-dev libopencv-contrib-dev libceres-dev libeigen3-dev libtbb-dev
  libyaml-cpp-dev nlohmann-json3-dev libcli11-dev
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  # make fuzz: clang with libFuzzer and the sanitizer runtimes; llvm-symbolizer
  # (llvm) turns sanitizer reports into file:line stacks for make test-asan too.
  clang libclang-rt-14-dev llvm
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "deps: all ${#packages[@]} Debian packages present"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
echo "deps: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
