#!/usr/bin/env bash
# Node latency benchmark, run by `make bench`:
#   scripts/bench_node.sh DEVEL_DIR MODEL DATASET FRAMES OUTPUT_JSON
# Writes DATASET's FRAMES (an id range, "" for all) as a 30 Hz bag, starts a
# private ROS master and relocalizer_node in continuous mode (process_all
# false, max_rate 0: it always takes the newest frame and drops what it cannot
# keep up with, as with a live camera), and has replay_evaluator publish the
# frames on a 30 Hz schedule without waiting for answers. Records the latency
# from publishing a frame to receiving its ~result, the share of frames
# answered, and the node's peak RSS (VmHWM), as JSON in OUTPUT_JSON.
# Environment: BENCH_NODE_RATE (Hz, default 30), BENCH_NODE_THREADS (the node's
# ~threads, default from config/default.yaml).
set -euo pipefail
if [ $# -lt 5 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
  sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'
  [ "${1:-}" = "-h" ] || [ "${1:-}" = "--help" ] && exit 0 || exit 2
fi
export PATH=/usr/bin:/bin:$PATH
here=$(cd "$(dirname "$0")/.." && pwd)
devel=$1
[[ "$devel" = /* ]] || devel="$here/$devel"
model=$(realpath "$2")
dataset=$(realpath "$3")
frames=$4
json_out=$5
rate=${BENCH_NODE_RATE:-30}
tools="$devel/lib/relocalizer"
[ -f "$model" ] || { echo "bench_node: error: $model: no such model file" >&2; exit 2; }
[ -x "$tools/relocalizer_node" ] || { echo "bench_node: error: $tools/relocalizer_node missing; build first" >&2; exit 2; }
work=$(dirname "$(realpath -m "$json_out")")/node_replay
mkdir -p "$work"

frame_args=()
[ -n "$frames" ] && frame_args=(--frames "$frames")
"$tools/make_bag" --dataset "$dataset" "${frame_args[@]}" --rate "$rate" --output "$work/frames.bag" >"$work/make_bag.log"

# shellcheck source=scripts/private_master.sh
source "$here/scripts/private_master.sh"
start_private_master "$devel" "$work"
rosparam load "$here/config/default.yaml" /relocalizer
rosparam set /relocalizer/model "$model"
rosparam set /relocalizer/mode continuous
rosparam set /relocalizer/process_all false
rosparam set /relocalizer/max_rate 0.0
rosparam set /relocalizer/approx_sync false
[ -n "${BENCH_NODE_THREADS:-}" ] && rosparam set /relocalizer/threads "$BENCH_NODE_THREADS"
threads=$(rosparam get /relocalizer/threads)
[ "$threads" = 0 ] && threads=$(nproc)  # 0 means every core

"$tools/relocalizer_node" __name:=relocalizer rgb/image:=/camera/rgb/image_raw depth/image:=/camera/depth/image_raw \
  rgb/camera_info:=/camera/rgb/camera_info >"$work/node.log" 2>&1 </dev/null &
node_pid=$!
own_process "$node_pid"

rosparam set /replay_evaluator/bag "$work/frames.bag"
rosparam set /replay_evaluator/model "$model"
rosparam set /replay_evaluator/output "$work/evaluation"
rosparam set /replay_evaluator/rate "$rate"
"$tools/replay_evaluator" __name:=replay_evaluator result:=/relocalizer/result >"$work/replay.log" 2>&1
hwm_kb=$(awk '/^VmHWM:/ { print $2 }' "/proc/$node_pid/status" 2>/dev/null || echo 0)
kill -0 "$node_pid" 2>/dev/null || { echo "bench_node: error: the node died (see $work/node.log)" >&2; exit 1; }
grep '^paced at' "$work/replay.log" || true

/usr/bin/python3 - "$work/evaluation" "$json_out" "$hwm_kb" "$threads" <<'PY'
import json, sys
evaluation, out, hwm_kb, threads = sys.argv[1:5]
latency = json.load(open(evaluation + "/latency.json"))
summary = json.load(open(evaluation + "/summary.json"))
latency["node_peak_rss_mb"] = int(hwm_kb) / 1024
latency["node_threads"] = int(threads)
latency["within_5cm_5deg"] = summary.get("within_5cm_5deg")
json.dump(latency, open(out, "w"), indent=2)
PY
