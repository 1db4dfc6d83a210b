#!/usr/bin/env bash
# make bench: speed, memory, model size and accuracy of this build beside the
# previous release's, measured in the same run on the same data, as one table
# (previous / now / now:previous). On ../shared/data/7scenes-redkitchen-dev
# (redkitchen-dev protocol, default parameters) when present, else on a small
# synthetic room.
#
# The previous release (BENCH_PREVIOUS, default 0.1.0: commit b4c4cae, the
# first session's last, named by its hash because a clone of main carries no
# tags and the v0.1.0 tag never reached one) is checked out
# in a git worktree under BUILD/bench/.previous and built there with its own
# `make build` (its devel space is BUILD/bench/.previous/build/devel); the first
# run pays for that build, later runs only check it. Both versions train their
# own model on the same frames, and are evaluated and benchmarked on the same
# test frames; the per-stage benchmarks alternate between the two
# (BENCH_ROUNDS rounds, default 3; medians of the rounds), so that drift of a
# shared machine hits both alike. BENCH_PREVIOUS=none skips the previous
# release. SWEEP=1 adds the speed-accuracy sweep of this build.
set -euo pipefail
build_dir=${1:-build}
export PATH=/usr/bin:/bin:$PATH
root=$PWD
devel=${RELOCALIZER_DEVEL:-$root/devel}
out="$root/$build_dir/bench"
mkdir -p "$out"
threads=$(nproc)
rounds=${BENCH_ROUNDS:-3}
previous=${BENCH_PREVIOUS:-b4c4cae}

data="$root/../shared/data/7scenes-redkitchen-dev"
if [ -f "$data/frame-000000.pose.txt" ]; then
  echo "bench: real data $data (redkitchen-dev protocol)"
  train_args=(--dataset "$data" --frames 0-99,200-299,400-499)
  test_args=(--dataset "$data" --frames 100-199,300-399)
else
  echo "bench: ../shared/data is absent; a synthetic room (seed 1, 300 + 100 frames) stands in"
  "$devel/lib/relocalizer/synthesize" --output "$out/scene" --seed 1 --train-frames 300 --test-frames 100 > /dev/null
  train_args=(--dataset "$out/scene/train")
  test_args=(--dataset "$out/scene/test")
fi

# --- The previous release, built in its own worktree --------------------------------------
versions=(now)
declare -A tools_of=([now]="$devel/lib/relocalizer")
# What each version's scripts/bench_node.sh takes: the devel space now, the
# build folder in 0.1.0 (whose devel space was inside it).
declare -A node_arg_of=([now]="$devel")
declare -A tree_of=([now]="$root")
# A hidden folder: roslaunch finds launch files by walking the package folder,
# build/ included, and skips only hidden folders; a second copy of the launch
# files there makes `roslaunch relocalizer X.launch` ambiguous.
worktree="$out/.previous"
if [ "$previous" != none ]; then
  if ! git -C "$root" rev-parse -q --verify "$previous^{commit}" > /dev/null; then
    echo "bench: $previous is not a git revision here; measuring this build only"
  else
    echo "bench: building the previous release $previous in $worktree (log: $out/previous_build.log)"
    # A build folder configured elsewhere (a moved worktree) fails CMake's
    # check of its own path: start that build afresh.
    cache="$worktree/build/CMakeCache.txt"
    if [ -f "$cache" ] && ! grep -qx "CMAKE_CACHEFILE_DIR:INTERNAL=$worktree/build" "$cache"; then
      rm -rf "$worktree/build"
    fi
    if [ ! -e "$worktree/.git" ]; then
      git -C "$root" worktree prune
      git -C "$root" worktree add --detach -f "$worktree" "$previous" > "$out/previous_build.log" 2>&1
    fi
    if git -C "$worktree" checkout -q --detach "$previous" >> "$out/previous_build.log" 2>&1 &&
       make -C "$worktree" build >> "$out/previous_build.log" 2>&1; then
      versions=(previous now)
      tools_of[previous]="$worktree/build/devel/lib/relocalizer"
      node_arg_of[previous]="$worktree/build"
      tree_of[previous]="$worktree"
    else
      echo "bench: the previous release did not build (see $out/previous_build.log); measuring this build only"
    fi
  fi
