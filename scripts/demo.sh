#!/usr/bin/env bash
# make demo: the package's main job on an embedded default. Synthesizes the
# default room, reads it back, trains the point and line forests on its
# training path and relocalizes every frame of its test path.
set -euo pipefail
build_dir=${1:-build}
export PATH=/usr/bin:/bin:$PATH
tools="$build_dir/devel/lib/relocalizer"
out="$build_dir/demo"
mkdir -p "$out"

step() { printf '\n=== %s\n' "$*"; }
start=$(date +%s)

step "1/4 synthesize the default room (seed 1: 300 training, 100 test frames, 640x480)"
"$tools/synthesize" --output "$out/scene" --seed 1 --train-frames 300 --test-frames 100

step "2/4 read it back with the dataset reader"
"$tools/dataset_info" --dataset "$out/scene/train"
"$tools/dataset_info" --dataset "$out/scene/test"

step "3/4 train the point and line forests (config/forest.yaml defaults)"
"$tools/train" --dataset "$out/scene/train" --output "$out/room.model"

step "4/4 relocalize every test frame"
"$tools/evaluate" --model "$out/room.model" --dataset "$out/scene/test" --output "$out/evaluation"

step "done in $(( $(date +%s) - start )) s; pictures: $out/scene/contact_sheet.png, $out/evaluation/trajectory.png, $out/evaluation/errors.png"
