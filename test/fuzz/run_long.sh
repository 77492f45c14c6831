#!/usr/bin/env bash
# Long libFuzzer runs as a benchmark: each target for --time seconds (default 60) from its seed
# corpus (copied: the source tree is never written), then prints a table of executions,
# executions/s, coverage (edges, features), corpus size, peak RSS and crashes, and writes JSON.
#
#   test/fuzz/run_long.sh [--build-dir build] [--time 60] [--json FILE] [--out DIR] [target...]
#
# Targets: rig_log console params_json (default: all three). The fuzzer binaries are
# BUILD/test/fuzz/fuzz_<target> (cmake --build BUILD --target fuzzers; needs clang++ and
# libclang-rt-*-dev). Exit status 1 if any target crashed (the reproducer is in DIR/<target>/).
set -u
here=$(cd "$(dirname "$0")" && pwd)
build=build
secs=60
json=""
out=""
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --build-dir) build=$2; shift 2 ;;
    --time) secs=$2; shift 2 ;;
    --json) json=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[ ${#targets[@]} -eq 0 ] && targets=(rig_log console params_json)
[ -n "$out" ] || out="$build/test/fuzz/long"
mkdir -p "$out"

results=()
status=0
printf '| %-12s | %8s | %10s | %8s | %6s | %6s | %7s | %7s | %7s |\n' target time_s executions exec/s cov ft corpus rss_mb crashes
printf '|--------------|----------|------------|----------|--------|--------|---------|---------|---------|\n'
for t in "${targets[@]}"; do
  bin="$build/test/fuzz/fuzz_$t"
  if [ ! -x "$bin" ]; then
    echo "run_long: $bin not built (cmake --build $build --target fuzzers)" >&2
    status=1
    continue
  fi
  work="$out/$t/corpus"
  art="$out/$t/artifacts"
  rm -rf "$work" "$art"
  mkdir -p "$work" "$art"
  cp "$here/corpus/$t/"* "$work/" 2>/dev/null
  dict=()
  [ -f "$here/$t.dict" ] && dict=(-dict="$here/$t.dict")
  log="$out/$t/fuzz.log"
  start=$(date +%s.%N)
  "$bin" -max_total_time="$secs" -timeout=10 -rss_limit_mb=2048 -max_len=4096 \
    -print_final_stats=1 -create_missing_dirs=1 -artifact_prefix="$art/" "${dict[@]}" "$work" > "$log" 2>&1
  rc=$?
  end=$(date +%s.%N)
  dur=$(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.1f", b - a }')
  execs=$(awk '/stat::number_of_executed_units/ { print $2 }' "$log" | tail -1)
  eps=$(awk '/stat::average_exec_per_sec/ { print $2 }' "$log" | tail -1)
  rss=$(awk '/stat::peak_rss_mb/ { print $2 }' "$log" | tail -1)
  # Last progress line: "#N  DONE|pulse|NEW  cov: C ft: F corp: U/SIZE ..."
  last=$(grep -E '^#[0-9]+.*cov: ' "$log" | tail -1)
  cov=$(echo "$last" | sed -n 's/.*cov: \([0-9]*\).*/\1/p')
  ft=$(echo "$last" | sed -n 's/.*ft: \([0-9]*\).*/\1/p')
  corp=$(echo "$last" | sed -n 's/.*corp: \([0-9]*\)\/.*/\1/p')
  crashes=$(find "$art" -type f | wc -l)
  if [ $rc -ne 0 ] || [ "$crashes" -ne 0 ]; then
    status=1
    echo "run_long: fuzz_$t failed (exit $rc), see $log and $art" >&2
    grep -E 'ERROR|invariant|SUMMARY' "$log" | head -5 >&2
  fi
  printf '| %-12s | %8s | %10s | %8s | %6s | %6s | %7s | %7s | %7s |\n' \
    "$t" "$dur" "${execs:-0}" "${eps:-0}" "${cov:-0}" "${ft:-0}" "${corp:-0}" "${rss:-0}" "$crashes"
  results+=("{\"target\": \"$t\", \"time_s\": $dur, \"executions\": ${execs:-0}, \"exec_per_s\": ${eps:-0}, \"coverage_edges\": ${cov:-0}, \"features\": ${ft:-0}, \"corpus_units\": ${corp:-0}, \"peak_rss_mb\": ${rss:-0}, \"crashes\": $crashes, \"exit_code\": $rc}")
done

if [ -n "$json" ]; then
  {
    echo "{"
    echo "  \"benchmark\": \"fuzz_long\","
    echo "  \"seconds_per_target\": $secs,"
    echo "  \"sanitizers\": \"address,undefined,fuzzer\","
    echo "  \"targets\": ["
    n=${#results[@]}
    for i in "${!results[@]}"; do
      sep=","
      [ "$i" -eq $((n - 1)) ] && sep=""
      echo "    ${results[$i]}$sep"
    done
    echo "  ]"
    echo "}"
  } > "$json"
fi
exit $status
