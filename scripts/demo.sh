#!/usr/bin/env bash
# make demo: the package's main job on an embedded default. Synthesizes the
# default room, reads it back, trains the point and line forests on its
# training path, relocalizes its test path offline, then writes the test path
# as a rosbag and replays it through relocalizer_node, printing the same table.
# Last, a building: two more rooms (one looks like the default room), and every
# test frame of the look-alike relocalized against all three places.
set -euo pipefail
build_dir=${1:-build}
export PATH=/usr/bin:/bin:$PATH
tools="${RELOCALIZER_DEVEL:-$PWD/devel}/lib/relocalizer"
out="$build_dir/demo"
mkdir -p "$out"

step() { printf '\n=== %s\n' "$*"; }
start=$(date +%s)

step "1/7 synthesize the default room (seed 1: 300 training, 100 test frames, 640x480)"
"$tools/synthesize" --output "$out/scene" --seed 1 --train-frames 300 --test-frames 100

step "2/7 read it back with the dataset reader"
"$tools/dataset_info" --dataset "$out/scene/train"
"$tools/dataset_info" --dataset "$out/scene/test"

step "3/7 train the point and line forests (config/forest.yaml defaults)"
"$tools/train" --dataset "$out/scene/train" --output "$out/room.model"

step "4/7 relocalize every test frame offline"
"$tools/evaluate" --model "$out/room.model" --dataset "$out/scene/test" --output "$out/evaluation"

step "5/7 write the test path as a rosbag (30 Hz)"
"$tools/make_bag" --dataset "$out/scene/test" --output "$out/test.bag"

step "6/7 replay the bag through relocalizer_node (continuous mode, every frame)"
ROS_LOG_DIR="$PWD/$build_dir/ros_log" ./scripts/replay_eval "$out/room.model" "$out/test.bag" "$out/replay"

step "7/7 a building: two more rooms (room-2 looks like the default room: the same furniture, placed differently), each place asked about room-2's frames"
"$tools/synthesize" --output "$out/building" --rooms 3 --seed 1 --train-frames 60 --test-frames 20 \
  --width 320 --height 240 --no-walk > /dev/null
for room in room-1 room-2; do
  "$tools/train" --dataset "$out/building/$room/train" --output "$out/building/$room.model" > /dev/null
done
"$tools/evaluate" --model room-0="$out/room.model" --model room-1="$out/building/room-1.model" \
  --model room-2="$out/building/room-2.model" --dataset "$out/building/room-2/test" \
  --expect-place room-2 --output "$out/building/evaluation"

step "done in $(( $(date +%s) - start )) s; pictures: $out/scene/contact_sheet.png, $out/replay/trajectory.png, $out/replay/errors.png, $out/building/evaluation/places.csv"
