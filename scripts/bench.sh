#!/usr/bin/env bash
# make bench: speed and memory of the whole pipeline, printed as one table.
# On ../shared/data/7scenes-redkitchen-dev (redkitchen-dev protocol, default
# parameters) when present, else on a small synthetic room. Set SWEEP=1 for the
# speed-accuracy sweep (adds ~15 minutes on real data).
set -euo pipefail
build_dir=${1:-build}
export PATH=/usr/bin:/bin:$PATH
devel=${RELOCALIZER_DEVEL:-$PWD/devel}
tools="$devel/lib/relocalizer"
out="$PWD/$build_dir/bench"
mkdir -p "$out"
threads=$(nproc)

data="$PWD/../shared/data/7scenes-redkitchen-dev"
if [ -f "$data/frame-000000.pose.txt" ]; then
  echo "bench: real data $data (redkitchen-dev protocol)"
  train_args=(--dataset "$data" --frames 0-99,200-299,400-499)
  test_args=(--dataset "$data" --frames 100-199,300-399)
  bench_frames=(--dataset "$data" --frames 100-199,300-399)
else
  echo "bench: ../shared/data is absent; a synthetic room (seed 1, 300 + 100 frames) stands in"
  "$tools/synthesize" --output "$out/scene" --seed 1 --train-frames 300 --test-frames 100 > /dev/null
  train_args=(--dataset "$out/scene/train")
  test_args=(--dataset "$out/scene/test")
  bench_frames=(--dataset "$out/scene/test")
fi

echo "bench: training (default parameters, $threads threads)"
/usr/bin/time -f "%e %M" -o "$out/train.time" "$tools/train" "${train_args[@]}" --threads "$threads" \
  --output "$out/bench.model" > "$out/train.log"
echo "bench: evaluating"
/usr/bin/time -f "%e %M" -o "$out/evaluate.time" "$tools/evaluate" --model "$out/bench.model" \
  "${test_args[@]}" --threads "$threads" --output "$out/evaluation" > "$out/evaluate.log"
echo "bench: per-stage latency, 1 and $threads threads"
sweep=()
if [ "${SWEEP:-0}" = 1 ]; then sweep=(--sweep "$out/sweep"); fi
"$tools/benchmark" --model "$out/bench.model" "${bench_frames[@]}" --threads "1,$threads" \
  --json "$out/stages.json" "${sweep[@]}" > "$out/benchmark.log"
node_json="$out/node.json"
rm -f "$node_json"
echo "bench: node replay at 30 Hz, continuous mode"
./scripts/bench_node.sh "$devel" "$out/bench.model" "${test_args[1]}" "${test_args[3]:-}" "$node_json" \
  > "$out/node.log" 2>&1 || echo "bench: node replay failed (see $out/node.log)"

/usr/bin/python3 - "$out" "$threads" <<'PY'
import json, os, re, sys
out, threads = sys.argv[1], sys.argv[2]
stages = json.load(open(os.path.join(out, "stages.json")))
train_s, train_kb = open(os.path.join(out, "train.time")).read().split()
eval_s, eval_kb = open(os.path.join(out, "evaluate.time")).read().split()
summary = json.load(open(os.path.join(out, "evaluation", "summary.json")))
log = open(os.path.join(out, "train.log")).read()
per_tree = re.findall(r"^\s+(points|lines)\s.*per tree (.*)$", log, re.M)
size_mb = os.path.getsize(os.path.join(out, "bench.model")) / 1e6
print()
print(f"CPU: {stages['cpu']}; {os.cpu_count()} cores; {stages['frames']} frames")
print(f"{'figure':56s} {'value':>28s}")
names = [("sampling_points", "sampling, random pixels"), ("sampling_lines", "sampling, LSD lines"),
         ("forest_points", "point forest (descriptors + prediction)"),
         ("forest_lines", "line forest (descriptors + prediction)"), ("ransac", "preemptive RANSAC"),
         ("refinement", "Ceres refinement"), ("total", "whole relocalize call")]
for t in sorted(stages["threads"], key=int):
    for key, label in names:
        s = stages["threads"][t][key]
        print(f"{label + ', ' + t + ' thread(s)':56s} {s['median_ms']:10.1f} ms median {s['p95_ms']:7.1f} p95")
print(f"{'training, ' + threads + ' threads, wall':56s} {float(train_s):10.1f} s")
for kind, times in per_tree:
    print(f"{'  per tree, ' + kind:56s} {times:>28s}")
print(f"{'train peak RSS':56s} {int(train_kb) / 1024:10.0f} MiB")
print(f"{'evaluate peak RSS':56s} {int(eval_kb) / 1024:10.0f} MiB")
print(f"{'model file':56s} {size_mb:10.1f} MB")
print(f"{'accuracy, within 5 cm / 5 deg':56s} {100 * summary['within_5cm_5deg']:10.1f} %")
node = os.path.join(out, "node.json")
if os.path.exists(node):
    n = json.load(open(node))
    label = f"node, 30 Hz replay, {n['node_threads']} thread(s)"
    if "latency_ms_median" in n:
        print(f"{label + ', stamp to ~result':56s} {n['latency_ms_median']:10.1f} ms median {n['latency_ms_p95']:7.1f} p95")
    print(f"{label + ', frames answered':56s} {100 * n['answered_share']:10.1f} % of {n['published']}")
    print(f"{'node peak RSS':56s} {n['node_peak_rss_mb']:10.0f} MiB")
else:
    print(f"{'node replay':56s} {'not measured':>28s}")
PY
