#!/usr/bin/env bash
# Soak test: the node in continuous mode on a looping bag, watched for leaks.
#   scripts/soak.sh MODEL BAG [MINUTES=10]
# Starts a private ROS master, relocalizer_node (continuous, max_rate 30, not
# process_all, so it is always busy and drops what it cannot take) and
# `rosbag play -l` on BAG (make_bag writes 30 Hz; every loop is a jump back in
# time). Every 10 s it records the node's RSS (/proc/PID/status) and the
# ~result counters (received, processed, dropped, failed, time jumps) in a CSV.
# Passes (exit 0) only if the node is alive and still relocalizing at the end
# and its RSS grew less than 5 % from the 1-minute sample to the last one.
# Not part of CI (`make test`).
#
# Environment: SOAK_DEVEL_DIR (catkin devel space, default devel),
# SOAK_OUTPUT (folder for soak.csv, summary.txt, node.log; default
# ./soak_output), SOAK_RATE (max_rate, default 30), SOAK_THREADS (node
# threads, default from config/default.yaml), SOAK_INTERVAL (s, default 10),
# SOAK_MAX_GROWTH (%, default 5).
set -euo pipefail
if [ $# -lt 2 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
  sed -n '2,19p' "$0" | sed 's/^# \{0,1\}//'
  [ $# -ge 2 ] && exit 0 || exit 2
fi
export PATH=/usr/bin:/bin:$PATH
here=$(cd "$(dirname "$0")/.." && pwd)
devel=${SOAK_DEVEL_DIR:-devel}
[[ "$devel" = /* ]] || devel="$here/$devel"
model=$(realpath "$1")
bag=$(realpath "$2")
minutes=${3:-10}
rate=${SOAK_RATE:-30}
interval=${SOAK_INTERVAL:-10}
max_growth=${SOAK_MAX_GROWTH:-5}
out=${SOAK_OUTPUT:-$PWD/soak_output}
node_bin="$devel/lib/relocalizer/relocalizer_node"
[ -f "$model" ] || { echo "soak: error: $model: no such model file" >&2; exit 2; }
[ -f "$bag" ] || { echo "soak: error: $bag: no such bag" >&2; exit 2; }
[ -x "$node_bin" ] || { echo "soak: error: $node_bin missing; build first (SOAK_DEVEL_DIR=$devel)" >&2; exit 2; }
[[ "$minutes" =~ ^[0-9]+([.][0-9]+)?$ ]] || { echo "soak: error: MINUTES must be a number, got '$minutes'" >&2; exit 2; }
mkdir -p "$out"
out=$(realpath "$out")
csv=$out/soak.csv
summary=$out/summary.txt
# shellcheck source=scripts/private_master.sh
source "$here/scripts/private_master.sh"
start_private_master "$devel" "$out" || exit 1
echo "soak: private master at $ROS_MASTER_URI; output in $out"

rosparam load "$here/config/default.yaml" /relocalizer
rosparam set /relocalizer/model "$model"
rosparam set /relocalizer/mode continuous
rosparam set /relocalizer/max_rate "$rate"
rosparam set /relocalizer/process_all false
[ -n "${SOAK_THREADS:-}" ] && rosparam set /relocalizer/threads "$SOAK_THREADS"

"$node_bin" __name:=relocalizer rgb/image:=/camera/rgb/image_raw depth/image:=/camera/depth/image_raw \
  rgb/camera_info:=/camera/rgb/camera_info >"$out/node.log" 2>&1 </dev/null &
node_pid=$!
own_process "$node_pid"
for _ in $(seq 300); do
  rosservice list 2>/dev/null | grep -q '^/relocalizer/relocalize$' && break
  kill -0 "$node_pid" 2>/dev/null || { echo "soak: error: the node exited at start:" >&2; cat "$out/node.log" >&2; exit 1; }
  sleep 0.2
done

rosbag play -l -q "$bag" >"$out/play.log" 2>&1 </dev/null &
play_pid=$!
own_process "$play_pid"

rss_kb() { awk '/^VmRSS:/ { print $2 }' "/proc/$node_pid/status" 2>/dev/null || true; }
# The counters of the next ~result, as "received,processed,dropped,failed,jumps",
# or ",,,," when none comes within 5 s.
counters() {
  timeout 8 rostopic echo -n 1 -p --nostr --noarr /relocalizer/result 2>/dev/null | awk -F, '
    NR == 1 { for (i = 1; i <= NF; i++) col[$i] = i; next }
    NR == 2 { printf "%s,%s,%s,%s,%s\n", $col["field.frames_received"], $col["field.frames_processed"],
              $col["field.frames_dropped"], $col["field.frames_failed"], $col["field.time_jumps"]; found = 1 }
    END { if (!found) print ",,,," }'
}

echo "elapsed_s,rss_kb,frames_received,frames_processed,frames_dropped,frames_failed,time_jumps" >"$csv"
total=$(awk -v m="$minutes" 'BEGIN { printf "%d", m * 60 }')
start=$(date +%s.%N)
alive=1
next=0
while :; do
  now=$(date +%s.%N)
  elapsed=$(awk -v a="$now" -v b="$start" 'BEGIN { printf "%d", a - b + 0.5 }')
  if ! kill -0 "$node_pid" 2>/dev/null; then alive=0; echo "soak: the node died at ${elapsed} s"; break; fi
  line="$elapsed,$(rss_kb),$(counters)"
  echo "$line" >>"$csv"
  echo "soak: $line"
  [ "$next" -ge "$total" ] && break
  next=$((next + interval))
  # Sleep to the next multiple of the interval from the start.
  wait_s=$(awk -v s="$start" -v n="$next" -v t="$(date +%s.%N)" 'BEGIN { d = s + n - t; printf "%.2f", (d > 0 ? d : 0) }')
  sleep "$wait_s"
done
kill -0 "$play_pid" 2>/dev/null || echo "soak: warning: rosbag play is no longer running (see $out/play.log)"

# Summary from the CSV.
awk -F, -v alive="$alive" -v max_growth="$max_growth" -v minutes="$minutes" '
  NR == 1 { next }
  { t[++n] = $1; rss[n] = $2; rec[n] = $3; proc[n] = $4; drop[n] = $5; fail[n] = $6; jumps[n] = $7 }
  END {
    if (n < 2) { print "soak: FAIL: fewer than two samples"; exit 1 }
    first_minute = 0
    for (i = 1; i <= n; i++) if (t[i] >= 60) { first_minute = i; break }
    peak = 0
    for (i = first_minute; i <= n && first_minute; i++) if (rss[i] + 0 > peak) peak = rss[i] + 0
    growth = first_minute ? 100.0 * (rss[n] - rss[first_minute]) / rss[first_minute] : 0
    peak_growth = first_minute ? 100.0 * (peak - rss[first_minute]) / rss[first_minute] : 0
    # Still relocalizing: the processed count rose over the last interval.
    progressing = (proc[n] != "" && proc[n - 1] != "" && proc[n] + 0 > proc[n - 1] + 0)
    span = t[n] - t[1]
    printf "soak: %.1f min, %d samples\n", span / 60, n
    printf "soak: RSS start %.1f MB, after 1 min %.1f MB, end %.1f MB, peak after 1 min %.1f MB\n",
           rss[1] / 1024, first_minute ? rss[first_minute] / 1024 : 0, rss[n] / 1024, peak / 1024
    printf "soak: RSS growth after the first minute %+.2f %% (peak %+.2f %%; limit %s %%)\n",
           growth, peak_growth, max_growth
    printf "soak: frames received %s, processed %s, dropped %s, failed %s; %s time jumps (bag loops)\n",
           rec[n], proc[n], drop[n], fail[n], jumps[n]
    if (span > 0 && proc[n] != "")
      printf "soak: %.2f relocalizations/s, %.1f frames/s received\n",
             (proc[n] - proc[1]) / span, (rec[n] - rec[1]) / span
    ok = 1
    if (!alive) { print "soak: FAIL: the node died"; ok = 0 }
    else if (!progressing) { print "soak: FAIL: the node stopped relocalizing (no new ~result counts)"; ok = 0 }
    if (!first_minute) { print "soak: FAIL: the run was shorter than a minute"; ok = 0 }
    else if (growth >= max_growth) { printf "soak: FAIL: RSS grew %.2f %% after the first minute\n", growth; ok = 0 }
    print ok ? "soak: PASS" : "soak: FAIL"
    exit ok ? 0 : 1
  }' "$csv" | tee "$summary"
status=${PIPESTATUS[0]}
echo "soak: samples in $csv, node log in $out/node.log"
exit "$status"
