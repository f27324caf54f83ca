#!/usr/bin/env bash
# Data association where it is hard, as a Markdown table: worlds (built-in scenarios, by default
# `sparse` and `sparse-cluttered` over several seeds, or worlds of a family) x filters: EKF-SLAM with
# nearest neighbour and with JCBB, FastSLAM 1.0 and 2.0 (nearest neighbour per particle), all
# without identities, and the EKF with JCBB with the settings of config/association-cluttered.json,
# alone and as recommended for cluttered worlds (with first-estimates Jacobians and iterated
# updates). Per world set and filter: loops closed (metrics.json "loop_closed": loop_closure_fraction
# at least 0.8, see docs/metrics.md), the median and range of loop_closure_fraction and of wrong pairings, spurious
# landmarks (runs with none / sum / largest), the mean ATE of the per-step estimates, the median pose
# NEES and the mean time of a run (filter, evaluation and files). Every run's figures also go to
# $OUT/runs.csv.
#
# Environment:
#   SCENARIOS     world sets, space-separated (default "sparse sparse-cluttered"): a built-in scenario
#                 NAME, simulated with each seed of SEEDS as its noise seed; or family:NAME, the world
#                 of each seed of SEEDS from that family (docs/world-families.md), noise seed 1
#   SEEDS         default "1 2 3 4 5 6 7 8 9 10" (settings are chosen on other seeds, e.g. 101-110;
#                 scripts/world_family_table.sh holds the families' split)
#   FILTERS       ';'-separated: labels of the table below, or LABEL=RUN OPTIONS for a setting of your
#                 own (e.g. "fastslam2 nn; mine=--filter ekf --assoc-config my.json"); default all
#   JOBS          runs at a time (default 1), through xargs -P
#   THREADS       threads per run (default 2 / JOBS, at least 1); PARTICLES (default 100)
#   SUMMARY_ONLY  1: print the table and write the CSV from the runs already in OUT, run nothing
#   SLAMKIT (default build/slamkit), OUT (scratch folder, default out/association-table)
# Rerunning one row (one world set and one filter) reruns only its runs; SUMMARY_ONLY=1 with every
# filter then prints the whole table again. Needs python3 for the summary.
set -euo pipefail

slamkit=${SLAMKIT:-build/slamkit}
scenarios=${SCENARIOS:-sparse sparse-cluttered}
seeds=${SEEDS:-1 2 3 4 5 6 7 8 9 10}
particles=${PARTICLES:-100}
jobs=${JOBS:-1}
threads=${THREADS:-$(( jobs >= 2 ? 1 : 2 / jobs ))}
out=${OUT:-out/association-table}

die() { echo "association_table.sh: $*" >&2; exit 1; }
[[ $jobs =~ ^[1-9][0-9]*$ ]] || die "JOBS must be a positive integer, found '$jobs'"
[[ -x $slamkit ]] || die "no slamkit binary at $slamkit (run make build, or set SLAMKIT)"
command -v python3 > /dev/null || die "python3 is needed for the summary"

config_dir=$(cd "$(dirname "$0")/../config" && pwd)
# label=run options. The EKF ignores --seed and --particles, so they are given to the particle
# filters only.
known=("ekf nn=--filter ekf --assoc nn"
       "ekf jcbb=--filter ekf --assoc jcbb"
       "ekf jcbb fej iterated=--filter ekf --assoc jcbb --ekf-variant fej --ekf-update iterated"
       "ekf jcbb cluttered=--filter ekf --assoc-config $config_dir/association-cluttered.json"
       "ekf jcbb fej iterated cluttered=--filter ekf --ekf-variant fej --ekf-update iterated --assoc-config $config_dir/association-cluttered.json"
       "fastslam1 nn=--filter fastslam1 --assoc nn --particles $particles"
       "fastslam2 nn=--filter fastslam2 --assoc nn --particles $particles"
       "fastslam1 nn clutter=--filter fastslam1 --assoc nn --clutter-per-scan 1 --particles $particles"
       "fastslam2 nn clutter 0.01=--filter fastslam2 --assoc nn --clutter-per-scan 1 --pose-sample-fraction 0.01 --particles $particles"
       "fastslam1 jcbb=--filter fastslam1 --assoc jcbb --particles $particles"
       "fastslam2 jcbb=--filter fastslam2 --assoc jcbb --particles $particles"
       "fastslam2 jcbb clutter 0.01=--filter fastslam2 --assoc jcbb --clutter-per-scan 1 --pose-sample-fraction 0.01 --particles $particles")
runs=()
if [[ -z ${FILTERS:-} ]]; then
  runs=("${known[@]}")
else
  IFS=';' read -ra wanted <<< "$FILTERS"
  for item in "${wanted[@]}"; do
    item=$(sed 's/^ *//; s/ *$//' <<< "$item")
    [[ -z $item ]] && continue
    if [[ $item == *=* ]]; then runs+=("$item"); continue; fi
    found=
    for run in "${known[@]}"; do [[ ${run%%=*} == "$item" ]] && found=$run; done
    [[ -n $found ]] || die "unknown filter '$item'; expected one of: $(printf '%s; ' "${known[@]%%=*}")or LABEL=OPTIONS"
    runs+=("$found")
  done
