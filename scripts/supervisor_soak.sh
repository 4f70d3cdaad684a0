#!/usr/bin/env bash
# The supervisor's soak benchmark: `alc supervise` on a real mosquitto with the twin gateway playing
# load case A for DAYS days of machine time (default 30) as fast as the supervisor takes it, answering
# probe requests in closed loop. Prints the supervisor's RSS, samples/s and the history's and inbox's
# sizes at day 1, 10 and 30, and checks that every sample is stored once (tests/supervisor/soak_test.cpp).
# Usage: scripts/supervisor_soak.sh [DAYS] [BUILD_DIR]
#   BUILD_DIR default build/test-release, the release build of scripts/test.sh (the soak is a test, so
#   not main.sh's build/release, which has no tests); installs what is missing (the build's packages
#   and mosquitto), then builds alc and test_supervisor there (configured as Release if new; an existing
#   BUILD_DIR keeps its configuration). The build's output is shown only if it fails.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
DAYS="${1:-30}"
BUILD="$(realpath -m "${2:-$ALC_ROOT/build/test-release}")"
ensure_packages "${ALC_PACKAGES[@]}" mosquitto
config=()
[ -f "$BUILD/CMakeCache.txt" ] || config=(-DCMAKE_BUILD_TYPE=Release)
build "$BUILD" "${config[@]}" -- alc test_supervisor
ALC_SOAK_DAYS="$DAYS" "$BUILD/tests/test_supervisor" "[soak]"
