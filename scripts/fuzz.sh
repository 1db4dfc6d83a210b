#!/usr/bin/env bash
# Builds the libFuzzer targets of test/fuzz/ with clang into build/fuzz/ and runs
# each for FUZZ_SECONDS, then prints one summary line per target (executions,
# coverage, corpus, crashes) and exits non-zero if any target crashed, leaked,
# timed out or did not build. See docs/reliability.md.
#
# Environment:
#   FUZZ_SECONDS   seconds per target, libFuzzer -max_total_time (default 60)
#   FUZZ_PARALLEL  targets run at once (default 1; CI uses 2 on its 2 cores)
#   FUZZ_TARGETS   space-separated subset of targets (default: all)
#   FUZZ_BUILD_DIR build folder (default build/fuzz)
#   JOBS           parallel compile jobs (default: nproc)
#   FUZZ_BUILD_ONLY set: build the targets and stop (CI builds them at low
#                  priority while the new-machine stage runs)
#   CXX_FUZZ       clang++ to use (default: clang++, else clang++-14)
#
# Inputs each target found interesting are kept in build/fuzz/corpus/<target>/
# (so repeated runs on one machine build on each other); the committed seeds
# in test/fuzz/corpus/<target>/ are only read. A crashing input is written to
# build/fuzz/artifacts/<target>/ and the command to replay it is printed.
set -uo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH

seconds=${FUZZ_SECONDS:-60}
parallel=${FUZZ_PARALLEL:-1}
build_dir=${FUZZ_BUILD_DIR:-build/fuzz}
jobs=${JOBS:-$(nproc)}
all_targets=(fuzz_model fuzz_frame_selection fuzz_config fuzz_seven_scenes fuzz_twelve_scenes fuzz_tum fuzz_submap_manifest fuzz_names fuzz_place_requests fuzz_stamps)
read -r -a targets <<< "${FUZZ_TARGETS:-${all_targets[*]}}"

cxx=${CXX_FUZZ:-}
if [ -z "$cxx" ]; then
  if command -v clang++ > /dev/null; then cxx=clang++; else cxx=clang++-14; fi
fi
command -v "$cxx" > /dev/null || { echo "fuzz: $cxx not found (make deps installs clang)"; exit 1; }

start=$(date +%s)
# The stamp, not CMakeCache.txt, says a configure succeeded (as in the Makefile).
if [ ! -f "$build_dir/.relocalizer-configured" ]; then
  mkdir -p "$(dirname "$build_dir")"
  cmake -S test/fuzz -B "$build_dir" -DCMAKE_CXX_COMPILER="$cxx" > "$build_dir.configure.log" 2>&1 ||
    { cat "$build_dir.configure.log"; echo "fuzz: configure failed"; exit 1; }
  rm -f "$build_dir.configure.log"
  touch "$build_dir/.relocalizer-configured"
fi
mkdir -p "$build_dir/logs"
if ! cmake --build "$build_dir" -j "$jobs" --target "${targets[@]}" fuzz_seed_models \
    > "$build_dir/logs/build.log" 2>&1; then
  tail -n 60 "$build_dir/logs/build.log"
  echo "fuzz: the fuzz targets did not build (log: $build_dir/logs/build.log)"
  exit 1
fi
echo "fuzz: built in $(( $(date +%s) - start )) s; running ${#targets[@]} targets for ${seconds} s each, $parallel at a time"
[ -z "${FUZZ_BUILD_ONLY:-}" ] || exit 0

# Longest input per target: a small model is ~2 KB; text files are short.
max_len() {
  case $1 in
    fuzz_model) echo 16384 ;;
    fuzz_frame_selection) echo 256 ;;
    *) echo 2048 ;;
  esac
}

