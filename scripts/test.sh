#!/usr/bin/env bash
# The whole test suite: a release build and an ASan+UBSan build, each run through CTest.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
ensure_packages "${ALC_PACKAGES[@]}"
# LinuxCNC (rs274 and the headless simulator) for the nc_interface tests; large, so only here.
ensure_packages linuxcnc-uspace
# The MQTT broker for the supervisor's tests (tests/supervisor/ starts its own on a free port).
ensure_packages mosquitto
# SLURM and munge for the study's cluster test (tests/study/slurm_study_test.sh starts its own
# daemons; the packages' services are not used).
ensure_packages slurmctld slurmd slurm-client munge
# Chromium for the report's browser tests (tests/report/browser_test.cpp: headless, on a local file).
ensure_packages chromium
status=0
build "$ALC_ROOT/build/test-release" -DCMAKE_BUILD_TYPE=Release
ctest --no-tests=error --test-dir "$ALC_ROOT/build/test-release" -j "$ALC_JOBS" --output-on-failure || status=1
build "$ALC_ROOT/build/test-asan" -DCMAKE_BUILD_TYPE=RelWithDebInfo -DALC_SANITIZE=ON
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --no-tests=error --test-dir "$ALC_ROOT/build/test-asan" -j "$ALC_JOBS" --output-on-failure || status=1
exit $status
