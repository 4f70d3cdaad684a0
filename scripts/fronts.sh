#!/usr/bin/env bash
# Regenerates the Pareto fronts of docs/adaptive.md ("Judged on the Pareto front") in one command:
# the paper-schedule and adaptive-schedule studies (docs/grids-{paper,adaptive}-schedule*.toml, every
# file of a schedule) on every case (A-D, S16, H1-H5; CASES) at their own seeds and at the seeds in SEEDS
# (default "2 3"; SEEDS= empty: the own seeds only; recordings made with `alc simulate --case X --seed
# S`), then the comparison tables, the runs whose case or an output is worse than uncompensated and one SVG
# per seed.
#
# usage: scripts/fronts.sh [OUT_DIR]      (ALC=path/to/alc, SEEDS="2 3", JOBS=2, CASES="A B ..." in the environment)
# CASES: the cases, default "A B C D S16 H1 H2 H3 H4 H5" (those of the tables in docs/adaptive.md); the
# sets are chosen on A-D at their own seeds (--choose-on below), so keep A B C D in it. H6 and H7, built
# after the policy was settled, are judged each apart: CASES="A B C D H6", CASES="A B C D H7" (docs/adaptive.md,
# "A case built after", "A second case built after"), or all cases in one run and the tables of each subset
# from its CSVs with `scripts/compare_fronts.py OUT_DIR/paper.csv OUT_DIR/adaptive.csv --cases A,B,C,D,H7 ...`
# (the same rows: a run does not depend on the other cases).
# ALC defaults to build/release/cli/alc of this checkout, the build of scripts/main.sh (run that first;
# this script builds nothing).
# Writes OUT_DIR/paper.csv, OUT_DIR/adaptive.csv, OUT_DIR/fronts.md and OUT_DIR/fronts-*.svg
# (default OUT_DIR: build/fronts); prints the table and the run time.
set -euo pipefail
# The whole script is one block, read before any of it runs: bash reads a script as it goes, so a run of an
# hour would otherwise break (a syntax error, or lines run twice) when the file is rewritten in place under
# it, by an editor or a script writing the same file (2026-12-08: a run stopped after its studies that way;
# tests/scripts/fronts_test.sh). A file replaced by a new one, as git checkout does, never broke a run.
{
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
alc=$(realpath -m "${ALC:-$here/build/release/cli/alc}")
if [ ! -x "$alc" ] || [ -d "$alc" ]; then
  echo "fronts.sh: no alc at $alc: build it with scripts/main.sh, or give ALC=path/to/alc" >&2
  exit 2
fi
out=$(realpath -m "${1:-$here/build/fronts}")  # absolute: the seed studies run inside its recordings/
seeds=${SEEDS-2 3}  # set but empty: the own seeds only
jobs=${JOBS:-2}
cases=${CASES:-A B C D S16 H1 H2 H3 H4 H5}
# Checked before any study runs: built-in case names (`alc simulate --list`), each once, A-D among them.
known=$("$alc" simulate --list | awk '/^[A-Z][A-Z0-9]* /{print $1}')
seen=" "
for c in $cases; do
  if ! grep -qx -- "$c" <<< "$known"; then
    echo "fronts.sh: CASES: '$c' is not a built-in case (alc simulate --list; no groups such as all or heldout)" >&2
    exit 2
  fi
  if [[ $seen == *" $c "* ]]; then
    echo "fronts.sh: CASES: '$c' is given twice" >&2
    exit 2
  fi
  seen="$seen$c "
done
for c in A B C D; do
  if [[ $seen != *" $c "* ]]; then
    echo "fronts.sh: CASES must include A, B, C and D (the sets are chosen on them), got '$cases'" >&2
    exit 2
  fi
done
start=$(date +%s)
mkdir -p "$out/recordings"
for s in $seeds; do
  for c in $cases; do
    f="$out/recordings/$c seed $s.csv"
    "$alc" simulate --case "$c" --seed "$s" --out "$f"  # always anew: the twin may have changed
  done
done
for g in paper adaptive; do
  rm -f "$out/$g.csv"
  part=0
  # Every grid file of the schedule (docs/grids-adaptive-schedule.toml, -dense.toml and -rare.toml: the
  # same keys in the same order, so their rows share one file; compare_fronts.py names a set by its values).
  for grid in "$here"/docs/grids-"$g"-schedule*.toml; do
    # The cases at their own seeds, then each other seed's recordings (the case column names the file).
    for what in $(for c in $cases; do echo "case:$c"; done) $(for s in $seeds; do echo "seed:$s"; done); do
      part=$((part + 1))
      if [[ $what == seed:* ]]; then
        s=${what#seed:}
        files=()
        for c in $cases; do files+=("$out/recordings/$c seed $s.csv"); done
        (cd "$out/recordings" && "$alc" study --grid "$grid" --jobs "$jobs" --quiet --csv "$out/$g.$part.csv" \
          "${files[@]##*/}" > /dev/null)
      else
        "$alc" study --grid "$grid" --case "${what#case:}" --jobs "$jobs" --quiet --csv "$out/$g.$part.csv" > /dev/null
      fi
      if [ ! -s "$out/$g.csv" ]; then
        cp "$out/$g.$part.csv" "$out/$g.csv"
        first=${grid##*/}
      elif [ "$(head -1 "$out/$g.$part.csv" | sed 's/,status,.*//')" != "$(head -1 "$out/$g.csv" | sed 's/,status,.*//')" ]; then
        echo "fronts.sh: ${grid##*/}: its keys differ from those of $first; give every grid of a schedule the same keys" >&2
        exit 2
      else
        tail -n +2 "$out/$g.$part.csv" >> "$out/$g.csv"
      fi
      rm -f "$out/$g.$part.csv"
    done
  done
done
# --choose-on: each schedule's sets on its front pooled over A-D at their own seeds, judged on the other recordings
# (tuned on A-D, reported on the others; out of sample). --worse-by: the runs whose case or an output is worse than
# uncompensated, with the guard's move check on (0.5), off (inf) and moot (no Post-CP probes) (docs/adaptive.md,
# "Judged on the Pareto front" and "What remains").
python3 "$here/scripts/compare_fronts.py" "$out/paper.csv" "$out/adaptive.csv" --label-a paper --label-b adaptive \
  --svg "$out/fronts" --choose-on "A-D, own seeds" --worse-by move-fraction | tee "$out/fronts.md"
echo "fronts.sh: $(( $(date +%s) - start )) s (cases: $cases; seeds: own${seeds:+, $seeds}; jobs $jobs); SVGs: $out/fronts-*.svg"
exit
}
