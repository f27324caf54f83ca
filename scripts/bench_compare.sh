#!/usr/bin/env bash
# slamkit's EKF-SLAM next to MRPT's (mrpt::slam::CRangeBearingKFSLAM2D) on the same simulated logs,
# with known association, as a Markdown table (`make bench-compare`; docs/performance.md explains it).
#
# Worlds: the built-in one (100 landmarks, two laps), and make-world loops driven once (the lap ends
# where it began, so the last part re-observes the first landmarks: a loop closure). WORLDS lists them
# as LANDMARKS:WIDTH:HEIGHT [m]; the default, 1000:360:240, puts 1,000 landmarks within 20 m of a
# 1.2 km route (about 49 observations per scan). Each filter runs RUNS times on each log; the table
# gives median filter times (slamkit: metrics.json "wall_time_s"; MRPT: the processing loop of
# tools/mrpt_compare, log reading excluded) and the accuracy (the same every run). Where MRPT's
# estimate diverges (a non-positive pose variance, then NaN), both ATEs are also given over the scans
# before that.
#
# Environment: SLAMKIT (default build/slamkit), MRPT_TOOL (default build/mrpt_compare/mrpt_ekf_slam),
# RUNS (default 5), OUT (scratch folder, default out/bench-compare), WORLDS (default "1000:360:240";
# "" for the built-in world only; one MRPT run on the 1,000-landmark world takes 10-20 minutes on a
# 2-core machine).
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
tool=${MRPT_TOOL:-build/mrpt_compare/mrpt_ekf_slam}
runs=${RUNS:-5}
out=${OUT:-out/bench-compare}
worlds=${WORLDS-1000:360:240}

die() { echo "bench_compare.sh: $*" >&2; exit 1; }
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (run make build, or set SLAMKIT)"
[[ -x $tool ]] || die "no MRPT comparison tool at $tool (run make bench-compare, or set MRPT_TOOL)"
[[ $runs =~ ^[1-9][0-9]*$ ]] || die "RUNS must be a positive integer, not '$runs'"

mkdir -p "$out"

median() { printf '%s\n' "$@" | sort -g | sed -n "$(( ($# + 1) / 2 ))p"; }
# A number field of a JSON object by key: metrics.json (one key per line) or the tool's one-line output.
json_number() { grep -o "\"$2\": *[-0-9.eE+]*" "$1" | head -1 | sed 's/.*: *//'; }
# MRPT's ATE, or where its estimate diverged and its ATE before that.
mrpt_ate() {
  local t; t=$(json_number "$1" mrpt_first_invalid_t)
  if [[ -n $t ]]; then
    echo "diverged at t = $t s; $(fmt3 "$(json_number "$1" mrpt_ate_rmse_before_invalid_m)") before"
  else
    fmt3 "$(json_number "$1" mrpt_ate_rmse_m)"
  fi
}
# slamkit's ATE, and over the same scans as MRPT's where MRPT diverged.
slamkit_ate() {
  local all before; all=$(fmt3 "$(json_number "$1" slamkit_ate_rmse_m)")
  before=$(json_number "$1" slamkit_ate_rmse_before_invalid_m)
  if [[ -n $before ]]; then echo "$all; $(fmt3 "$before") before MRPT diverged"; else echo "$all"; fi
}
fmt3() { if [[ -z $1 ]]; then echo "n/a"; else printf '%.3f' "$1"; fi; }

echo "| world | landmarks | scans | slamkit EKF [s] | MRPT EKF [s] | MRPT / slamkit | ATE slamkit [m] | ATE MRPT [m] | map RMSE slamkit [m] | map RMSE MRPT [m] |"
echo "|---|---|---|---|---|---|---|---|---|---|"

# compare LABEL LOG_DIR
compare() {
  local label=$1 log=$2 sk_times=() mrpt_times=() i
  local run="$out/run"
  for ((i = 0; i < runs; ++i)); do
    rm -rf "$run"
    "$slamkit" run --filter ekf --assoc known --data "sim:$log" --out "$run" >/dev/null
    sk_times+=("$(json_number "$run/metrics.json" wall_time_s)")
    "$tool" --data "$log" --slamkit-run "$run" >"$out/mrpt.json" 2>"$out/mrpt.log"
    mrpt_times+=("$(json_number "$out/mrpt.json" mrpt_wall_time_s)")
  done
  local sk mr
  sk=$(median "${sk_times[@]}")
  mr=$(median "${mrpt_times[@]}")
  printf '| %s | %s | %s | %.3f | %.3f | %.1f | %s | %s | %s | %s |\n' "$label" \
    "$(grep -vc "^#" "$log/truth_landmarks.txt")" "$(json_number "$out/mrpt.json" scans)" "$sk" "$mr" \
    "$(awk -v a="$mr" -v b="$sk" 'BEGIN { print a / b }')" \
    "$(slamkit_ate "$out/mrpt.json")" \
    "$(mrpt_ate "$out/mrpt.json")" \
    "$(fmt3 "$(json_number "$out/mrpt.json" slamkit_map_rmse_m)")" \
    "$(fmt3 "$(json_number "$out/mrpt.json" mrpt_map_rmse_m | grep -v nan)")"
}

"$slamkit" simulate --seed 1 --out "$out/sim-default" >/dev/null
compare "built-in, 2 laps" "$out/sim-default"

for world in $worlds; do
  IFS=: read -r n w h <<<"$world"
  [[ $n =~ ^[1-9][0-9]*$ && $w =~ ^[1-9][0-9]*$ && $h =~ ^[1-9][0-9]*$ ]] ||
    die "WORLDS entries are LANDMARKS:WIDTH:HEIGHT with positive integers, not '$world'"
  "$slamkit" make-world --landmarks "$n" --width "$w" --height "$h" --out "$out/world-$n.txt" >/dev/null
  "$slamkit" simulate --world "$out/world-$n.txt" --loops 1 --seed 1 --out "$out/sim-$n" >/dev/null
  compare "make-world ${w} x ${h} m, 1 lap" "$out/sim-$n"
done
