#!/usr/bin/env bash
# slamkit's EKF-SLAM next to MRPT's (mrpt::slam::CRangeBearingKFSLAM2D) on the same simulated logs,
# with known association, as a Markdown table (`make bench-compare`; docs/performance.md explains it).
#
# Filters: slamkit's full EKF and its compressed EKF (both exact, joint scan updates), and MRPT's two
# update modes, kfEKFNaive (its default, O(n^3) per scan) and kfEKFAlaDavison (scalar sequential
# updates, O(m n^2), its fastest for a large map). Every ratio is taken within this run: MRPT's median
# time over slamkit's median time on the same log.
#
# Worlds: the built-in one (100 landmarks, two laps), and make-world loops driven once (the lap ends
# where it began, so the last part re-observes the first landmarks: a loop closure). WORLDS lists them
# as LANDMARKS:WIDTH:HEIGHT[:BAND[:FOV]] (metres, degrees; band and field of view default to
# make-world's and the simulator's). The default, 1000:880:420:20:150, puts 1,000 landmarks within
# 20 m of a 2.4 km route seen through a 150-degree, 30 m sensor: about 10 observations per scan,
# 4,030 scans. Times: slamkit's metrics.json "wall_time_s" (the filter loop), MRPT's processing loop
# in tools/mrpt_compare (log reading excluded); both one thread. Accuracy is the same every run: ATE
# and map RMSE scored alike for all by tools/mrpt_compare at the scan instants, and the pose NEES
# (slamkit's from metrics.json, every step; MRPT's at the scans while its estimate is valid). Where
# MRPT's estimate diverges (a non-positive pose variance, then NaN), its ATE is given over the scans
# before that, and slamkit's over the same scans too.
#
# Environment: SLAMKIT (default build/slamkit), MRPT_TOOL (default build/mrpt_compare/mrpt_ekf_slam),
# RUNS (slamkit runs per log, default 5), MRPT_RUNS (MRPT runs per mode and log, default RUNS; one
# naive run on the 1,000-landmark world takes 15-20 minutes on a 2-core machine), MRPT_METHODS
# (default "davison naive"), OUT (scratch folder, default out/bench-compare), WORLDS (default
# "1000:880:420:20:150"; "" for the built-in world only).
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
tool=${MRPT_TOOL:-build/mrpt_compare/mrpt_ekf_slam}
runs=${RUNS:-5}
mrpt_runs=${MRPT_RUNS:-$runs}
methods=${MRPT_METHODS-davison naive}
out=${OUT:-out/bench-compare}
worlds=${WORLDS-1000:880:420:20:150}

die() { echo "bench_compare.sh: $*" >&2; exit 1; }
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (run make build, or set SLAMKIT)"
[[ -x $tool ]] || die "no MRPT comparison tool at $tool (run make bench-compare, or set MRPT_TOOL)"
[[ $runs =~ ^[1-9][0-9]*$ ]] || die "RUNS must be a positive integer, not '$runs'"
[[ $mrpt_runs =~ ^[1-9][0-9]*$ ]] || die "MRPT_RUNS must be a positive integer, not '$mrpt_runs'"
for m in $methods; do [[ $m == naive || $m == davison ]] || die "MRPT_METHODS holds naive and davison, not '$m'"; done

mkdir -p "$out"

