#!/usr/bin/env bash
# Data association where it is hard, as a Markdown table: the `sparse` and `sparse-cluttered`
# scenarios over several seeds, for EKF-SLAM with nearest neighbour and with JCBB and for FastSLAM
# 1.0 and 2.0 (nearest neighbour per particle), all without identities, and the EKF with JCBB
# with the settings of config/association-cluttered.json, alone and as recommended for cluttered
# worlds (with first-estimates Jacobians and iterated updates). Per scenario and filter:
# loops closed (metrics.json "loop_closed": loop_closure_fraction at least 0.8, see docs/metrics.md), the
# median and range of loop_closure_fraction, wrong pairings and spurious landmarks, the mean ATE of
# the per-step estimates and the median pose NEES.
#
# Environment: SLAMKIT (default build/slamkit), SEEDS (default "1 2 3 4 5 6 7 8 9 10"; the test
# seeds: settings are chosen on others, e.g. 101-110), PARTICLES (default 100), THREADS (default 2),
# OUT (scratch folder, default out/association-table). Needs python3 for the summary.
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
seeds=${SEEDS:-1 2 3 4 5 6 7 8 9 10}
particles=${PARTICLES:-100}
threads=${THREADS:-2}
out=${OUT:-out/association-table}

die() { echo "association_table.sh: $*" >&2; exit 1; }
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (run make build, or set SLAMKIT)"
command -v python3 > /dev/null || die "python3 is needed for the summary"

config_dir=$(cd "$(dirname "$0")/../config" && pwd)
# label=run options; the EKF ignores --seed and --particles, so they are given to the particle filters only.
runs=("ekf nn=--filter ekf --assoc nn"
      "ekf jcbb=--filter ekf --assoc jcbb"
      "ekf jcbb fej iterated=--filter ekf --assoc jcbb --ekf-variant fej --ekf-update iterated"
      "ekf jcbb cluttered=--filter ekf --assoc-config $config_dir/association-cluttered.json"
      "ekf jcbb fej iterated cluttered=--filter ekf --ekf-variant fej --ekf-update iterated --assoc-config $config_dir/association-cluttered.json"
      "fastslam1 nn=--filter fastslam1 --assoc nn --particles $particles --threads $threads"
      "fastslam2 nn=--filter fastslam2 --assoc nn --particles $particles --threads $threads")
for scenario in sparse sparse-cluttered; do
  for seed in $seeds; do
    log=$out/$scenario/log-$seed
    "$slamkit" simulate --scenario "$scenario" --seed "$seed" --out "$log" > /dev/null
    for run in "${runs[@]}"; do
      label=${run%%=*} options=${run#*=}
      extra=()
      [[ $options == *fastslam* ]] && extra=(--seed "$seed")
      # shellcheck disable=SC2086  # the options are words
      "$slamkit" run $options "${extra[@]}" --data "sim:$log" --quiet --out "$out/$scenario/${label// /-}-$seed"
    done
  done
done

python3 - "$out" "${runs[@]%%=*}" <<'EOF'
import json, statistics, sys
from pathlib import Path

out, runs = Path(sys.argv[1]), sys.argv[2:]
def span(values, fmt="{:g}"):
    return f"{fmt.format(statistics.median(values))} [{fmt.format(min(values))}-{fmt.format(max(values))}]"
print("| scenario | filter | loops closed | loop_closure_fraction | wrong pairings | spurious landmarks | ATE [m] mean | pose NEES median |")
print("|---|---|---|---|---|---|---|---|")
for scenario in ["sparse", "sparse-cluttered"]:
    for label in runs:
        metrics = [json.loads(p.read_text()) for p in sorted((out / scenario).glob(f"{label.replace(' ', '-')}-[0-9]*/metrics.json"))]
        if not metrics:
            continue
        fractions = [m["loop_closure_fraction"] or 0.0 for m in metrics]
        print(f"| {scenario} | {label} | {sum(bool(m['loop_closed']) for m in metrics)}/{len(metrics)} "
              f"| {span(fractions, '{:.2f}')} | {span([m['association_wrong'] for m in metrics])} "
              f"| {span([m['spurious_landmarks'] for m in metrics])} "
              f"| {statistics.mean(m['ate_rmse_m'] for m in metrics):.2f} "
              f"| {statistics.median(m['nees_pose_mean'] for m in metrics):.3g} |")
EOF
