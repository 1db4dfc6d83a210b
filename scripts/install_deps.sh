#!/usr/bin/env bash
# Installs the Debian packages that relocalizer builds, tests and runs with, on
# Debian 11 (bullseye), 12 (bookworm) and 13 (trixie): every package named in
# scripts/debian-dependencies.txt, the one table of the package's dependencies
# (a unit test keeps it in step with package.xml and CMakeLists.txt). A package
# written name@suite there is installed on that suite only (a package renamed
# between releases has one such item per suite). Idempotent: asks apt only for
# what dpkg does not already have.
#   scripts/install_deps.sh           install what is missing (apt-get, via sudo when not root)
#   scripts/install_deps.sh --list    print this suite's packages, one per line, and exit
# RELOCALIZER_SUITE overrides the suite read from /etc/os-release.
set -euo pipefail
table="$(cd "$(dirname "$0")" && pwd)/debian-dependencies.txt"
[ -r "$table" ] || { echo "deps: error: $table: cannot read the dependency table" >&2; exit 1; }

suite=${RELOCALIZER_SUITE:-$(. /etc/os-release 2>/dev/null && echo "${VERSION_CODENAME:-}")}
case $suite in
  bullseye|bookworm|trixie) ;;
  *) echo "deps: warning: '${suite:-an unknown release}' is not Debian 11, 12 or 13; installing the" \
          "packages whose names hold on every release (on Ubuntu, use rosdep install instead)" >&2 ;;
esac

# Columns 3 and 4 (build, run) of every row: comma-separated, "-" for none;
# name@suite items only on their suite.
mapfile -t packages < <(awk '!/^[[:space:]]*(#|$)/ { print $3 "," $4 }' "$table" |
  tr ',' '\n' | grep -v -e '^-$' -e '^$' |
  awk -v suite="$suite" -F@ 'NF == 1 || $2 == suite { print $1 }' | sort -u)

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