median() { printf '%s\n' "$@" | sort -g | sed -n "$(( ($# + 1) / 2 ))p"; }
# A number field of a JSON object by key: metrics.json (one key per line) or the tool's one-line output.
# (metrics.json also describes each key in a string of the same name: those do not match.) Empty,
# not a failure, for a key that is absent or null (pipefail would otherwise end the script there).
json_number() { { grep -o "\"$2\": *-\?[0-9][-0-9.eE+]*" "$1" || true; } | head -1 | sed 's/.*: *//'; }
fmt3() { if [[ -z $1 || $1 == nan ]]; then echo "n/a"; else printf '%.3f' "$1"; fi; }
fmt2() { if [[ -z $1 ]]; then echo "n/a"; else printf '%.2f' "$1"; fi; }
percent() { if [[ -z $1 ]]; then echo "n/a"; else awk -v f="$1" 'BEGIN { printf "%.0f%%", 100 * f }'; fi; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", a / b }'; }

echo "| world | filter | median time [s] | runs | MRPT Davison / this | MRPT naive / this | ATE [m] | map RMSE [m] | pose NEES mean | pose NEES in 95% |"
echo "|---|---|---|---|---|---|---|---|---|---|"

# compare LABEL LOG_DIR
compare() {
  local label=$1 log=$2 i variant method
  declare -A time ate map nees_mean nees_in
  for variant in full compressed; do
    local run="$out/run-$variant" times=()
    for ((i = 0; i < runs; ++i)); do
      rm -rf "$run"
      "$slamkit" run --filter ekf --ekf-variant "$variant" --assoc known --threads 1 --data "sim:$log" --out "$run" >/dev/null
      times+=("$(json_number "$run/metrics.json" wall_time_s)")
    done
    time[$variant]=$(median "${times[@]}")
    "$tool" --data "$log" --method none --slamkit-run "$run" >"$out/score.json"
    ate[$variant]=$(fmt3 "$(json_number "$out/score.json" slamkit_ate_rmse_m)")
    map[$variant]=$(fmt3 "$(json_number "$out/score.json" slamkit_map_rmse_m)")
    nees_mean[$variant]=$(fmt2 "$(json_number "$run/metrics.json" nees_pose_mean)")
    nees_in[$variant]=$(percent "$(json_number "$run/metrics.json" nees_pose_in_95_fraction)")
  done
  for method in $methods; do
    local times=()
    for ((i = 0; i < mrpt_runs; ++i)); do
      "$tool" --data "$log" --method "$method" --slamkit-run "$out/run-full" >"$out/mrpt-$method.json" 2>"$out/mrpt-$method.log"
      times+=("$(json_number "$out/mrpt-$method.json" mrpt_wall_time_s)")
    done
    local json="$out/mrpt-$method.json" invalid
    time[$method]=$(median "${times[@]}")
    invalid=$(json_number "$json" mrpt_first_invalid_t)
    if [[ -n $invalid ]]; then
      ate[$method]="diverged at t = $invalid s; $(fmt3 "$(json_number "$json" mrpt_ate_rmse_before_invalid_m)") before"
      map[$method]="n/a"
      ate[full]+="; $(fmt3 "$(json_number "$json" slamkit_ate_rmse_before_invalid_m)") before t = $invalid s"
    else
      ate[$method]=$(fmt3 "$(json_number "$json" mrpt_ate_rmse_m)")
      map[$method]=$(fmt3 "$(json_number "$json" mrpt_map_rmse_m)")
    fi
    nees_mean[$method]=$(fmt2 "$(json_number "$json" mrpt_nees_pose_mean)")
    nees_in[$method]=$(percent "$(json_number "$json" mrpt_nees_pose_in_95_fraction)")
  done
  local davison naive name row
  for row in full:"slamkit EKF" compressed:"slamkit compressed EKF" davison:"MRPT kfEKFAlaDavison" naive:"MRPT kfEKFNaive"; do
    variant=${row%%:*} name=${row#*:}
    [[ -n ${time[$variant]:-} ]] || continue
    davison="-" naive="-"
    if [[ $variant == full || $variant == compressed ]]; then
      [[ -n ${time[davison]:-} ]] && davison=$(ratio "${time[davison]}" "${time[$variant]}")
      [[ -n ${time[naive]:-} ]] && naive=$(ratio "${time[naive]}" "${time[$variant]}")
    fi
    local n=$runs
    [[ $variant == davison || $variant == naive ]] && n=$mrpt_runs
    printf '| %s | %s | %.3f | %s | %s | %s | %s | %s | %s | %s |\n' "$label" "$name" "${time[$variant]}" "$n" \
      "$davison" "$naive" "${ate[$variant]}" "${map[$variant]}" "${nees_mean[$variant]}" "${nees_in[$variant]}"
  done
}

"$slamkit" simulate --seed 1 --out "$out/sim-default" >/dev/null
compare "built-in, 2 laps" "$out/sim-default"

for world in $worlds; do
  IFS=: read -r n w h band fov <<<"$world"
  [[ $n =~ ^[1-9][0-9]*$ && $w =~ ^[1-9][0-9]*$ && $h =~ ^[1-9][0-9]*$ && ${band:-1} =~ ^[1-9][0-9]*$ &&
     ${fov:-1} =~ ^[1-9][0-9]*$ ]] ||
    die "WORLDS entries are LANDMARKS:WIDTH:HEIGHT[:BAND[:FOV]] with positive integers, not '$world'"
  world_args=(--landmarks "$n" --width "$w" --height "$h")
  [[ -n $band ]] && world_args+=(--band "$band")
  sim_args=(--loops 1 --seed 1)
  if [[ -n $fov ]]; then
    echo "{\"fov_deg\": $fov}" >"$out/sim-$n.json"
    sim_args+=(--config "$out/sim-$n.json")
  fi
  "$slamkit" make-world "${world_args[@]}" --out "$out/world-$n.txt" >/dev/null
  "$slamkit" simulate --world "$out/world-$n.txt" "${sim_args[@]}" --out "$out/sim-$n" >/dev/null
  compare "make-world ${w} x ${h} m${band:+, band $band m}${fov:+, fov $fov deg}, 1 lap" "$out/sim-$n"
done
