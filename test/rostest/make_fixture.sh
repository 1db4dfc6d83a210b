#!/usr/bin/env bash
# Builds the rostests' data from nothing: a small synthetic room, a small model
# trained on it, a bag of its test frames (make_bag), a bag of its training
# frames with TF for learn mode and the offline
# `evaluate` output the replay test compares against; a folder of submaps
# learned from the training frames; and a second, different room with its
# model, the other place of the many-places test.
#   make_fixture.sh TOOL_DIR FIXTURE_DIR
set -euo pipefail
tools=$1
out=$2
here=$(cd "$(dirname "$0")" && pwd)
rm -rf "$out"
mkdir -p "$out"
"$tools/synthesize" --output "$out/scene" --train-frames 60 --test-frames 20 --width 320 --height 240 >/dev/null
"$tools/train" --dataset "$out/scene/train" --config "$here/fixture_forest.yaml" --output "$out/model.bin" >/dev/null
"$tools/make_bag" --dataset "$out/scene/test" --output "$out/test.bag" >/dev/null
# Learn mode: the training frames with their poses on TF, as recorded beside SLAM.
"$tools/make_bag" --dataset "$out/scene/train" --tf --output "$out/learn.bag" >/dev/null
"$tools/evaluate" --model "$out/model.bin" --dataset "$out/scene/test" --output "$out/evaluate" >/dev/null
# A building learned online and saved (learn mode's folder of submaps): the
# training loop cut into submaps of 8 key frames, for the node to answer from.
"$tools/evaluate" --dataset "$out/scene/train" --learn-frames 0-59 --frames 0 --submaps \
  --max-keyframes 8 --learn-config "$here/fixture_forest.yaml" --curve-every 1000 \
  --save-model "$out/learned" --output "$out/learned_eval" >/dev/null
# Issue 38: the same set with its last submap renumbered 2147483647 (its
# `index + 1` once overflowed and the node aborted at start-up).
cp -r "$out/learned" "$out/learned_huge_index"
python3 - "$out/learned_huge_index/manifest.json" <<'PY'
import collections, json, sys
manifest = json.load(open(sys.argv[1]), object_pairs_hook=collections.OrderedDict)
last = manifest["submaps"][-1]
if manifest["active"] == last["index"]:
    manifest["active"] = 2147483647
last["index"] = 2147483647
open(sys.argv[1], "w").write(json.dumps(manifest, indent=2) + "\n")
PY
# Many places: another room (another seed), trained the same way.
"$tools/synthesize" --output "$out/scene2" --seed 2 --train-frames 60 --test-frames 20 --width 320 --height 240 >/dev/null
"$tools/train" --dataset "$out/scene2/train" --config "$here/fixture_forest.yaml" --output "$out/model2.bin" >/dev/null
touch "$out/fixture.stamp"
echo "rostest fixture in $out"
