# Sourced by scripts/bench_places.sh and scripts/bench_changes.sh with their
# arguments: the script's header comment as --help, and what they find the same
# way: build_dir (the first argument, default build), root (the checkout),
# devel, tools, kitchen (the redkitchen-dev folder, which may be absent) and
# PATH with /usr/bin first (catkin's Python, not a pyenv one); and
# model_is_current, the rule for reusing a kept model.
set -euo pipefail
if [ "${1:-}" = "-h" ] || [ "${1:-}" = "--help" ]; then
  sed -n '2,/^[^#]/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'
  exit 0
fi
build_dir=${1:-build}
export PATH=/usr/bin:/bin:$PATH
root=$PWD
devel=${RELOCALIZER_DEVEL:-$root/devel}
tools="$devel/lib/relocalizer"
kitchen="$root/../shared/data/7scenes-redkitchen-dev"

# Whether a model kept from an earlier run can be used again: only when it is
# newer than the train tool, since a rebuilt train may train otherwise (a kept
# model once gave a whole table of another configuration's figures).
model_is_current() {
  [ "$1" -nt "$tools/train" ]
}
