#!/usr/bin/env bash
# Data association where it is hard, as a Markdown table: the `sparse` and `sparse-cluttered`
# scenarios over several seeds, for EKF-SLAM with nearest neighbour and with JCBB and for FastSLAM
# 1.0 and 2.0 (nearest neighbour per particle), all without identities. Per scenario and filter:
# loops closed (metrics.json "loop_closed": loop_closure_fraction at least 0.8, see README), the
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

runs=("ekf:nn" "ekf:jcbb" "fastslam1:nn" "fastslam2:nn")
for scenario in sparse sparse-cluttered; do
  for seed in $seeds; do
    log=$out/$scenario/log-$seed
    "$slamkit" simulate --scenario "$scenario" --seed "$seed" --out "$log" > /dev/null
    for run in "${runs[@]}"; do
      filter=${run%%:*} assoc=${run##*:}
      "$slamkit" run --filter "$filter" --assoc "$assoc" --data "sim:$log" --seed "$seed" \
        --particles "$particles" --threads "$threads" --out "$out/$scenario/$filter-$assoc-$seed" > /dev/null
    done
  done
done

python3 - "$out" "${runs[@]}" <<'EOF'
import json, statistics, sys
from pathlib import Path

out, runs = Path(sys.argv[1]), sys.argv[2:]
def span(values, fmt="{:g}"):
    return f"{fmt.format(statistics.median(values))} [{fmt.format(min(values))}-{fmt.format(max(values))}]"
print("| scenario | filter | loops closed | loop_closure_fraction | wrong pairings | spurious landmarks | ATE [m] mean | pose NEES median |")
print("|---|---|---|---|---|---|---|---|")
for scenario in ["sparse", "sparse-cluttered"]:
    for run in runs:
        filter, assoc = run.split(":")
        metrics = [json.loads(p.read_text()) for p in sorted((out / scenario).glob(f"{filter}-{assoc}-*/metrics.json"))]
        if not metrics:
            continue
        fractions = [m["loop_closure_fraction"] or 0.0 for m in metrics]
        print(f"| {scenario} | {filter} {assoc} | {sum(bool(m['loop_closed']) for m in metrics)}/{len(metrics)} "
              f"| {span(fractions, '{:.2f}')} | {span([m['association_wrong'] for m in metrics])} "
              f"| {span([m['spurious_landmarks'] for m in metrics])} "
              f"| {statistics.mean(m['ate_rmse_m'] for m in metrics):.2f} "
              f"| {statistics.median(m['nees_pose_mean'] for m in metrics):.3g} |")
EOF
