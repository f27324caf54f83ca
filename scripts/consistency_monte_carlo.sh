#!/usr/bin/env bash
# Monte Carlo consistency of the Gaussian filters: RUNS logs of one world that differ only in their
# noise seed, each run by the plain EKF, the UKF, the first-estimates-Jacobians EKF and the invariant
# EKF with known association. Prints a markdown table of the means over the runs of: pose NEES,
# share of steps inside the 95% NEES interval, ATE and wall time; and draws each filter's NEES
# averaged over the runs, with the interval of an N-run mean (OUT/nees_<filter>.svg).
#
# Usage: scripts/consistency_monte_carlo.sh default|sparse|WORLD_FILE [simulate options...]
#   e.g. scripts/consistency_monte_carlo.sh w1k.txt --config fov150.json --loops 1
# Environment: SLAMKIT (the binary, default build/slamkit), RUNS (default 50), JOBS (parallel runs,
# default 2), OUT (scratch folder, default out/consistency-<world>), FILTERS (default
# "ekf ukf fej fej-iterated invariant invariant-iterated"; also ekf-iterated, ukf-additive (the UKF
# with --ukf-noise additive), the information filters eif, seif, seif-exact (--seif-covariance exact)
# and eseif, and the thin junction tree filter tjtf), FIRST_SEED (default 1:
# seeds FIRST_SEED .. FIRST_SEED + RUNS - 1; choices are made on other seeds than the table's).
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
runs=${RUNS:-50}
jobs=${JOBS:-2}
filters=${FILTERS:-ekf ukf fej fej-iterated invariant invariant-iterated}
first_seed=${FIRST_SEED:-1}
die() { echo "consistency_monte_carlo.sh: $*" >&2; exit 1; }
[[ $# -ge 1 ]] || die "usage: $0 default|sparse|WORLD_FILE [simulate options...]"
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (set SLAMKIT)"
[[ $runs =~ ^[1-9][0-9]*$ ]] || die "RUNS must be a positive integer, not '$runs'"
[[ $first_seed =~ ^[0-9]+$ ]] || die "FIRST_SEED must be a non-negative integer, not '$first_seed'"
seeds=$(seq "$first_seed" $((first_seed + runs - 1)))
command -v jq >/dev/null || die "jq not found (Debian package 'jq')"
world=$1
shift
if [[ -f $world ]]; then source_args=(--world "$world"); name=$(basename "$world" .txt); else source_args=(--scenario "$world"); name=$world; fi
out=${OUT:-out/consistency-$name}
mkdir -p "$out"

filter_args() {
  case $1 in
    ekf) echo "--filter ekf" ;;
    ukf) echo "--filter ukf" ;;
    ukf-additive) echo "--filter ukf --ukf-noise additive" ;;
    fej) echo "--filter ekf --ekf-variant fej" ;;
    fej-iterated) echo "--filter ekf --ekf-variant fej --ekf-update iterated" ;;
    invariant) echo "--filter ekf --ekf-variant invariant" ;;
    invariant-iterated) echo "--filter ekf --ekf-variant invariant --ekf-update iterated" ;;
    ekf-iterated) echo "--filter ekf --ekf-update iterated" ;;
    eif) echo "--filter eif" ;;
    seif) echo "--filter seif" ;;
    seif-exact) echo "--filter seif --seif-covariance exact" ;;
    eseif) echo "--filter eseif" ;;
    tjtf) echo "--filter tjtf" ;;
    *) die "unknown filter '$1'" ;;
  esac
}

one_seed() {  # simulate seed $1 and run every filter on it; a seed already done is kept
  local seed=$1 sim="$out/sim-$1" f done=1
  for f in $filters; do [[ -f $out/$f-$seed/metrics.json ]] || done=0; done
  [[ $done == 1 ]] && return 0
  "$slamkit" simulate "${source_args[@]}" --seed "$seed" --out "$sim" >/dev/null
  for f in $filters; do
    # shellcheck disable=SC2046
    "$slamkit" run $(filter_args "$f") --assoc known --data "sim:$sim" --out "$out/$f-$seed" >/dev/null
  done
}
export -f one_seed filter_args die
export slamkit out filters
export SOURCE_ARGS="${source_args[*]} $*"
echo "$seeds" | xargs -P "$jobs" -I{} bash -c 'set -euo pipefail; source_args=($SOURCE_ARGS); one_seed {}' 

echo "| filter | runs | mean pose NEES | steps in 95% band | ATE [m] | time [s] |"
echo "|---|---|---|---|---|---|"
for f in $filters; do
  files=()
  for seed in $seeds; do files+=("$out/$f-$seed/metrics.json"); done
  jq -s -r --arg f "$f" '
    def mean(f): (map(f) | add) / length;
    "| \($f) | \(length) | \(mean(.nees_pose_mean) * 100 | round / 100) | \(mean(.nees_pose_in_95_fraction) * 1000 | round / 10)% | \(mean(.ate_rmse_m) * 1000 | round / 1000) | \(mean(.wall_time_s) * 100 | round / 100) |"' "${files[@]}"
  dirs=()
  for seed in $seeds; do dirs+=("$out/$f-$seed"); done
  "$slamkit" plot-nees "${dirs[@]}" --title "$f on $name: pose NEES averaged over $runs runs" --out "$out/nees_$f.svg" >/dev/null
done
