# shellcheck shell=bash
# Shared by the scripts of scripts/ (main.sh, test.sh, fuzz.sh, ...): install Debian packages if missing,
# configure, build. Idempotent and quiet: a second run installs nothing and rebuilds only what changed.
set -euo pipefail

ALC_ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
ALC_JOBS="${ALC_JOBS:-$(nproc)}"

# Build dependencies, all from Debian 12 (the arrays are used by the scripts that source this file).
# shellcheck disable=SC2034
ALC_PACKAGES=(g++ cmake ninja-build pkg-config libeigen3-dev libceres-dev libsqlite3-dev sqlite3 libspdlog-dev
              catch2 libcli11-dev libtomlplusplus-dev nlohmann-json3-dev libmosquitto-dev libsvm-dev
              libcpp-httplib-dev)

# The fuzz build (fuzz/, README "Fuzzing"): clang with libFuzzer and its sanitizer runtimes.
# shellcheck disable=SC2034
ALC_FUZZ_PACKAGES=(clang libclang-rt-14-dev)

# Whether this script process has run `apt-get update` already: once is enough for all the
# ensure_packages calls of a script (test.sh makes eight).
ALC_APT_UPDATED=0

# ensure_packages PKG...: apt-get install the ones that are not installed yet.
ensure_packages() {
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  local sudo=""
  if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
    sudo="sudo"
  fi
  echo "installing: ${missing[*]}"
  # apt's chatter goes to a log that is shown only when the install fails.
  local log
  log="$(mktemp)"
  if ! { { [ "$ALC_APT_UPDATED" = 1 ] || $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq; } &&
         $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"; } \
       >"$log" 2>&1; then
    cat "$log" >&2
    rm -f "$log"
    echo "apt-get install failed: ${missing[*]}" >&2
    exit 1
  fi
  ALC_APT_UPDATED=1
  rm -f "$log"
}

# build DIR [CMAKE_ARGS...] [-- TARGET...]: configure, then build everything in DIR (or only the
# TARGETs). The configure step runs every time (quick when nothing changed), so CMAKE_ARGS that
# differ from the cache of an earlier run take effect instead of being ignored.
build() {
  local dir="$1"; shift
  local args=() targets=()
  while [ $# -gt 0 ]; do
    if [ "$1" = -- ]; then shift; targets=(--target "$@"); break; fi
    args+=("$1"); shift
  done
  cmake -S "$ALC_ROOT" -B "$dir" -G Ninja "${args[@]}" >/dev/null
  if ! cmake --build "$dir" -j "$ALC_JOBS" "${targets[@]}" >"$dir/build.log" 2>&1; then
    cat "$dir/build.log" >&2
    echo "build failed in $dir" >&2
    return 1
  fi
  grep -A3 "warning:" "$dir/build.log" >&2 || true  # warnings stay visible
}

# build_fuzz DIR LEVEL: the fuzz configuration (its own CMake configuration: clang, -DALC_FUZZ=ON; only
# the libraries and the fuzz targets) in DIR at optimisation LEVEL. The short run of the test suite uses
# build/fuzz at -O0: its 20,000 executions per target take 45 s there against 13 s at -O1, but the build
# takes 5.8 min against 9.2 (2 cores). The long run (scripts/fuzz.sh --long) uses build/fuzz-long at -O1.
build_fuzz() {
  CC=clang CXX=clang++ build "$1" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=$2 -g1 -DNDEBUG" -DALC_FUZZ=ON
}
