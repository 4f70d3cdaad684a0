#!/usr/bin/env bash
# Benchmark of `alc report` (docs/report.md): the report of an 8-day replay at 1 min (case A) and of
# a 90-day history at 1 min (case A's recording laid end to end 12 times, cut at 90 days; also
# without its stored indicators, as a supervisor's history, so they are computed from the probes), each
# written, then opened in headless chromium: the time to load and paint it is the wall time of a
# screenshot of the page minus that of an empty page (browser start), best of 3 each.
#   scripts/report_bench.sh [DIR]   (default: a temporary directory, removed at the end)
#   ALC=build/rel/cli/alc scripts/report_bench.sh   (an alc already built: no build here)
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
ensure_packages "${ALC_PACKAGES[@]}" chromium
if [ -n "${ALC:-}" ]; then
  alc="$(realpath "$ALC")"
else
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
rm -f "$dir"/*.sqlite*
"$alc" replay --case A --db "$dir/a8.sqlite" >/dev/null
start=$(date +%s%N)
"$alc" replay "$dir/a90.csv" --db "$dir/a90.sqlite" >/dev/null
echo "90-day history replayed in $(( ($(date +%s%N) - start) / 1000000 )) ms"
# Wall time of headless chromium loading a page and taking a screenshot (load, layout, paint), best
# of 3 [ms].
shot_ms() {
  local best=999999 i profile start ms
  for i in 1 2 3; do
    profile="$(mktemp -d)"
    start=$(date +%s%N)
    timeout 300 chromium --headless=new --no-sandbox --disable-gpu --user-data-dir="$profile" --window-size=1040,2000 \
      --screenshot="$dir/shot.png" "file://$1" >/dev/null 2>&1
    ms=$(( ($(date +%s%N) - start) / 1000000 ))
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
  echo "$name: the report loads and renders in $(( $(shot_ms "$dir/$name.html") - empty )) ms (chromium, headless)"
done
