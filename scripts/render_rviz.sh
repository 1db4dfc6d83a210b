#!/usr/bin/env bash
# Usage: rosrun relocalizer render_rviz.sh --model MODEL --bag BAG --output PNG [--timeout SECONDS]
# Renders RViz with rviz/relocalizer.rviz to a PNG, headless. Starts a private
# ROS master, an X server of its own (Xvfb) and
# `roslaunch relocalizer view.launch model:=MODEL mode:=continuous` on it, plays
# BAG (camera/rgb/image_raw, camera/depth/image_raw, camera/rgb/camera_info, as
# `rosrun relocalizer make_bag` writes) until an answer's inliers are on
# ~inliers, then saves the screen (xwd) as PNG once RViz draws the surface and
# the inliers (up to --timeout seconds, default 240, for each step). Prints the
# picture's colour shares; exits non-zero when RViz drew no surface or no
# inliers. Stops everything it started. Needs a sourced devel space.
set -euo pipefail
usage() { sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; }
# RViz starts with software OpenGL in Xvfb: on a loaded 2-core machine its first
# frame has taken more than 120 s.
model="" bag="" output="" timeout=240
while [ $# -gt 0 ]; do
  case $1 in
    -h | --help) usage; exit 0 ;;
    --model) model=$(realpath "$2"); shift 2 ;;
    --bag) bag=$(realpath "$2"); shift 2 ;;
    --output) output=$(realpath -m "$2"); shift 2 ;;
    --timeout) timeout=$2; shift 2 ;;
    *) echo "render_rviz: error: unknown argument $1" >&2; usage >&2; exit 2 ;;
  esac
done
[ -n "$model" ] && [ -n "$bag" ] && [ -n "$output" ] || { usage >&2; exit 2; }
[ -f "$model" ] || { echo "render_rviz: error: --model $model: no such file" >&2; exit 2; }
[ -f "$bag" ] || { echo "render_rviz: error: --bag $bag: no such file" >&2; exit 2; }
here=$(cd "$(dirname "$(realpath "$0")")" && pwd)
devel=${CMAKE_PREFIX_PATH%%:*}
[ -f "$devel/setup.bash" ] || { echo "render_rviz: error: source a devel space first (devel/setup.bash)" >&2; exit 2; }
log_dir=$(mktemp -d /tmp/render_rviz.XXXXXX)
# shellcheck source=private_master.sh
source "$here/private_master.sh"
start_private_master "$devel" "$log_dir"
keep_logs=1  # until the picture is saved: the logs say what went wrong
trap 'stop_owned_processes; [ "$keep_logs" = 1 ] || rm -rf "$log_dir"' EXIT

# An X server of our own: the first free display number, told through a pipe.
# `exec`: $! is then Xvfb itself whatever the bash; else it can be the
# substitution's subshell, whose stop leaves Xvfb running (an Xvfb outlived a
# bullseye root's README test).
exec 3< <(exec Xvfb -displayfd 1 -screen 0 1000x640x24 -nolisten tcp 2> "$log_dir/xvfb.log")
own_process $!
read -r -t 30 display <&3 || { echo "render_rviz: error: Xvfb did not start (see $log_dir/xvfb.log)" >&2; exit 1; }
export DISPLAY=:$display

# Until a command succeeds, at most $timeout seconds.
wait_for() {
  local what=$1; shift
  local end=$((SECONDS + timeout))
  until "$@" > /dev/null 2>&1; do
    [ $SECONDS -lt $end ] || { echo "render_rviz: error: no $what within ${timeout} s (logs in $log_dir)" >&2; return 1; }
    sleep 0.5
  done
}
started=$SECONDS
roslaunch relocalizer view.launch model:="$model" mode:=continuous > "$log_dir/view.log" 2>&1 &
own_process $!
wait_for "~surface" timeout 10 rostopic echo -n 1 /relocalizer/surface/width
rosbag play -q "$bag" > "$log_dir/play.log" 2>&1 &
own_process $!
wait_for "answer on ~inliers" timeout 10 rostopic echo -n 1 /relocalizer/inliers/width
# RViz draws at its own pace: take pictures until the surface and the inliers show.
drawn() {
  xwd -root -silent > "$log_dir/screen.xwd" &&
    /usr/bin/python3 "$here/xwd_to_png.py" "$log_dir/screen.xwd" "$output" > "$log_dir/stats.json" &&
    /usr/bin/python3 -c 'import json, sys; s = json.load(open(sys.argv[1]))["share"]
sys.exit(0 if s["surface"] > 0.05 and s["points"] + s["lines"] > 0.001 else 1)' "$log_dir/stats.json"
}
if ! wait_for "surface and inliers on the screen" drawn; then
  cat "$log_dir/stats.json" >&2 || true
  echo "render_rviz: the last lines of roslaunch view.launch (RViz among them):" >&2
  tail -n 20 "$log_dir/view.log" >&2 || true
  exit 1
fi
echo "render_rviz: $output in $((SECONDS - started)) s: $(cat "$log_dir/stats.json")"
keep_logs=0
