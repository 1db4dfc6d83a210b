#!/usr/bin/env bash
# make bench-places: many places in one node, measured (issue 25's targets).
#   scripts/bench_places.sh [BUILD_DIR]
# Builds a set of 10 places: the redkitchen-dev model (trained on frames
# 0-99,200-299,400-499 of ../shared/data/7scenes-redkitchen-dev) and the 9 rooms of
# `synthesize --rooms 9` (room-8 looks like room-0: the same furniture, placed
# differently), each trained with the default configuration. Without the real
# data, room-9 of a 10-room building stands in for the kitchen. Then:
#  - places_benchmark: resident memory per place, one-thread latency on the
#    first place's test frames with 1, 2 and 10 places (side by side), and every
#    place's test frames against all 10 (wrong-place answers);
#  - the node's peak RSS with the 10 places loaded (`places` parameter), read
#    from /proc once ~list_places lists all of them.
# Synthesized rooms and trained models are kept in BUILD_DIR/bench_places and
# reused (models while newer than the train tool); figures go to
# BUILD_DIR/bench_places/places.json and node.json.
# Environment: PLACES_TRAIN_FRAMES (200), PLACES_TEST_FRAMES (50), BENCH_ROUNDS (2: timed passes),
# PLACES_KITCHEN_MODEL (a kitchen model to use instead of training one: `make bench`
# passes the model it has just trained), PLACES_JSON (where places.json goes),
# PLACES_NODE (1; 0 skips the node's memory check).
. "$(dirname "$0")/bench_setup.sh"
out="$root/$build_dir/bench_places"
mkdir -p "$out"
train_frames=${PLACES_TRAIN_FRAMES:-200}
test_frames=${PLACES_TEST_FRAMES:-50}
data=$kitchen
rooms=9
[ -f "$data/frame-000000.pose.txt" ] || rooms=10

building="$out/building"
if [ ! -f "$building/building.json" ]; then
  echo "bench_places: synthesizing $rooms rooms ($train_frames + $test_frames frames each) into $building"
  "$tools/synthesize" --rooms "$rooms" --seed 11 --train-frames "$train_frames" \
    --test-frames "$test_frames" --no-walk --output "$building" > "$out/synthesize.log"
fi
place_args=() test_args=() yaml="["
add_place() {  # NAME MODEL TEST
  place_args+=(--place "$1=$2")
  test_args+=(--test "$1=$3")
  yaml+="{name: $1, model: $2, map_frame: $1},"
}
train() {  # MODEL ARGS...
  local model=$1
  shift
  model_is_current "$model" && return 0
  echo "bench_places: training $model"
  "$tools/train" "$@" --output "$model" > "$model.log"
}
if [ "$rooms" = 9 ]; then
  kitchen=${PLACES_KITCHEN_MODEL:-$out/kitchen.model}
  train "$kitchen" --dataset "$data" --frames 0-99,200-299,400-499
  add_place kitchen "$kitchen" "$data@100-199,300-399"
else
  echo "bench_places: ../shared/data is absent; room-9 stands in for the kitchen"
  train "$out/room-9.model" --dataset "$building/room-9/train"
  add_place room-9 "$out/room-9.model" "$building/room-9/test"
fi
for i in $(seq 0 8); do
  train "$out/room-$i.model" --dataset "$building/room-$i/train"
  add_place "room-$i" "$out/room-$i.model" "$building/room-$i/test"
done
yaml="${yaml%,}]"

echo "bench_places: places_benchmark (1 thread)"
"$tools/places_benchmark" "${place_args[@]}" "${test_args[@]}" --counts 1,2,10 \
  --repeat "${BENCH_ROUNDS:-2}" --threads 1 --json "${PLACES_JSON:-$out/places.json}" 2>&1 | tee "$out/places.log" |
  grep -v -E '^(places|evaluating) ' || true

[ "${PLACES_NODE:-1}" = 0 ] && exit 0

# --- The node with the 10 places -----------------------------------------------------------
# shellcheck source=scripts/private_master.sh
source "$root/scripts/private_master.sh"
start_private_master "$devel" "$out"
rosparam load "$root/config/default.yaml" /relocalizer
rosparam set /relocalizer/places "$yaml"
"$tools/relocalizer_node" __name:=relocalizer > "$out/node.log" 2>&1 < /dev/null &
node_pid=$!
own_process "$node_pid"
listed=0
for _ in $(seq 600); do
  kill -0 "$node_pid" 2>/dev/null || { echo "bench_places: the node died (see $out/node.log)" >&2; exit 1; }
  listed=$(rosservice call /relocalizer/list_places 2>/dev/null | grep -c 'name:' || true)
  [ "$listed" -ge 10 ] && break
  sleep 0.5
done
hwm_kb=$(awk '/^VmHWM:/ { print $2 }' "/proc/$node_pid/status")
rss_kb=$(awk '/^VmRSS:/ { print $2 }' "/proc/$node_pid/status")
printf '{"places_listed": %d, "peak_rss_bytes": %d, "rss_bytes": %d}\n' "$listed" \
  "$((hwm_kb * 1024))" "$((rss_kb * 1024))" > "$out/node.json"
echo "bench_places: node with $listed places: peak RSS $((hwm_kb / 1024)) MiB, RSS now $((rss_kb / 1024)) MiB"
echo "bench_places: figures in $out/places.json and $out/node.json"