# The dataset targets write their files here on every input: memory if we can.
scratch_base=${TMPDIR:-/tmp}
if [ -z "${TMPDIR:-}" ] && [ -d /dev/shm ] && [ -w /dev/shm ]; then scratch_base=/dev/shm; fi
scratch=$(mktemp -d "$scratch_base/relocalizer-fuzz.XXXXXX")
trap 'rm -rf "$scratch"' EXIT
stamp="$scratch/started"  # artifacts newer than this are this run's
touch "$stamp"

run_target() {
  local name=$1
  local corpus="$build_dir/corpus/$name" artifacts="$build_dir/artifacts/$name/"
  local log="$build_dir/logs/$name.log"
  mkdir -p "$corpus" "$artifacts" "$build_dir/logs" "$scratch/$name"
  local seeds=()
  [ -d "test/fuzz/corpus/$name" ] && seeds+=("test/fuzz/corpus/$name")
  [ -d "$build_dir/seeds/$name" ] && seeds+=("$build_dir/seeds/$name")
  local dict=()
  [ -f "test/fuzz/dict/$name.dict" ] && dict=(-dict="test/fuzz/dict/$name.dict")
  # rss_limit: peak RSS here stays under 600 MB (ASan quarantine included); timeout: no input may take 10 s.
  FUZZ_TMPDIR="$scratch/$name" \
  ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1} \
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1} \
    "$build_dir/$name" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
    -max_len="$(max_len "$name")" -print_final_stats=1 -artifact_prefix="$artifacts" \
    "${dict[@]}" "$corpus" "${seeds[@]}" > "$log" 2>&1
  echo $? > "$scratch/$name.status"
}

running=0
for name in "${targets[@]}"; do
  run_target "$name" &
  running=$((running + 1))
  if [ "$running" -ge "$parallel" ]; then
    wait -n
    running=$((running - 1))
  fi
done
wait

failed=0
for name in "${targets[@]}"; do
  log="$build_dir/logs/$name.log"
  status=$(cat "$scratch/$name.status" 2>/dev/null || echo 1)
  libfuzzer_stat() { grep -m1 "^stat::$1:" "$log" | awk '{print $2}'; }
  execs=$(libfuzzer_stat number_of_executed_units)
  rate=$(libfuzzer_stat average_exec_per_sec)
  new_units=$(libfuzzer_stat new_units_added)
  # The last status line: "#N ... cov: C ft: F corp: U/S ..."
  last=$(grep -E '^#[0-9]+' "$log" | tail -n 1)
  cov=$(echo "$last" | sed -n -E 's/.* cov: ([0-9]+).*/\1/p')
  ft=$(echo "$last" | sed -n -E 's/.* ft: ([0-9]+).*/\1/p')
  corp=$(echo "$last" | sed -n -E 's/.* corp: ([0-9]+)\/.*/\1/p')
  crashes=$(find "$build_dir/artifacts/$name" -type f -newer "$stamp" 2>/dev/null | wc -l)
  verdict=ok
  if [ "$status" -ne 0 ] || [ "$crashes" -gt 0 ]; then
    verdict=FAILED
    failed=$((failed + 1))
    [ "$crashes" -gt 0 ] || crashes=1
  fi
  echo "fuzz: $name: $verdict: ${execs:-0} execs (${rate:-0}/s), cov ${cov:-?} ft ${ft:-?}, corpus ${corp:-?} (${new_units:-0} new), crashes $crashes"
  if [ "$verdict" = FAILED ]; then
    grep -E -m1 -A25 'ERROR: (Address|Leak|UndefinedBehavior|libFuzzer)|runtime error:|==ERROR|deadly signal|timeout after' "$log" | head -n 40
    for artifact in $(find "$build_dir/artifacts/$name" -type f -newer "$stamp" 2>/dev/null); do
      echo "fuzz: replay with: $build_dir/$name $artifact"
    done
    echo "fuzz: full log: $log"
  fi
done
echo "fuzz: ${#targets[@]} targets, $failed failed, $(( $(date +%s) - start )) s in all"
[ "$failed" -eq 0 ]
