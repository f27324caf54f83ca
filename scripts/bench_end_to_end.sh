#!/usr/bin/env bash
# End-to-end timings of `slamkit run`: the whole run as a user sees it (reading the log, the filter,
# evaluation and pictures), on the built-in simulated world and, when the dataset is present, on the
# full Victoria Park run. Each case runs RUNS times; the table on stdout gives the median wall time
# (the machine may be shared, and the median ignores a run slowed by a neighbour), the spread, the
# median peak resident set and the ATE from the run's metrics.json (the same every run: runs are
# deterministic for a seed).
#
# Environment: SLAMKIT (the binary, default build/slamkit), RUNS (default 5), OUT (scratch folder,
# default out/bench-e2e), SLAMKIT_DATA (the folder holding the datasets, default ../shared/datasets).
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
runs=${RUNS:-5}
out=${OUT:-out/bench-e2e}
data=${SLAMKIT_DATA:-../shared/datasets}
time_cmd=/usr/bin/time  # GNU time: the shell keyword cannot report peak RSS

die() { echo "bench_end_to_end.sh: $*" >&2; exit 1; }
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (run make build, or set SLAMKIT)"
[[ -x $time_cmd ]] || die "$time_cmd not found (Debian package 'time'; make deps installs it)"
[[ $runs =~ ^[1-9][0-9]*$ ]] || die "RUNS must be a positive integer, not '$runs'"

mkdir -p "$out"
"$slamkit" simulate --seed 1 --out "$out/sim" >/dev/null
"$slamkit" simulate --seed 1 --no-ids --out "$out/sim-no-ids" >/dev/null

# The middle value of the arguments (the lower middle for an even count).
median() { printf '%s\n' "$@" | sort -g | sed -n "$(( ($# + 1) / 2 ))p"; }

# A number field of a flat JSON object, by key (metrics.json is written one key per line).
json_number() { sed -n "s/^ *\"$2\": *\([-0-9.eE+]*\),\{0,1\}$/\1/p" "$1"; }

echo "| data | filter | association | median wall [s] | min-max [s] | peak RSS [MiB] | ATE RMSE [m] |"
echo "|---|---|---|---|---|---|---|"

# bench DATA_LABEL FILTER_LABEL ASSOC -- slamkit run arguments (without --out)
bench() {
  local data_label=$1 filter_label=$2 assoc=$3
  shift 4
  local dir="$out/run" walls=() rss=() wall kib i
  for ((i = 0; i < runs; ++i)); do
    rm -rf "$dir"
    "$time_cmd" -f "%e %M" -o "$out/time.txt" "$slamkit" run "$@" --assoc "$assoc" --out "$dir" >/dev/null
    read -r wall kib <"$out/time.txt"
    walls+=("$wall")
    rss+=("$kib")
  done
  local ate min max
  ate=$(json_number "$dir/metrics.json" ate_rmse_m)
  min=$(printf '%s\n' "${walls[@]}" | sort -g | head -1)
  max=$(printf '%s\n' "${walls[@]}" | sort -g | tail -1)
  printf '| %s | %s | %s | %.2f | %.2f-%.2f | %.0f | %.3f |\n' "$data_label" "$filter_label" "$assoc" \
    "$(median "${walls[@]}")" "$min" "$max" "$(( $(median "${rss[@]}") / 1024 ))" "$ate"
}

bench "simulated, default world" "EKF-SLAM" known -- --filter ekf --data "sim:$out/sim"
bench "simulated, default world, no ids" "EKF-SLAM" jcbb -- --filter ekf --data "sim:$out/sim-no-ids"
bench "simulated, default world" "FastSLAM 1.0, 100 particles" known -- \
  --filter fastslam1 --particles 100 --data "sim:$out/sim"
bench "simulated, default world" "FastSLAM 2.0, 100 particles" known -- \
  --filter fastslam2 --particles 100 --data "sim:$out/sim"

vp="$data/victoria_park"
if [[ -d $vp ]]; then
  bench "Victoria Park, full run" "EKF-SLAM" jcbb -- --filter ekf --data "victoria-park:$vp"
  bench "Victoria Park, full run" "EKF-SLAM" nn -- --filter ekf --data "victoria-park:$vp"
  # The textbook filter, as timed before the park recommended --pose-sample-fraction 0.01 (whose runs
  # resample less and cost 1.14 times as much: README, Victoria Park).
  bench "Victoria Park, full run" "FastSLAM 2.0, 100 particles" nn -- \
    --filter fastslam2 --particles 100 --pose-sample-fraction 1 --data "victoria-park:$vp"
else
  echo "bench_end_to_end.sh: no Victoria Park data at $vp; simulated cases only" >&2
fi
