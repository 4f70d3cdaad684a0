#!/usr/bin/env bash
# The libFuzzer targets of fuzz/ (README "Fuzzing"): builds them (clang, -DALC_FUZZ=ON; build/fuzz, or
# build/fuzz-long with --long) and runs every target from its seed corpus (fuzz/corpus/<target>, never
# written to).
#   bash scripts/fuzz.sh          the short run of the CTest tests (label fuzz; build/fuzz, -O0)
#   bash scripts/fuzz.sh --long   10^6 executions per target (ALC_FUZZ_RUNS to change it); prints per
#                                 target executions, coverage (edges, features), corpus size, time and
#                                 findings (crash, leak, timeout or OOM inputs, kept in build/fuzz-long/long/;
#                                 build/fuzz-long at -O1; the folder of an earlier run is moved aside to
#                                 build/fuzz-long/long.TIME,
#                                 TIME the date of its last change)
# Exits 1 if a target left findings or its log has no status line (it did not start, or died first).
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
ensure_packages "${ALC_PACKAGES[@]}" "${ALC_FUZZ_PACKAGES[@]}"
if [ "${1:-}" != "--long" ]; then
  build_fuzz "$ALC_ROOT/build/fuzz" -O0
  exec ctest --no-tests=error --test-dir "$ALC_ROOT/build/fuzz" -L fuzz -j "$ALC_JOBS" --output-on-failure
fi
# The long run is built at -O1 in a folder of its own (the short run's build/fuzz is -O0: common.sh).
build_fuzz "$ALC_ROOT/build/fuzz-long" -O1
runs="${ALC_FUZZ_RUNS:-1000000}"
out="$ALC_ROOT/build/fuzz-long/long"
# The findings of an earlier run stay: its folder is renamed, not deleted.
if [ -e "$out" ]; then
  kept="$out.$(date -r "$out" +%Y%m%d-%H%M%S)"
  n=1
  while [ -e "$kept" ]; do kept="$out.$(date -r "$out" +%Y%m%d-%H%M%S)-$n"; n=$((n + 1)); done
  mv "$out" "$kept"
  echo "the earlier run's logs and findings: moved to $kept"
fi
mkdir -p "$out"
printf '%-18s %12s %8s %8s %10s %8s %9s\n' target executions cov ft corpus "time[s]" findings
findings_total=0
failed=0
for target in scenario_csv nc_jsonl machine_toml grid_toml run_state supervisor_payload supervisor_toml; do
  mkdir -p "$out/corpus_$target"
  dict=()
  [ -f "$ALC_ROOT/fuzz/$target.dict" ] && dict=(-dict="$ALC_ROOT/fuzz/$target.dict")
  start=$(date +%s)
  ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1 \
    "$ALC_ROOT/build/fuzz-long/fuzz/fuzz_$target" -seed=1 -runs="$runs" -max_len=8192 -timeout=10 -rss_limit_mb=2048 \
    "${dict[@]}" -print_final_stats=1 -artifact_prefix="$out/${target}_" \
    "$out/corpus_$target" "$ALC_ROOT/fuzz/corpus/$target" >"$out/$target.log" 2>&1 || true
  seconds=$(( $(date +%s) - start ))
  findings=$(find "$out" -maxdepth 1 -name "${target}_*" -type f | wc -l)
  findings_total=$((findings_total + findings))
  # The last status line: "#N DONE cov: C ft: F corp: K/..." (or the last progress line before a finding).
  last=$(grep -E '^#[0-9]+' "$out/$target.log" | tail -1 || true)
  if [ -z "$last" ]; then
    # No status line: the binary is missing or the target died before its first one.
    echo "$target: no status line, see $out/$target.log (findings: $findings)"
    failed=$((failed + 1))
    continue
  fi
  executions=$(grep -oE 'stat::number_of_executed_units: *[0-9]+' "$out/$target.log" | grep -oE '[0-9]+$' || true)
  [ -n "$executions" ] || executions=$(sed -E 's/^#([0-9]+).*/\1/' <<<"$last")
  cov=$(grep -oE 'cov: [0-9]+' <<<"$last" | grep -oE '[0-9]+' || echo -)
  ft=$(grep -oE 'ft: [0-9]+' <<<"$last" | grep -oE '[0-9]+' || echo -)
  corp=$(grep -oE 'corp: [0-9]+' <<<"$last" | grep -oE '[0-9]+' || echo -)
  printf '%-18s %12s %8s %8s %10s %8s %9s\n' "$target" "$executions" "$cov" "$ft" "$corp" "$seconds" "$findings"
done
echo "logs and any findings: $out"
[ "$failed" -eq 0 ] || echo "$failed target(s) without a status line" >&2
[ "$findings_total" -eq 0 ] && [ "$failed" -eq 0 ]
