#!/usr/bin/env bash
# The supervisor's soak benchmark: `alc supervise` on a real mosquitto with the twin gateway playing
# load case A for DAYS days of machine time (default 30) as fast as the supervisor takes it, answering
# probe requests in closed loop. Prints the supervisor's RSS, samples/s and the history's and inbox's
# sizes at day 1, 10 and 30, and checks that every sample is stored once (tests/supervisor/soak_test.cpp).
# Usage: scripts/supervisor_soak.sh [DAYS] [BUILD_DIR]   (BUILD_DIR default build/rel, built if needed)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
DAYS="${1:-30}"
BUILD="${2:-$ROOT/build/rel}"
if [[ ! -d "$BUILD" ]]; then
  cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release >/dev/null
fi
cmake --build "$BUILD" --target alc test_supervisor >/dev/null
ALC_SOAK_DAYS="$DAYS" "$BUILD/tests/test_supervisor" "[soak]"
