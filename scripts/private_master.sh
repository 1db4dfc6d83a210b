# Sourced by the scripts that run the node beside a private ROS master
# (bench_node.sh, bench_places.sh, soak.sh), so that they never touch a master
# that runs on this machine and always stop what they started:
#   start_private_master DEVEL_DIR LOG_DIR  sources the devel space, starts roscore on a
#       free port (ROS_MASTER_URI; logs in LOG_DIR/master.log and LOG_DIR/ros_log) and
#       waits until it answers
#   own_process PID  stops PID at exit; the last owned stops first (the node before the
#       master), gently: SIGINT, then SIGKILL after 5 s
#   private_port  prints a port no one listens on, drawn at random below the kernel's
#       ephemeral range (32768-60999): a port the kernel hands out (bind to 0, an outgoing
#       connection) can be taken by another process before roscore binds it, as happened
#       in CI with three new roots sharing one network
owned_pids=()
own_process() { owned_pids=("$1" "${owned_pids[@]}"); }
stop_owned_processes() {
  local pid
  for pid in "${owned_pids[@]}"; do kill -INT "$pid" 2>/dev/null || true; done
  for pid in "${owned_pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -KILL "$pid" 2>/dev/null || true
  done
}
private_port() {
  /usr/bin/python3 -c '
import random, socket
for port in random.sample(range(20000, 32768), 50):
    with socket.socket() as s:
        try:
            s.bind(("", port))
        except OSError:
            continue
        print(port)
        break
else:
    raise SystemExit("private_port: no free port among 50 drawn from 20000-32767")'
}
start_private_master() {
  local devel=$1 log_dir=$2 port
  set +u
  # shellcheck disable=SC1091
  source "$devel/setup.bash"
  set -u
  port=$(private_port)
  export ROS_MASTER_URI=http://localhost:$port
  export ROS_LOG_DIR=$log_dir/ros_log
  trap stop_owned_processes EXIT
  roscore -p "$port" > "$log_dir/master.log" 2>&1 &
  own_process $!
  for _ in $(seq 100); do rosparam list > /dev/null 2>&1 && return 0; sleep 0.2; done
  echo "error: the ROS master did not start (see $log_dir/master.log)" >&2
  return 1
}
