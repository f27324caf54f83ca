#!/usr/bin/env bash
# How much one Victoria Park ATE says: runs the Gaussian filters with JCBB at the default settings and
# at 18 neighbours of them (each dataset noise parameter 10% lower and higher, each association and
# map-management setting one step either side), and prints a markdown table of the ATEs with each
# variant's ratio to the plain EKF's. A gap that holds over the neighbours belongs to the filter;
# one that comes and goes with them belongs to the run (docs/consistency.md, "Real data").
#
# Usage: scripts/victoria_park_sensitivity.sh
# Environment: SLAMKIT (the binary, default build/slamkit), SLAMKIT_DATA (the datasets folder, as
# for slamkit run), VARIANTS (default "full invariant fej"; the EKF variants' names, and ukf and
# ukf-additive for the UKF with --ukf-noise augmented and additive), OUT (scratch folder, default
# out/vp-sensitivity), JOBS (parallel runs, default 2), RUN_ARGS (options added to every run, e.g.
# "--relocalise-min-pairs 0").
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
variants=${VARIANTS:-full invariant fej}
out=${OUT:-out/vp-sensitivity}
jobs=${JOBS:-2}
run_args=${RUN_ARGS:-}
die() { echo "victoria_park_sensitivity.sh: $*" >&2; exit 1; }
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (set SLAMKIT)"
command -v jq >/dev/null || die "jq not found (Debian package 'jq')"
mkdir -p "$out"

# label|options: the defaults, then one setting changed at a time.
settings=("default|")
for kv in sigma_speed_mps:1.8 sigma_speed_mps:2.2 sigma_steer_deg:5.4 sigma_steer_deg:6.6 \
  sigma_range_m:0.9 sigma_range_m:1.1 sigma_bearing_deg:2.7 sigma_bearing_deg:3.3; do
  echo "{\"${kv%%:*}\": ${kv##*:}}" >"$out/${kv/:/=}.json"
  settings+=("${kv/:/=}|--data-config $out/${kv/:/=}.json")
done
for kv in accept-probability:0.98 accept-probability:0.995 confirmed-max-misses:6 confirmed-max-misses:10 \
  provisional-max-misses:2 provisional-max-misses:4 confirm-after:2 confirm-after:4 view-margin-m:1.5 view-margin-m:2.5; do
  settings+=("${kv/:/=}|--${kv%%:*} ${kv##*:}")
done

filter_args() {
  case $1 in
    ukf) echo "--filter ukf --ukf-noise augmented" ;;
    ukf-additive) echo "--filter ukf --ukf-noise additive" ;;
    *) echo "--filter ekf --threads 1 --ekf-variant $1" ;;
  esac
}

one_run() {  # label, variant, options...
  local label=$1 variant=$2
  shift 2
  [[ -f $out/$label-$variant/metrics.json ]] && return 0
  # shellcheck disable=SC2068
  # shellcheck disable=SC2086,SC2046  # the extra options are words
  "$slamkit" run --quiet $(filter_args "$variant") --assoc jcbb --data victoria-park $run_args $@ \
    --out "$out/$label-$variant" >/dev/null
}
export -f one_run filter_args
export slamkit out run_args
for s in "${settings[@]}"; do
  for v in $variants; do echo "${s%%|*} $v ${s#*|}"; done
done | xargs -P "$jobs" -I{} bash -c 'set -euo pipefail; one_run {}'

ate() { jq -r '.ate_rmse_m' "$out/$1-$2/metrics.json"; }
header="| setting |" rule="|---|"
for v in $variants; do header+=" $v ATE [m] |"; rule+="---|"; done
for v in $variants; do [[ $v == full ]] || { header+=" $v / full |"; rule+="---|"; }; done
echo "$header"
echo "$rule"
for s in "${settings[@]}"; do
  label=${s%%|*} row="| $label |"
  for v in $variants; do row+=" $(printf '%.3f' "$(ate "$label" "$v")") |"; done
  for v in $variants; do
    [[ $v == full ]] || row+=" $(awk -v a="$(ate "$label" "$v")" -v b="$(ate "$label" full)" 'BEGIN { printf "%.2f", a / b }') |"
  done
  echo "$row"
done
