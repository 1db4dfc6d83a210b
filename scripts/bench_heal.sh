#!/usr/bin/env bash
# make bench-heal: a learned place heals itself after furniture moved (issue 40).
#   scripts/bench_heal.sh [BUILD_DIR]
# The synthetic room of seed 2 (the room where synthesize --test-moved-furniture 3
# makes all three moves) is learned as submaps from one lap of its test loop
# (300 frames at 30 Hz, 10 s), as the node learns beside SLAM. Then three
# pieces of furniture move, and the same place goes on learning, as the node
# does in learn mode with model:=FOLDER, from 30 s and 60 s of SLAM-tracked
# frames in the changed room (the changed lap looped at 30 Hz; evaluate
# --learn-frames --submaps --model FOLDER, poses from the ground truth). The
# held-out frames are 100 poses of the same loop, between and beside the
# learned ones, each rendered with two draws of depth noise (synthesize
# --test-frames 100 after 280 and after 300 training frames), so 200 frames,
# unchanged and changed.
# Prints one table: before the change, just after it, after 30 s and 60 s of
# learning in the changed room, and the unchanged room's frames after 60 s
# (the place now shows the moved furniture): the share within 5 cm / 5 deg and
# 2 cm / 2 deg, frames with no pose, answers off by more than 10 cm or 10 deg,
# and the key frames learned / left covered; then the same learning with
# --relearn-agreement 0 (covered key frames never learned again, as before
# online/place_change.h); then the same room surveyed by `train` from the lap
# before the change, as it answers and as it heals in learn mode from its one
# model file (the same rows). Everything goes to
# BUILD_DIR/bench_heal (the rendered frames are reused by the next run;
# heal.json holds the table).
# Environment: HEAL_THREADS (2: threads of evaluate).
. "$(dirname "$0")/bench_setup.sh"
out="$root/$build_dir/bench_heal"
mkdir -p "$out"
threads=${HEAL_THREADS:-2}
rate=30
lap=300  # frames of one lap of the test loop, 10 s at 30 Hz

# NAME and synthesize's options (a full lap of the test loop needs 280 training
# frames or more; the training frames' count also moves the test frames' noise).
renders=(
  "loop|--train-frames 280 --test-frames $lap"
  "loop_moved|--train-frames 280 --test-frames $lap --test-moved-furniture 3"
  "held_out|--train-frames 280 --test-frames 100"
  "held_out_b|--train-frames 300 --test-frames 100"
  "held_out_moved|--train-frames 280 --test-frames 100 --test-moved-furniture 3"
  "held_out_moved_b|--train-frames 300 --test-frames 100 --test-moved-furniture 3"
)
for entry in "${renders[@]}"; do
  name=${entry%%|*} options=${entry#*|}
  if [ ! -f "$out/$name/scene.json" ]; then
    echo "bench_heal: synthesizing $name ($options)"
    # shellcheck disable=SC2086
    "$tools/synthesize" --seed 2 $options --output "$out/$name" \
      > "$out/$name.log" 2>&1 || { echo "bench_heal: synthesize failed, see $out/$name.log"; exit 1; }
  fi
done
made=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['test_changes']['made']['moved_furniture'])" \
  "$out/loop_moved/scene.json")
[ "$made" = 3 ] || { echo "bench_heal: the room moved $made pieces of furniture, not 3"; exit 1; }

# One dataset of links, so that evaluate learns and relocalizes from one folder:
# 0-299 the lap before the change, 300-499 held out before, 500-699 held out
# after, 700-2499 the changed lap six times (60 s at 30 Hz).
data="$out/dataset"
rm -rf "$data"
mkdir -p "$data"
cp "$out/loop/test/camera-intrinsics.txt" "$out/loop/test/colour-registration.txt" "$data/"
link() {  # FOLDER FIRST_ID COUNT
  local from=$1 at=$2 count=$3 i
  for ((i = 0; i < count; ++i)); do
    for part in color.png depth.png pose.txt; do
      ln -s "$from/frame-$(printf %06d "$i").$part" "$data/frame-$(printf %06d $((at + i))).$part"
    done
  done
}
link "$out/loop/test" 0 $lap
link "$out/held_out/test" $lap 100
link "$out/held_out_b/test" $((lap + 100)) 100
link "$out/held_out_moved/test" $((lap + 200)) 100
link "$out/held_out_moved_b/test" $((lap + 300)) 100
for ((k = 0; k < 6; ++k)); do link "$out/loop_moved/test" $((lap + 400 + k * lap)) $lap; done
unchanged=$lap-$((lap + 199)) moved=$((lap + 200))-$((lap + 399)) stream=$((lap + 400))

