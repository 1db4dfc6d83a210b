#!/usr/bin/env bash
# make test-workspaces: the README's "In a catkin workspace" commands in a new
# workspace beside a second package (test/packaging/test_catkin_workspace.py):
# catkin_make, catkin_make install, catkin build (Debian 12 and 13), and a tool,
# the node, a launch file and the nodelet from the install space. Prints each
# step's wall time and ccache's hit rate, then one line, `N passed, N failed[, N
# skipped]`, and exits non-zero on any failure. Not part of `make test`: it builds
# the package twice more.
set -uo pipefail
export PATH=/usr/bin:/bin:$PATH
results=${1:-build/test_results_workspaces}
rm -rf "$results"
mkdir -p "$results"
start=$(date +%s)
/usr/bin/python3 -m pytest -q -s -p no:cacheprovider test/packaging/test_catkin_workspace.py \
  -o junit_family=xunit1 --junit-xml="$results/pytests-test_catkin_workspace.xml"
pytest_status=$?
echo "make test-workspaces: $(( $(date +%s) - start )) s"
out=$(/usr/bin/python3 scripts/count_test_results.py "$results")
count_status=$?
echo "$out"
if [ "$pytest_status" -ne 0 ] && [ "$count_status" -eq 0 ]; then
  # pytest failed without a failing result (e.g. it could not collect): one failure.
  echo "FAILED: pytest exited $pytest_status"
  exit 1
fi
exit $count_status
