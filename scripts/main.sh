#!/usr/bin/env bash
# The main job: build, then replay the built-in load cases A–D into the default history database.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
ensure_packages "${ALC_PACKAGES[@]}"
build "$ALC_ROOT/build/release" -DCMAKE_BUILD_TYPE=Release -DALC_BUILD_TESTS=OFF
alc="$ALC_ROOT/build/release/cli/alc"
# The history goes to the embedded default database (alc db path); each run is a new run in it.
"$alc" replay --case all --db "$("$alc" db path)"