manifest="$out/runs.tsv"
: > "$manifest"
run() {  # ROW FOLDER evaluate's options...
  local row=$1 folder="$out/$2"
  shift 2
  echo "bench_heal: $row"
  rm -rf "$folder"
  "$tools/evaluate" --dataset "$data" --threads "$threads" --output "$folder" "$@" \
    > "$folder.log" 2>&1 || { echo "bench_heal: evaluate failed, see $folder.log"; exit 1; }
  printf '%s\t%s\n' "$row" "$folder" >> "$manifest"
}
rm -rf "$out/place" "$out"/healed_* "$out"/never_relearned_*
run "before the change (learned from one lap)" before --learn-frames 0-$((lap - 1)) --submaps \
  --frames "$unchanged" --save-model "$out/place"
run "just after the change" just_after --model "$out/place" --frames "$moved"
for seconds in 30 60; do
  run "after ${seconds} s of learning in the changed room" "after_${seconds}s" --model "$out/place" \
    --learn-frames "$stream-$((stream + seconds * rate - 1))" --submaps --frames "$moved" \
    --save-model "$out/healed_${seconds}s"
done
run "unchanged room's frames after 60 s" unchanged_after --model "$out/healed_60s" \
  --frames "$unchanged"
# What the same learning did before covered key frames were learned again.
for seconds in 30 60; do
  run "after ${seconds} s, covered key frames never learned again" "never_relearned_${seconds}s" \
    --model "$out/place" --learn-frames "$stream-$((stream + seconds * rate - 1))" --submaps \
    --frames "$moved" --relearn-agreement 0 --save-model "$out/never_relearned_${seconds}s_place"
done

# The same room surveyed by `train` (every frame of the lap before the change,
# default training) instead of learned: continued in learn mode from that one
# model file, it answers as frozen submap 0 and learns only what its surface
# does not hold (online/place_change.h: viewKnowledge).
rm -rf "$out"/survey_healed_*
echo "bench_heal: training the survey"
"$tools/train" --dataset "$data" --frames 0-$((lap - 1)) --threads "$threads" \
  --output "$out/survey.model" > "$out/survey.log" 2>&1 ||
  { echo "bench_heal: train failed, see $out/survey.log"; exit 1; }
run "surveyed by train: before the change" survey_before --model "$out/survey.model" \
  --frames "$unchanged"
run "surveyed by train: just after the change" survey_just_after --model "$out/survey.model" \
  --frames "$moved"
for seconds in 30 60; do
  run "surveyed by train: after ${seconds} s of learning in the changed room" \
    "survey_after_${seconds}s" --model "$out/survey.model" \
    --learn-frames "$stream-$((stream + seconds * rate - 1))" --submaps --frames "$moved" \
    --save-model "$out/survey_healed_${seconds}s"
done
run "surveyed by train: unchanged room's frames after 60 s" survey_unchanged_after \
  --model "$out/survey_healed_60s" --frames "$unchanged"

python3 - "$manifest" "$out/heal.json" <<'EOF'
import json, re, sys
rows = []
for line in open(sys.argv[1]):
    row, folder = line.rstrip("\n").split("\t")
    s = json.load(open(folder + "/summary.json"))
    log = open(folder + ".log").read()
    learned = re.findall(r"(\d+) key frames in (\d+) submaps \((\d+) covered\)", log)
    rows.append({"row": row, "frames": s["frames"],
                 "within_5cm_5deg": 100 * s["within_5cm_5deg"],
                 "within_2cm_2deg": 100 * s["within_2cm_2deg"],
                 "no_pose": s["frames_without_pose"], "wrong_answers": s["wrong_answers"],
                 "keyframes_learned": int(learned[-1][0]) if learned else None,
                 "keyframes_covered": int(learned[-1][2]) if learned else None,
                 "submaps": int(learned[-1][1]) if learned else None})
json.dump(rows, open(sys.argv[2], "w"), indent=2)
print("| | within 5 cm / 5 deg | within 2 cm / 2 deg | no pose | wrong (> 10 cm / 10 deg) "
      "| key frames learned / covered (submaps) |")
print("| --- | --- | --- | --- | --- | --- |")
for r in rows:
    kf = ("%d / %d (%d)" % (r["keyframes_learned"], r["keyframes_covered"], r["submaps"])
          if r["keyframes_learned"] is not None else "")
    print("| %s | %.1f %% | %.1f %% | %d | %d | %s |" % (
        r["row"], r["within_5cm_5deg"], r["within_2cm_2deg"], r["no_pose"],
        r["wrong_answers"], kf))
EOF
