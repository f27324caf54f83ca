#!/usr/bin/env bash
# Runs every libFuzzer target built in BUILD_DIR for SECONDS each, one after another, starting from
# its seeds in fuzz/corpus/<target>/; new inputs and any crash go to OUT/<target>/. Prints each
# target's executions and coverage (libFuzzer's cov: edges, ft: features) and fails on a finding.
# Usage: scripts/fuzz.sh BUILD_DIR SECONDS OUT [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/.."
build=$1 seconds=$2 out=$3
shift 3
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
  for dir in fuzz/corpus/*/; do targets+=("$(basename "$dir")"); done
fi
failed=()
for t in "${targets[@]}"; do
  mkdir -p "$out/$t/corpus"
  log="$out/$t/fuzz.log"
  # -timeout: one input taking 10 s is a hang; -rss_limit_mb: a blow-up; both count as findings.
  if "$build/fuzz_$t" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
       -artifact_prefix="$out/$t/" "$out/$t/corpus" "fuzz/corpus/$t" >"$log" 2>&1; then
    runs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | grep -o '[0-9]*$' || true)
    cov=$(grep -E '^#[0-9]+' "$log" | tail -1 | grep -oE 'cov: [0-9]+ ft: [0-9]+' || true)
    echo "fuzz $t: ${seconds} s, ${runs:-?} executions, ${cov:-no coverage line}, no finding"
  else
    echo "fuzz $t: FINDING, see $log; keep the input (crash-*, leak-*, timeout-*, oom-*) in fuzz/crashes/$t/"
    failed+=("$t")
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "fuzz: findings in ${failed[*]}"
  exit 1
fi
