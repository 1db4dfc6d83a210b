#!/usr/bin/env bash
# Builds and runs every gtest and rostest of the package, then prints one line,
# `N passed, N failed[, N skipped]`, summed over all result files, and exits
# non-zero on any failure. A test binary that crashes counts as failed: catkin
# writes a failing MISSING-RESULT file for it.
set -uo pipefail
build_dir=${1:-build}
export PATH=/usr/bin:/bin:$PATH
export ROS_LOG_DIR=${ROS_LOG_DIR:-$PWD/$build_dir/ros_log}

results_dir="$build_dir/test_results"
rm -rf "$results_dir"

if ! cmake --build "$build_dir" -j "$(nproc)" --target tests; then
  echo "the tests did not build"
  echo "0 passed, 1 failed"
  exit 1
fi
# run_tests goes on past failing tests (-k); the counts come from the result files.
cmake --build "$build_dir" --target run_tests -- -k
make_status=$?

out=$(/usr/bin/python3 scripts/count_test_results.py "$results_dir")
count_status=$?
echo "$out" | grep -v -E '^[0-9]+ passed' || true
line=$(echo "$out" | grep -E '^[0-9]+ passed' | tail -n 1)
if [ "$make_status" -ne 0 ] && [ "$count_status" -eq 0 ]; then
  # run_tests failed without a failing result file: count that as one failure.
  line=$(echo "$line" | sed -E 's/([0-9]+) failed/1 failed/')
  count_status=1
fi
echo "$line"
exit $count_status
