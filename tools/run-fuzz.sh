#!/usr/bin/env bash
# Runs a libFuzzer target for a bounded time from the checked-in seed corpus; a crash fails.
set -euo pipefail
target=$1
seconds=$2
corpus=$(mktemp -d)
trap 'rm -rf "$corpus"' EXIT
cp firmware/fuzz/corpus/* "$corpus"/
"$target" -max_total_time="$seconds" -timeout=5 -max_len=512 -print_final_stats=1 "$corpus" 2>&1 \
  | grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss_mb|==[0-9]+==ERROR)" || true
exit "${PIPESTATUS[0]}"
