#!/usr/bin/env bash
# Builds the unit-test binaries (test/unit/test_*.cpp) with AddressSanitizer and
# UndefinedBehaviorSanitizer (RELOCALIZER_SANITIZE=ON, configured by
# `make test-asan` into build/asan/) and runs each one under them with leak
# detection, then prints one line, `N passed, N failed[, N skipped]`, counted
# from the gtest XML files, and exits non-zero on any failure.
#
# A sanitizer report aborts the binary (halt_on_error, -fno-sanitize-recover),
# so gtest writes no XML for it; a leak report comes after gtest wrote a clean
# XML. Either way the binary's exit status is non-zero, and a failing
# `<binary>.Sanitizer` case is recorded so the count shows it.
#
# Environment:
#   JOBS               parallel compile jobs (default: nproc)
#   ASAN_GTEST_FILTER  gtest filter for every binary (default: all tests), e.g.
#                      '-RealData.*' to leave out slow suites
#   ASAN_TEST_TIMEOUT  seconds per binary before it counts as failed (default 1200)
#   ASAN_BUILD_ONLY    set: build the binaries and stop (CI builds them at low
#                      priority while the new-machine stage runs)
set -uo pipefail
cd "$(dirname "$0")/.."
export PATH=/usr/bin:/bin:$PATH
build_dir=${1:-build/asan}
jobs=${JOBS:-$(nproc)}
timeout_s=${ASAN_TEST_TIMEOUT:-1200}
export ROS_LOG_DIR=${ROS_LOG_DIR:-$PWD/$build_dir/ros_log}

fail() {
  echo "test-asan: $1"
  echo "0 passed, 1 failed"
  exit 1
}

[ -f "$build_dir/CMakeCache.txt" ] || fail "$build_dir is not configured (run \`make test-asan\`)"
grep -q '^RELOCALIZER_SANITIZE:BOOL=ON' "$build_dir/CMakeCache.txt" ||
  fail "$build_dir is not configured with -DRELOCALIZER_SANITIZE=ON"

tests=()
for source in test/unit/test_*.cpp; do
  tests+=("$(basename "$source" .cpp)")
done
[ ${#tests[@]} -gt 0 ] || fail "no unit tests found in test/unit/"

start=$(date +%s)
if ! cmake --build "$build_dir" -j "$jobs" --target "${tests[@]}"; then
  fail "the unit tests did not build with sanitizers"
fi
echo "test-asan: built ${#tests[@]} unit-test binaries in $(( $(date +%s) - start )) s"
[ -z "${ASAN_BUILD_ONLY:-}" ] || exit 0

results_dir="$build_dir/test_results_asan"
rm -rf "$results_dir"
mkdir -p "$results_dir"
bin_dir="$build_dir/devel/lib/relocalizer"

# A JUnit file holding one failing case, for a binary that died or reported
# after its tests.
failure_xml() {
  local name=$1 message=$2
  message=$(printf '%s' "$message" | sed -e 's/&/\&amp;/g' -e 's/</\&lt;/g' -e 's/>/\&gt;/g' -e 's/"/\&quot;/g')
  cat > "$results_dir/$name.sanitizer.xml" <<EOF
<?xml version="1.0" encoding="UTF-8"?>
<testsuites><testsuite name="$name" tests="1" failures="1">
<testcase classname="$name" name="Sanitizer"><failure message="$message"/></testcase>
</testsuite></testsuites>
EOF
}

# Halt on the first report, with full stacks; leaks are checked at exit.
# Uninstrumented libraries (OpenCV, TBB, Ceres) are not checked, only their use.
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:halt_on_error=1:check_initialization_order=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}
# LeakSanitizer cannot run under ptrace (e.g. some container sandboxes); then
# the run goes on without leak checks and says so.
if ! ASAN_OPTIONS=detect_leaks=1 "$bin_dir/${tests[0]}" --gtest_list_tests > /dev/null 2>&1; then
  echo "test-asan: LeakSanitizer does not work here; running without leak detection"
  export ASAN_OPTIONS=${ASAN_OPTIONS//detect_leaks=1/detect_leaks=0}
fi
filter=${ASAN_GTEST_FILTER:-*}
[ "$filter" = "*" ] || echo "test-asan: gtest filter '$filter'"

run_start=$(date +%s)
for name in "${tests[@]}"; do
  binary="$bin_dir/$name"
  log="$results_dir/$name.log"
  xml="$results_dir/$name.xml"
  if [ ! -x "$binary" ]; then
    failure_xml "$name" "$binary was not built"
    echo "test-asan: $name: FAILED (not built)"
    continue
  fi
  t0=$(date +%s)
  # The tests expect the package root as working directory, as catkin runs them.
  timeout --kill-after=10 "$timeout_s" "$binary" --gtest_output="xml:$xml" \
    --gtest_filter="$filter" > "$log" 2>&1
  status=$?
  seconds=$(( $(date +%s) - t0 ))
  if [ "$status" -eq 0 ]; then
    echo "test-asan: $name: ok (${seconds} s)"
    continue
  fi
  report=$(grep -m1 -E 'ERROR: (Address|Leak|UndefinedBehavior)Sanitizer|runtime error:' "$log")
  if [ "$status" -eq 124 ] || [ "$status" -eq 137 ]; then
    failure_xml "$name" "timed out after ${timeout_s} s"
    echo "test-asan: $name: FAILED: timed out after ${timeout_s} s"
  elif [ -n "$report" ]; then
    failure_xml "$name" "$report"
    echo "test-asan: $name: FAILED (${seconds} s): $report"
  elif [ -f "$xml" ]; then
    echo "test-asan: $name: FAILED (${seconds} s): failing tests, see $log"
  else
    failure_xml "$name" "exited with status $status before writing results"
    echo "test-asan: $name: FAILED (${seconds} s): exit status $status, no results"
  fi
  # The report itself, so CI logs show it without the log file.
  grep -E -A30 'ERROR: (Address|Leak|UndefinedBehavior)Sanitizer|runtime error:|\[  FAILED  \]' \
    "$log" | head -n 80
done
echo "test-asan: ran ${#tests[@]} binaries in $(( $(date +%s) - run_start )) s"

out=$(/usr/bin/python3 scripts/count_test_results.py "$results_dir")
count_status=$?
echo "$out" | grep -v -E '^[0-9]+ passed' || true
echo "$out" | grep -E '^[0-9]+ passed' | tail -n 1
exit $count_status
