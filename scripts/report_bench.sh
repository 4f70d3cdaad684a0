#!/usr/bin/env bash
# Benchmark of `alc report` (docs/report.md): the report of an 8-day replay at 1 min (case A) and of
# a 90-day history at 1 min (case A's recording laid end to end 12 times, cut at 90 days; also
# without its stored indicators, as a supervisor's history, so they are computed from the probes), each
# written, then opened in headless chromium: the time to load and paint it is the wall time of a
# screenshot of the page minus that of an empty page (browser start), best of 3 each.
#   scripts/report_bench.sh [DIR]   (default: a temporary directory, removed at the end; in a DIR of
#                                    yours only its own files are replaced: a.csv, a90.csv, a8/a90/a90p
#                                    .sqlite and .html, empty.html, shot.png)
#   ALC=build/release/cli/alc scripts/report_bench.sh   (an alc already built: no build here, and only
#                                    sqlite3 and chromium are installed if missing)
# Exits 1 if chromium fails or writes no screenshot.
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
if [ -n "${ALC:-}" ]; then
  ensure_packages sqlite3 chromium
  alc="$(realpath "$ALC")"
else
  ensure_packages "${ALC_PACKAGES[@]}" chromium
  build "$ALC_ROOT/build/release" -DCMAKE_BUILD_TYPE=Release -DALC_BUILD_TESTS=OFF
  alc="$ALC_ROOT/build/release/cli/alc"
fi
dir="${1:-}"
if [ -z "$dir" ]; then dir="$(mktemp -d)"; trap 'rm -rf "$dir"' EXIT; fi
mkdir -p "$dir"
"$alc" simulate --case A --out "$dir/a.csv" >/dev/null
# 90 days at 60 s: copies of the 8-day recording shifted by 8 days + 1 min each.
awk -F, -v OFS=, 'NR == 1 { header = $0; next } { rows[n++] = $0 }
  END { print header; step = 691260; for (k = 0; k < 12; ++k) for (i = 0; i < n; ++i) {
          split(rows[i], f, ","); t = f[1] + k * step; if (t > 90 * 86400) exit
          $0 = rows[i]; $1 = t; print } }' "$dir/a.csv" >"$dir/a90.csv"
# Only the databases this script writes (and their WAL files), not every database in DIR.
for name in a8 a90 a90p; do rm -f "$dir/$name.sqlite" "$dir/$name.sqlite-wal" "$dir/$name.sqlite-shm"; done
"$alc" replay --case A --db "$dir/a8.sqlite" >/dev/null
start=$(date +%s%N)
"$alc" replay "$dir/a90.csv" --db "$dir/a90.sqlite" >/dev/null
echo "90-day history replayed in $(( ($(date +%s%N) - start) / 1000000 )) ms"
# Wall time of headless chromium loading a page and taking a screenshot (load, layout, paint), best
# of 3 [ms]. A chromium that fails (or times out) or writes no screenshot is an error: its output is
# shown and the script exits 1 (called as $(shot_ms ...), so the caller's assignment fails).
shot_ms() {
  local best=999999 profile start ms rc
  for _ in 1 2 3; do
    profile="$(mktemp -d)"
    rm -f "$dir/shot.png"
    start=$(date +%s%N)
    rc=0
    timeout 300 chromium --headless=new --no-sandbox --disable-gpu --user-data-dir="$profile" --window-size=1040,2000 \
      --screenshot="$dir/shot.png" "file://$1" >"$profile/chromium.log" 2>&1 || rc=$?
    ms=$(( ($(date +%s%N) - start) / 1000000 ))
    if [ "$rc" -ne 0 ] || [ ! -s "$dir/shot.png" ]; then
      cat "$profile/chromium.log" >&2
      rm -rf "$profile"
      if [ "$rc" -eq 124 ]; then
        echo "report_bench.sh: chromium timed out after 300 s on $1" >&2
      elif [ "$rc" -ne 0 ]; then
        echo "report_bench.sh: chromium failed on $1 (exit $rc)" >&2
      else
        echo "report_bench.sh: chromium wrote no screenshot of $1" >&2
      fi
      exit 1
    fi
    rm -rf "$profile"
    [ "$ms" -lt "$best" ] && best=$ms
  done
  echo "$best"
}
echo '<!DOCTYPE html><html><body>empty</body></html>' >"$dir/empty.html"
empty=$(shot_ms "$dir/empty.html")
echo "chromium start, empty page, screenshot: $empty ms (subtracted below)"
# The 90-day history as a supervisor leaves it: no stored indicators, so the report computes them
# from the probes (docs/report.md, Indicators).
sqlite3 "$dir/a90.sqlite" "PRAGMA wal_checkpoint(TRUNCATE);" >/dev/null
cp "$dir/a90.sqlite" "$dir/a90p.sqlite"
sqlite3 "$dir/a90p.sqlite" "DELETE FROM run_indicators;"
for name in a8 a90 a90p; do
  "$alc" report "$dir/$name.sqlite" --out "$dir/$name.html"
  ms=$(shot_ms "$dir/$name.html")  # a separate assignment: a failing chromium stops the script here
  echo "$name: the report loads and renders in $(( ms - empty )) ms (chromium, headless)"
done
