#!/usr/bin/env bash
# The whole test suite: a release build and an ASan+UBSan build, each run through CTest, then the
# libFuzzer targets for a short run each (their own clang build, build/fuzz).
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
ensure_packages "${ALC_PACKAGES[@]}"
# LinuxCNC (rs274 and the headless simulator) for the nc_interface tests; large, so only here.
ensure_packages linuxcnc-uspace
# The MQTT broker for the supervisor's tests (tests/supervisor/ starts its own on a free port); openssl makes
# the certificates of its TLS test.
ensure_packages mosquitto openssl
# strace kills a supervisor child at a chosen system call (tests/supervisor/nc_loop_test.cpp: a kill
# while a program is handed to the spool).
ensure_packages strace
# SLURM and munge for the study's cluster test (tests/study/slurm_study_test.sh starts its own
# daemons; the packages' services are not used).
ensure_packages slurmctld slurmd slurm-client munge
# Chromium for the report's browser tests (tests/report/browser_test.cpp: headless, on a local file).
ensure_packages chromium
# Python 3 for the test of scripts/compare_fronts.py (tests/scripts/compare_fronts_test.py, standard library only).
ensure_packages python3
ensure_packages "${ALC_FUZZ_PACKAGES[@]}"
status=0
build "$ALC_ROOT/build/test-release" -DCMAKE_BUILD_TYPE=Release
ctest --no-tests=error --test-dir "$ALC_ROOT/build/test-release" -j "$ALC_JOBS" --output-on-failure || status=1
# -O1 -g1: line tables are all the sanitizers' reports need; -O2 -g made this the longest step of CI.
build "$ALC_ROOT/build/test-asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1 -DNDEBUG" \
  -DALC_SANITIZE=ON
# Every test but the label sweep (accuracy figures over many seeds, checked in the release run above;
# 40x slower under the sanitizers, with no code path the other replays do not run: tests/CMakeLists.txt).
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --no-tests=error --test-dir "$ALC_ROOT/build/test-asan" -LE sweep -j "$ALC_JOBS" --output-on-failure || status=1
# The fuzzers: a short fixed number of executions per target (label fuzz); scripts/fuzz.sh --long
# runs them for 10^6 each.
build_fuzz "$ALC_ROOT/build/fuzz" -O0
ctest --no-tests=error --test-dir "$ALC_ROOT/build/fuzz" -L fuzz -j "$ALC_JOBS" --output-on-failure || status=1
exit $status