fi

# A world set's folder: family:NAME runs go to family-NAME.
folder() { echo "$out/${1/:/-}"; }

if [[ ${SUMMARY_ONLY:-0} != 1 ]]; then
  # One tab-separated line per job; a log is simulated once for all its runs.
  sims=() jobs_list=()
  for scenario in $scenarios; do
    for seed in $seeds; do
      log=$(folder "$scenario")/log-$seed
      if [[ $scenario == family:* ]]; then
        sims+=("$log"$'\t'"--family ${scenario#family:} --world-seed $seed --seed 1")
      else
        sims+=("$log"$'\t'"--scenario $scenario --seed $seed")
      fi
      for run in "${runs[@]}"; do
        label=${run%%=*} options="${run#*=} --threads $threads"
        [[ $options == *fastslam* ]] && options+=" --seed $seed"
        jobs_list+=("$log"$'\t'"$(folder "$scenario")/${label// /-}-$seed"$'\t'"$options")
      done
    done
  done
  export slamkit
  simulate_one() {
    IFS=$'\t' read -r log options <<< "$1"
    # shellcheck disable=SC2086  # the options are words
    "$slamkit" simulate $options --out "$log" > /dev/null
  }
  # A failed run (a diverged filter exits 3 after writing its folder) is reported, not fatal: the
  # summary counts the runs it finds.
  run_one() {
    IFS=$'\t' read -r log dir options <<< "$1"
    local start=$EPOCHREALTIME status=0
    # shellcheck disable=SC2086
    "$slamkit" run $options --data "sim:$log" --quiet --out "$dir" || status=$?
    awk -v a="$start" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.2f\n", b - a }' > "$dir.elapsed_s"
    (( status == 0 )) || echo "association_table.sh: $dir: slamkit run exited $status" >&2
  }
  export -f simulate_one run_one
  # shellcheck disable=SC2016  # $1, the job's line, is for the inner bash to expand
  printf '%s\n' "${sims[@]}" | xargs -d '\n' -n 1 -P "$jobs" bash -c 'simulate_one "$1"' _
  # shellcheck disable=SC2016
  printf '%s\n' "${jobs_list[@]}" | xargs -d '\n' -n 1 -P "$jobs" bash -c 'run_one "$1"' _
fi

python3 - "$out" "$scenarios" "$seeds" "${runs[@]%%=*}" <<'EOF'
import csv, json, statistics, sys
from pathlib import Path

out, scenarios, seeds, labels = Path(sys.argv[1]), sys.argv[2].split(), sys.argv[3].split(), sys.argv[4:]
def span(values, fmt="{:g}"):
    return f"{fmt.format(statistics.median(values))} [{fmt.format(min(values))}-{fmt.format(max(values))}]"
columns = ["scenario", "seed", "filter", "loop_closed", "loop_closure_fraction", "spurious_landmarks",
           "association_wrong", "ate_rmse_m", "nees_pose_mean", "landmarks", "elapsed_s"]
rows = []
print("| scenario | filter | loops closed | loop_closure_fraction | wrong pairings | spurious landmarks: runs with 0 / sum / max | ATE [m] mean | pose NEES median | s per run |")
print("|---|---|---|---|---|---|---|---|---|")
for scenario in scenarios:
    folder = out / scenario.replace(":", "-", 1)
    for label in labels:
        metrics, elapsed = [], []
        for seed in seeds:
            run = folder / f"{label.replace(' ', '-')}-{seed}"
            if not (run / "metrics.json").exists():
                continue
            m = json.loads((run / "metrics.json").read_text())
            t = Path(f"{run}.elapsed_s")
            e = float(t.read_text()) if t.exists() else None
            metrics.append(m)
            if e is not None:
                elapsed.append(e)
            figures = {k: m.get(k) for k in columns if k not in ("scenario", "seed", "filter", "elapsed_s")}
            rows.append({"scenario": scenario, "seed": seed, "filter": label, "elapsed_s": e,
                         **{k: json.dumps(v) if isinstance(v, bool) else v for k, v in figures.items()}})
        if not metrics:
            continue
        missing = f" (of {len(seeds)})" if len(metrics) < len(seeds) else ""
        spurious = [m["spurious_landmarks"] for m in metrics]
        fractions = [m["loop_closure_fraction"] or 0.0 for m in metrics]
        print(f"| {scenario} | {label} | {sum(bool(m['loop_closed']) for m in metrics)}/{len(metrics)}{missing} "
              f"| {span(fractions, '{:.2f}')} | {span([m['association_wrong'] for m in metrics])} "
              f"| {sum(s == 0 for s in spurious)}/{len(spurious)} / {sum(spurious)} / {max(spurious)} "
              f"| {statistics.mean(m['ate_rmse_m'] for m in metrics):.2f} "
              f"| {statistics.median(m['nees_pose_mean'] for m in metrics):.3g} "
              f"| {f'{statistics.mean(elapsed):.1f}' if elapsed else '-'} |")
out.mkdir(parents=True, exist_ok=True)
with open(out / "runs.csv", "w", newline="") as f:
    writer = csv.DictWriter(f, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
EOF
