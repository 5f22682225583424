#!/usr/bin/env bash
# Runs a libFuzzer target for a bounded time from the checked-in seed corpus; a crash fails.
set -euo pipefail
target=$1
seconds=$2
corpus=$(mktemp -d)
log=$(mktemp)
trap 'rm -rf "$corpus" "$log"' EXIT
cp firmware/fuzz/corpus/* "$corpus"/
status=0
"$target" -max_total_time="$seconds" -timeout=5 -max_len=512 -print_final_stats=1 "$corpus" >"$log" 2>&1 || status=$?
grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss_mb|==[0-9]+==ERROR|SUMMARY)" "$log" || true
if [ "$status" -ne 0 ]; then
  echo "the fuzzer failed (exit $status): its report follows" >&2
  tail -n 40 "$log" >&2
fi
exit "$status"
