#!/usr/bin/env bash
# Run by run, the consistent EKF variants' ATE against the plain EKF's, from the folders
# scripts/consistency_monte_carlo.sh leaves (OUT/<filter>-<seed>/metrics.json): one markdown row per
# seed with each filter's ATE [m] (aligned), its ratio to the EKF's, and the unaligned position
# RMSE in the truth's frame; then the number of runs over RATIO (default 1.1) and the largest ratio.
#
# Usage: scripts/ate_ratio_table.sh OUT_DIR [filters...]   (default filters: fej invariant)
#   e.g. FILTERS="ekf fej invariant" RUNS=20 scripts/consistency_monte_carlo.sh room
#        scripts/ate_ratio_table.sh out/consistency-room
set -euo pipefail

die() { echo "ate_ratio_table.sh: $*" >&2; exit 1; }
[[ $# -ge 1 ]] || die "usage: $0 OUT_DIR [filters...]"
out=$1
shift
filters=${*:-fej invariant}
limit=${RATIO:-1.1}
command -v jq >/dev/null || die "jq not found (Debian package 'jq')"
[[ -d $out ]] || die "no folder $out"

seeds=$(find "$out" -maxdepth 1 -type d -name 'ekf-*' | sed 's/.*ekf-//' | sort -n)
[[ -n $seeds ]] || die "no ekf-<seed> runs in $out"
header="| seed | ekf ATE (unaligned) |"
rule="|---|---|"
for f in $filters; do
  header+=" $f ATE (unaligned) | ratio |"
  rule+="---|---|"
done
echo "$header"
echo "$rule"
over=0
worst=0
for seed in $seeds; do
  ekf=$(jq -r '.ate_rmse_m' "$out/ekf-$seed/metrics.json")
  row="| $seed | $(jq -r '"\(.ate_rmse_m * 1000 | round / 1000) (\(.unaligned_position_rmse_m * 1000 | round / 1000))"' "$out/ekf-$seed/metrics.json") |"
  for f in $filters; do
    m="$out/$f-$seed/metrics.json"
    [[ -f $m ]] || die "missing $m"
    ratio=$(jq -r --argjson ekf "$ekf" '.ate_rmse_m / $ekf' "$m")
    row+=" $(jq -r '"\(.ate_rmse_m * 1000 | round / 1000) (\(.unaligned_position_rmse_m * 1000 | round / 1000))"' "$m") | $(printf '%.2f' "$ratio") |"
    if awk -v r="$ratio" -v l="$limit" 'BEGIN { exit !(r > l) }'; then over=$((over + 1)); fi
    worst=$(awk -v r="$ratio" -v w="$worst" 'BEGIN { print (r > w ? r : w) }')
  done
  echo "$row"
done
echo
echo "runs over ${limit}x the EKF's ATE: $over of $(($(echo "$seeds" | wc -l) * $(echo "$filters" | wc -w))); largest ratio $(printf '%.2f' "$worst")"