fi

run_dir() { echo "$out/runs/$1"; }
for v in "${versions[@]}"; do rm -rf "$(run_dir "$v")"; mkdir -p "$(run_dir "$v")"; done

# --- Training and accuracy, one version after the other ------------------------------------
for v in "${versions[@]}"; do
  dir=$(run_dir "$v")
  echo "bench: $v: training (default parameters, $threads threads)"
  /usr/bin/time -f "%e %M" -o "$dir/train.time" "${tools_of[$v]}/train" "${train_args[@]}" \
    --threads "$threads" --output "$dir/bench.model" > "$dir/train.log"
done
for v in "${versions[@]}"; do
  dir=$(run_dir "$v")
  echo "bench: $v: evaluating"
  /usr/bin/time -f "%e %M" -o "$dir/evaluate.time" "${tools_of[$v]}/evaluate" --model "$dir/bench.model" \
    "${test_args[@]}" --threads "$threads" --output "$dir/evaluation" > "$dir/evaluate.log"
done
# The previous release had no surface stage (depth ICP and surface check): the
# same pipeline as theirs, for the accuracy comparison.
echo "bench: now: evaluating without the surface stage (config/surface_off.yaml)"
"${tools_of[now]}/evaluate" --model "$(run_dir now)/bench.model" "${test_args[@]}" --threads "$threads" \
  --config "$root/config/surface_off.yaml" --output "$(run_dir now)/evaluation_surface_off" \
  > "$(run_dir now)/evaluate_surface_off.log"
if [ "${versions[0]}" = previous ]; then
  echo "bench: now: evaluating the previous release's model (format version 1)"
  "${tools_of[now]}/evaluate" --model "$(run_dir previous)/bench.model" "${test_args[@]}" \
    --threads "$threads" --output "$(run_dir now)/previous_model" > "$(run_dir now)/previous_model.log"
fi

# --- Per-stage latency, the versions alternating -------------------------------------------
for round in $(seq "$rounds"); do
  for v in "${versions[@]}"; do
    dir=$(run_dir "$v")
    echo "bench: $v: per-stage latency, 1 and $threads threads (round $round of $rounds)"
    "${tools_of[$v]}/benchmark" --model "$dir/bench.model" "${test_args[@]}" --threads "1,$threads" \
      --json "$dir/stages-$round.json" > "$dir/benchmark-$round.log"
  done
done
# Many places: the same model as the kitchen among 9 synthetic rooms, one thread with
# 1, 2 and 10 places (the rooms' models are trained on the first run and kept in
# BUILD/bench_places). This build only: the previous release had one place.
echo "bench: now: one-thread latency with 1, 2 and 10 places (scripts/bench_places.sh)"
PLACES_KITCHEN_MODEL="$(run_dir now)/bench.model" PLACES_JSON="$(run_dir now)/places.json" \
  PLACES_NODE=0 "$root/scripts/bench_places.sh" "$build_dir" > "$(run_dir now)/places.log" 2>&1 ||
  echo "bench: now: places benchmark failed (see $(run_dir now)/places.log)"
if [ "${SWEEP:-0}" = 1 ]; then
  echo "bench: now: speed-accuracy sweep"
  "${tools_of[now]}/benchmark" --model "$(run_dir now)/bench.model" "${test_args[@]}" --threads 1 \
    --sweep "$out/sweep" > "$out/sweep.log"
fi

# --- The node at 30 Hz -----------------------------------------------------------------------
for v in "${versions[@]}"; do
  dir=$(run_dir "$v")
  echo "bench: $v: node replay at 30 Hz, continuous mode"
  "${tree_of[$v]}/scripts/bench_node.sh" "${node_arg_of[$v]}" "$dir/bench.model" "${test_args[1]}" \
    "${test_args[3]:-}" "$dir/node.json" > "$dir/node.log" 2>&1 ||
    echo "bench: $v: node replay failed (see $dir/node.log)"
done

/usr/bin/python3 "$root/scripts/bench_table.py" "$out/runs" "$threads" "${versions[@]}" | tee "$out/table.txt"
