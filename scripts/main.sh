#!/usr/bin/env bash
# The main job: build, then replay the built-in load cases A–D.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
ensure_packages "${ALC_PACKAGES[@]}"
build "$ALC_ROOT/build/release" -DCMAKE_BUILD_TYPE=Release -DALC_BUILD_TESTS=OFF
"$ALC_ROOT/build/release/cli/alc" simulate --case all --summary
