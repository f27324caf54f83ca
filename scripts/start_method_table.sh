#!/usr/bin/env bash
# Monte Carlo over noise seeds of one landmark start method on the default world with a range-only
# or bearing-only sensor, known identities: one markdown table row of docs/results.md's start-method
# table. Each seed is simulated once (`simulate --scenario default --sensor SENSOR --seed N`) and run
# with `run --filter ekf --ekf-variant VARIANT --assoc known --landmark-init START --threads 1`.
#
# Usage: scripts/start_method_table.sh range-only|bearing-only full|fej|invariant START [run options...]
#   e.g. FIRST_SEED=26 RUNS=50 scripts/start_method_table.sh bearing-only fej inverse-distance
# Environment: SLAMKIT (the binary, default build/slamkit), RUNS (default 50), FIRST_SEED (default 26:
# seeds FIRST_SEED .. FIRST_SEED + RUNS - 1, the held-out seeds of docs/results.md), OUT (scratch
# folder, default out/start-<sensor>-<variant>-<start>).
#
# Columns: mean ATE after SE(2) alignment (median, worst); dead reckoning's mean ATE; runs whose ATE
# is worse than their own dead reckoning's; mean pose NEES (median run); share of steps whose pose
# NEES lies in its 95% chi-square band, mean (worst run); landmarks in the map; landmarks more than
# 3 m from the truth after the trajectory's alignment, per run; median map RMSE; the median over
# every run's landmarks of the time from a landmark's first observation (associations.txt) to its
# first appearance in the map (landmark_std.txt, written once a second): for a delayed start its
# start, for an inverse-distance one its conversion to a point.
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
runs=${RUNS:-50}
first_seed=${FIRST_SEED:-26}
die() { echo "start_method_table.sh: $*" >&2; exit 1; }
[[ $# -ge 3 ]] || die "usage: $0 range-only|bearing-only full|fej|invariant START [run options...]"
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (set SLAMKIT)"
[[ $runs =~ ^[1-9][0-9]*$ ]] || die "RUNS must be a positive integer, not '$runs'"
[[ $first_seed =~ ^[0-9]+$ ]] || die "FIRST_SEED must be a non-negative integer, not '$first_seed'"
command -v jq >/dev/null || die "jq not found (Debian package 'jq')"
sensor=$1 variant=$2 start=$3
shift 3
out=${OUT:-out/start-$sensor-$variant-$start}
mkdir -p "$out"

rows=$out/rows.txt delays=$out/delays.txt
: >"$rows"
: >"$delays"
for seed in $(seq "$first_seed" $((first_seed + runs - 1))); do
  log=$out/log-$seed run=$out/run-$seed
  [[ -d $log ]] || "$slamkit" simulate --scenario default --sensor "$sensor" --seed "$seed" --out "$log" >/dev/null
  rm -rf "$run"
  "$slamkit" run --data "sim:$log" --filter ekf --ekf-variant "$variant" --assoc known --landmark-init "$start" \
    --threads 1 "$@" --out "$run" >/dev/null
  m=$run/metrics.json
  # Landmarks more than 3 m off: the map carried by the trajectory's alignment onto the truth.
  off=$(awk -v c="$(jq .alignment.theta_rad "$m")" -v tx="$(jq .alignment.tx_m "$m")" -v ty="$(jq .alignment.ty_m "$m")" '
    NR == FNR { if ($1 !~ /^#/) { x[$1] = $2; y[$1] = $3 } next }
    $1 !~ /^#/ && ($1 in x) {
      ax = cos(c) * $2 - sin(c) * $3 + tx; ay = sin(c) * $2 + cos(c) * $3 + ty
      if ((ax - x[$1]) ^ 2 + (ay - y[$1]) ^ 2 > 9) n++
    }
    END { print n + 0 }' "$log/truth_landmarks.txt" "$run/map.txt")
  jq -r --arg off "$off" '[.ate_rmse_m, .dead_reckoning_ate_rmse_m, .nees_pose_mean, .nees_pose_in_95_fraction,
    .landmarks, ($off | tonumber), .map_rmse_m] | @tsv' "$m" >>"$rows"
  awk 'FNR == 1 { file++ } /^#/ { next }
    file == 1 && NF == 5 && $4 != "discard" && !($5 in seen) { seen[$5] = $2 }
    file == 2 && !($2 in mapped) { mapped[$2] = $1 }
    END { for (id in mapped) if (id in seen) print mapped[id] - seen[id] }' \
    "$run/associations.txt" "$run/landmark_std.txt" >>"$delays"
done

median() { sort -g | awk '{v[NR] = $1} END { print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2) }'; }
col() { cut -f"$1" "$rows"; }
awk -v sensor="$sensor" -v variant="$variant" -v start="$start" -v n="$runs" \
  -v ate_median="$(col 1 | median)" -v nees_median="$(col 3 | median)" -v map_median="$(col 7 | median)" \
  -v delay_median="$(median <"$delays")" '
  { ate += $1; dr += $2; worse += ($1 > $2); nees += $3; band += $4; landmarks += $5; off += $6
    if ($1 > worst) worst = $1
    if (NR == 1 || $4 < worst_band) worst_band = $4 }
  END {
    printf "| %s | %s | %s | %d | %.2f (%.2f, %.2f) | %.2f | %d | %.1f (%.1f) | %.0f%% (%.0f%%) | %.1f | %.2f | %.2f | %.1f |\n",
      sensor, variant, start, n, ate / n, ate_median, worst, dr / n, worse, nees / n, nees_median,
      100 * band / n, 100 * worst_band, landmarks / n, off / n, map_median, delay_median
  }' "$rows"
