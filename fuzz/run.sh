#!/usr/bin/env bash
# Usage: fuzz/run.sh [SECONDS]: run every fuzz target for SECONDS each (default 60), one
# after the other, starting from its committed seeds in fuzz/corpus/<target>/. Fails on
# the first crash (libFuzzer leaves the input in fuzz/artifacts/<target>/).
set -euo pipefail
SECONDS_EACH=${1:-60}
cd "$(dirname "$0")"
TARGETS=$(cargo +nightly fuzz list)
cargo +nightly fuzz build
for t in $TARGETS; do
  echo "== $t: ${SECONDS_EACH} s"
  cargo +nightly fuzz run "$t" -- -max_total_time="$SECONDS_EACH" -print_final_stats=1
done
echo "all targets ran ${SECONDS_EACH} s without a crash"
