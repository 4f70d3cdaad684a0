#!/usr/bin/env bash
# scripts/fronts.sh end to end on grids of a few sets (CTest "scripts: fronts.sh"): the recordings, both
# studies, the tables and one SVG per seed, for A-D at their own seeds and at seed 2; and the run goes on to
# its end when the script's file is rewritten in place while it runs (an editor writing the file, a script
# regenerating it), which stopped an hour's run with a syntax error on 2026-12-08. Also CASES without A-D is
# refused before anything runs. The grids are written here, small; the script and compare_fronts.py are
# those of this tree, copied into a temporary tree (fronts.sh reads its grids from its own tree's docs/).
# usage: fronts_test.sh path/to/alc
set -euo pipefail
alc=$(realpath "$1")
src=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
mkdir -p "$tmp/scripts" "$tmp/docs"
cp "$src/scripts/fronts.sh" "$src/scripts/compare_fronts.py" "$tmp/scripts/"
printf 'cp = [6.5]\ninterval = [1, 4]\nmove-fraction = [0.5]\n' > "$tmp/docs/grids-paper-schedule.toml"
# Two files of the adaptive schedule with the same keys: fronts.sh joins their rows into one CSV.
printf 'cp = [6.5]\ninterval = [2]\nuncertainty-fraction = [0.5, 1.0]\nmin-interval = [0.5]\nmax-interval = [4]\nmove-fraction = [0.5]\n[fixed]\nschedule = "adaptive"\n' \
  > "$tmp/docs/grids-adaptive-schedule.toml"
printf 'cp = [6.5]\ninterval = [2]\nuncertainty-fraction = [0.2]\nmin-interval = [0.25]\nmax-interval = [1]\nmove-fraction = [0.5]\n[fixed]\nschedule = "adaptive"\n' \
  > "$tmp/docs/grids-adaptive-schedule-dense.toml"

# CASES without one of A-D: refused (exit 2) before any recording is made.
rc=0
CASES="A B C H1" ALC="$alc" bash "$tmp/scripts/fronts.sh" "$tmp/refused" > "$tmp/refused.log" 2>&1 || rc=$?
[ "$rc" = 2 ] || fail "CASES without D: exit $rc, expected 2"
grep -q "CASES must include A, B, C and D" "$tmp/refused.log" || fail "CASES without D: $(cat "$tmp/refused.log")"
[ ! -e "$tmp/refused" ] || fail "CASES without D: $tmp/refused was made"

# The run, and the script's file rewritten in place (same file, 40 comment lines more at its top) once the
# first study's rows are there, while the others still run.
out="$tmp/out"
(rc=0; CASES="A B C D" SEEDS="2" ALC="$alc" JOBS=2 bash "$tmp/scripts/fronts.sh" "$out" > "$tmp/run.log" 2>&1 || rc=$?
 echo "$rc" > "$tmp/run.rc") &
pid=$!
for _ in $(seq 1 600); do
  [ -s "$out/paper.csv" ] && break
  kill -0 "$pid" 2> /dev/null || break
  sleep 0.05
done
[ -s "$out/paper.csv" ] || fail "no $out/paper.csv while the run went on: $(cat "$tmp/run.log")"
[ ! -e "$out/fronts.md" ] || fail "the run had ended before its file was rewritten: the test tested nothing"
{ head -3 "$src/scripts/fronts.sh"; printf '# a line that moves the rest down %s\n' $(seq 1 40)
  tail -n +4 "$src/scripts/fronts.sh"; } > "$tmp/edited.sh"
cat "$tmp/edited.sh" > "$tmp/scripts/fronts.sh"  # in place: the file bash is reading
wait "$pid" || true
rc=$(cat "$tmp/run.rc")
[ "$rc" = 0 ] || fail "fronts.sh exit $rc after its file was rewritten: $(tail -5 "$tmp/run.log")"
grep -q "^fronts.sh: [0-9]* s (cases: A B C D; seeds: own, 2; jobs 2)" "$tmp/run.log" ||
  fail "no closing line: $(tail -3 "$tmp/run.log")"

# What it made: 8 recordings (4 cases at seed 2 written, own seeds built in), 2 paper and 3 adaptive sets each.
[ "$(ls "$out/recordings" | wc -l)" = 4 ] || fail "recordings: $(ls "$out/recordings")"
[ "$(tail -n +2 "$out/paper.csv" | wc -l)" = 16 ] || fail "paper.csv: $(tail -n +2 "$out/paper.csv" | wc -l) rows, expected 16"
[ "$(tail -n +2 "$out/adaptive.csv" | wc -l)" = 24 ] ||
  fail "adaptive.csv: $(tail -n +2 "$out/adaptive.csv" | wc -l) rows, expected 24 (both grid files joined)"
for r in "A" "D" "A seed 2" "D seed 2"; do
  grep -q "^| $r | " "$out/fronts.md" || fail "fronts.md: no row of $r"
done
grep -q "^chosen on A-D, own seeds (4)" "$out/fronts.md" || fail "fronts.md: no tables of the sets chosen on A-D"
grep -q "^| paper | 0.5 | 16 | " "$out/fronts.md" || fail "fronts.md: no worse-than-uncompensated row of the paper's 16 runs"
for f in fronts-own.svg fronts-seed-2.svg; do
  grep -q "<svg" "$out/$f" || fail "no $f"
done
echo "ok: fronts.sh on A-D at two seeds, 16 paper and 24 adaptive runs, rewritten in place while it ran"
