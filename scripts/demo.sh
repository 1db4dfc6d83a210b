#!/usr/bin/env bash
# make demo: the package's main job on an embedded default. Synthesizes the
# default room, reads it back, trains the point and line forests on its
# training path, relocalizes its test path offline, then writes the test path
# as a rosbag and replays it through relocalizer_node, printing the same table.
set -euo pipefail
build_dir=${1:-build}
export PATH=/usr/bin:/bin:$PATH
tools="${RELOCALIZER_DEVEL:-$PWD/devel}/lib/relocalizer"
out="$build_dir/demo"
mkdir -p "$out"

step() { printf '\n=== %s\n' "$*"; }
start=$(date +%s)

step "1/6 synthesize the default room (seed 1: 300 training, 100 test frames, 640x480)"
"$tools/synthesize" --output "$out/scene" --seed 1 --train-frames 300 --test-frames 100

step "2/6 read it back with the dataset reader"
"$tools/dataset_info" --dataset "$out/scene/train"
"$tools/dataset_info" --dataset "$out/scene/test"

step "3/6 train the point and line forests (config/forest.yaml defaults)"
"$tools/train" --dataset "$out/scene/train" --output "$out/room.model"

step "4/6 relocalize every test frame offline"
"$tools/evaluate" --model "$out/room.model" --dataset "$out/scene/test" --output "$out/evaluation"

step "5/6 write the test path as a rosbag (30 Hz)"
"$tools/make_bag" --dataset "$out/scene/test" --output "$out/test.bag"

step "6/6 replay the bag through relocalizer_node (continuous mode, every frame)"
ROS_LOG_DIR="$PWD/$build_dir/ros_log" ./scripts/replay_eval "$out/room.model" "$out/test.bag" "$out/replay"

step "done in $(( $(date +%s) - start )) s; pictures: $out/scene/contact_sheet.png, $out/replay/trajectory.png, $out/replay/errors.png"
