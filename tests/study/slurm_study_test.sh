#!/usr/bin/env bash
# A study sharded over SLURM gives the same rows as one process: starts a one-node cluster
# (slurm_cluster.sh), submits tests/study/slurm_grid.toml over case A as 3 array tasks plus the
# dependent merge job through scripts/slurm/submit-study.sh --wait, and compares
# `alc study report merged.sqlite --csv` byte for byte with `alc study --csv` of a single process.
# The daemons are stopped and the temporary directory removed however the test ends.
# usage: tests/study/slurm_study_test.sh ALC_BINARY      (needs root; installs SLURM and munge if missing)
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
source "$here/slurm_cluster.sh"

[ $# -eq 1 ] || { echo "usage: $0 ALC_BINARY" >&2; exit 2; }
alc="$(cd "$(dirname "$1")" && pwd)/$(basename "$1")"
[ -x "$alc" ] || { echo "slurm_study_test: $1 is not an executable" >&2; exit 1; }
help="$("$alc" study --help 2>&1)" || true
[[ "$help" == *--shard* ]] || { echo "slurm_study_test: $alc has no 'study' command with --shard" >&2; exit 1; }
grid="$here/slurm_grid.toml"

# Cases alc study cannot take together are refused at submission, not in every task of the array.
submit="$here/../../scripts/slurm/submit-study.sh"
for bad in "--case A --case B" "--case A --case $grid.csv"; do
  # shellcheck disable=SC2086
  if out="$("$submit" --alc "$alc" --out /nonexistent/never $bad 2>&1)"; then
    echo "slurm_study_test: submit-study.sh $bad was accepted" >&2; exit 1
  fi
  [[ "$out" == *"give"* ]] || { echo "slurm_study_test: submit-study.sh $bad: unexpected message: $out" >&2; exit 1; }
done

tmp="$(mktemp -d)"
chmod 755 "$tmp"  # munged wants every directory above its socket searchable by all
trap 'slurm_cluster_stop "$tmp/cluster"; rm -rf "$tmp"' EXIT
trap 'exit 130' INT TERM  # so that the EXIT trap stops the daemons then too
slurm_cluster_start "$tmp/cluster"

# The jobs write into $tmp/out; their logs, and the submit script's report, are shown on failure.
if ! "$here/../../scripts/slurm/submit-study.sh" --wait --alc "$alc" --grid "$grid" --case A --shards 3 \
       --out "$tmp/out" >"$tmp/submit.log" 2>&1; then
  cat "$tmp/submit.log" >&2
  for log in "$tmp"/out/logs/*; do echo "---- $(basename "$log")" >&2; cat "$log" >&2; done
  echo "slurm_study_test: the sharded study on SLURM failed" >&2
  exit 1
fi

"$alc" study report "$tmp/out/merged.sqlite" --csv "$tmp/sharded.csv" >/dev/null ||
  { echo "slurm_study_test: alc study report of the merged shards failed" >&2; exit 1; }
"$alc" study --grid "$grid" --case A --db "$tmp/single.sqlite" --csv "$tmp/single.csv" >/dev/null ||
  { echo "slurm_study_test: alc study in one process failed" >&2; exit 1; }
[ "$(wc -l <"$tmp/single.csv")" -ge 2 ] ||
  { echo "slurm_study_test: alc study in one process wrote no result rows" >&2; exit 1; }
if ! cmp "$tmp/single.csv" "$tmp/sharded.csv"; then
  diff "$tmp/single.csv" "$tmp/sharded.csv" | head -n 20 >&2 || true
  echo "slurm_study_test: the merged shards' rows differ from a single process's" >&2
  exit 1
fi
