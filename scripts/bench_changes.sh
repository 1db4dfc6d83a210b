#!/usr/bin/env bash
# make bench-changes: the relocalizer in a world that changed after training.
#   scripts/bench_changes.sh [BUILD_DIR]
# Trains a model of each scene with the default configuration and one with each
# preset of CHANGES_PRESETS (config/NAME.yaml; light_augmented by default: each
# training image under a drawn light, descriptors scaled per colour channel),
# and relocalizes its test frames unchanged and
# seen under other light (evaluate --light-stops/--light-kelvin/--light-gamma:
# a global gain, colour temperature and tone curve applied in linear light, so
# they are physically honest on real frames too), each at a few severities:
#  - redkitchen-dev (../shared/data/7scenes-redkitchen-dev, the README protocol:
#    trained on frames 0-99,200-299,400-499 with --seed 42, tested on 100-199,300-399),
#    when the data is there (said when it is not);
#  - a synthetic room (synthesize --seed 1, 300 training and 100 test frames),
#    also with the world changed after training (synthesize --test-*: people
#    walking through, furniture moved, objects removed or added, a lamp off or
#    on; the training frames stay the same, so the same models answer), each in
#    the light of training; the change's name says how many were made.
# Prints one table (scripts/bench_changes_table.py): per scene and change the
# share within 5 cm / 5 deg and 2 cm / 2 deg, frames with no pose, answers off
# by more than 10 cm or 10 deg, and the change of the 5 cm share against the
# unchanged frames. Everything goes to BUILD_DIR/bench_changes (models and the
# room are reused by the next run; changes.json holds the table).
# Environment: CHANGES_THREADS (2: threads of train and evaluate);
# CHANGES_PRESETS ("light_augmented"; e.g. "light_augmented colour_normalised").
. "$(dirname "$0")/bench_setup.sh"
out="$root/$build_dir/bench_changes"
mkdir -p "$out"
threads=${CHANGES_THREADS:-2}
read -r -a presets <<< "${CHANGES_PRESETS:-light_augmented}"
for preset in "${presets[@]}"; do
  [ -f "$root/config/$preset.yaml" ] ||
    { echo "bench_changes: CHANGES_PRESETS names $preset, but config/$preset.yaml does not exist"; exit 2; }
done
# The model name suffixes: "" (the default configuration), then _PRESET each.
suffixes=("" "${presets[@]/#/_}")
# SCENE as a table names it with the model of SUFFIX: "SCENE" or "SCENE, PRESET".
label() { echo "$1${2/_/, }"; }

# NAME and evaluate's options of each change; "unchanged" first, as the reference.
changes=(
  "unchanged|"
  "half a stop darker|--light-stops -0.5"
  "one stop darker|--light-stops -1"
  "two stops darker|--light-stops -2"
  "half a stop brighter|--light-stops 0.5"
  "one stop brighter|--light-stops 1"
  "warm light, 2700 K|--light-kelvin 2700"
  "warm light, 3500 K|--light-kelvin 3500"
  "cold light, 6500 K|--light-kelvin 6500"
  "cold light, 8000 K|--light-kelvin 8000"
  "tone curve, gamma 0.7|--light-gamma 0.7"
  "tone curve, gamma 1.4|--light-gamma 1.4"
  "evening: one stop darker, 2700 K|--light-stops -1 --light-kelvin 2700"
)

manifest="$out/runs.tsv"
: > "$manifest"
measure() {  # SCENE MODEL TEST_ARGS...
  local scene=$1 model=$2
  shift 2
  local scene_folder
  scene_folder="$out/$(echo "$scene" | tr -c 'a-zA-Z0-9\n' '_')"
  mkdir -p "$scene_folder"
  for entry in "${changes[@]}"; do
    local name=${entry%%|*} options=${entry#*|} folder
    folder="$scene_folder/$(echo "$name" | tr -c 'a-zA-Z0-9\n' '_')"
    echo "bench_changes: $scene, $name"
    # shellcheck disable=SC2086
    "$tools/evaluate" --model "$model" "$@" --threads "$threads" --output "$folder" $options \
      > "$folder.log" 2>&1 || { echo "bench_changes: evaluate failed, see $folder.log"; exit 1; }
    printf '%s\t%s\t%s\n' "$scene" "$name" "$folder" >> "$manifest"
  done
}

# MODEL, then train's arguments: trained with the default configuration, and as
# MODEL_PRESET with config/PRESET.yaml each; kept for the next run while
# model_is_current (bench_setup.sh).
train_all() {
  local model=$1 name
  shift
  for name in "${suffixes[@]}"; do
    local file="${model%.model}$name.model" config=()
    [ -n "$name" ] && config=(--config "$root/config/${name#_}.yaml")
    model_is_current "$file" && continue
    echo "bench_changes: training $file (log: ${file%.model}_train.log)"
    "$tools/train" "$@" --seed 42 --threads "$threads" "${config[@]}" --output "$file" \
      > "${file%.model}_train.log" 2>&1
  done
}

data=$kitchen
if [ -f "$data/frame-000000.pose.txt" ]; then
  train_all "$out/kitchen.model" --dataset "$data" --frames 0-99,200-299,400-499
  for name in "${suffixes[@]}"; do
    measure "$(label redkitchen-dev "$name")" "$out/kitchen$name.model" --dataset "$data" \
      --frames 100-199,300-399
  done
else
  echo "bench_changes: $data is absent: the synthetic room only (see ../shared/data/README.md)"
fi

room="$out/room"
if [ ! -f "$room/scene.json" ]; then
  echo "bench_changes: synthesizing the room (seed 1, 300 + 100 frames) into $room"
  "$tools/synthesize" --seed 1 --train-frames 300 --test-frames 100 --output "$room" \
    > "$out/room_synthesize.log"
fi
train_all "$out/room.model" --dataset "$room/train"
for name in "${suffixes[@]}"; do
  measure "$(label "synthetic room" "$name")" "$out/room$name.model" --dataset "$room/test"
done

# The world changed: KEY and synthesize's options of each; the room's test frames rendered
# again from the changed room (its training frames come out the same).
world_changes=(
  "people|--test-people 1"
  "people|--test-people 2"
  "people|--test-people 3"
  "moved_furniture|--test-moved-furniture 3"
  "removed_objects|--test-removed-objects 3"
  "added_objects|--test-added-objects 3"
  "lamp|--test-lamp off"
  "lamp|--test-lamp on"
)
changes=("in the light of training|")
for entry in "${world_changes[@]}"; do
  key=${entry%%|*} options=${entry#*|}
  changed="$out/room-$(echo "$options" | tr -c 'a-zA-Z0-9\n' '_')"
  if [ ! -f "$changed/scene.json" ]; then
    echo "bench_changes: synthesizing the room with $options into $changed"
    # shellcheck disable=SC2086
    "$tools/synthesize" --seed 1 --train-frames 300 --test-frames 100 $options --output "$changed" \
      > "$changed.log" 2>&1 || { echo "bench_changes: synthesize failed, see $changed.log"; exit 1; }
  fi
  made=$(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['test_changes']['made'][sys.argv[2]])" \
    "$changed/scene.json" "$key")
  for name in "${suffixes[@]}"; do
    measure "$(label "synthetic room" "$name"): $options (made: $made)" "$out/room$name.model" \
      --dataset "$changed/test"
  done
done

python3 "$root/scripts/bench_changes_table.py" "$manifest" "$out/changes.json"
