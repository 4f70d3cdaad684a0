#!/usr/bin/env bash
# The main job: build, replay the built-in load cases A–D into the default history database, then
# write the HTML report of these replays (docs/report.md) beside the history and print its path.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
ensure_packages "${ALC_PACKAGES[@]}"
build "$ALC_ROOT/build/release" -DCMAKE_BUILD_TYPE=Release -DALC_BUILD_TESTS=OFF
alc="$ALC_ROOT/build/release/cli/alc"
# The history goes to the embedded default database (alc db path); each run is a new run in it.
db="$("$alc" db path)"
# Run ids of a history, one a line (alc db info lists "  run N: ...").
run_ids() { [ -f "$db" ] && "$alc" db info "$db" | sed -n 's/^  run \([0-9][0-9]*\):.*/\1/p'; true; }
last_before="$(run_ids | tail -n 1)"
"$alc" replay --case all --db "$db"
# The report of the runs this job added (earlier runs stay in the history, not in this page).
run_options=()
for id in $(run_ids); do
  [ "$id" -gt "${last_before:-0}" ] && run_options+=(--run "$id")
done
"$alc" report "$db" "${run_options[@]}" --out "${db%.sqlite}-report.html"
