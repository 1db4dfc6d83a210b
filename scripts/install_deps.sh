#!/usr/bin/env bash
# Installs the Debian bookworm packages that relocalizer builds, tests and runs
# with: every package named in scripts/debian-dependencies.txt, the one table of
# the package's dependencies (a unit test keeps it in step with package.xml and
# CMakeLists.txt). Idempotent: asks apt only for what dpkg does not already have.
#   scripts/install_deps.sh           install what is missing (apt-get, via sudo when not root)
#   scripts/install_deps.sh --list    print the packages, one per line, and exit
set -euo pipefail
table="$(cd "$(dirname "$0")" && pwd)/debian-dependencies.txt"
[ -r "$table" ] || { echo "deps: error: $table: cannot read the dependency table" >&2; exit 1; }

# Columns 3 and 4 (build, run) of every row: comma-separated, "-" for none.
mapfile -t packages < <(awk '!/^[[:space:]]*(#|$)/ { print $3 "," $4 }' "$table" |
  tr ',' '\n' | grep -v -e '^-$' -e '^$' | sort -u)

if [ "${1:-}" = "--list" ]; then
  printf '%s\n' "${packages[@]}"
  exit 0
fi

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "deps: all ${#packages[@]} Debian packages present"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi
echo "deps: installing ${#missing[@]} missing Debian packages: ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
start=$(date +%s)
"${sudo_cmd[@]}" apt-get update -qq
# Without recommends: the table names everything needed, so what it forgets
# fails here and in the fresh-machine check instead of hiding behind a recommend.
"${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "deps: installed ${#missing[@]} packages in $(( $(date +%s) - start )) s"
