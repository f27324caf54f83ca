#!/usr/bin/env bash
# The association table (scripts/association_table.sh) over worlds of the families `sparse` and
# `sparse-cluttered` (docs/world-families.md), one world per seed and one run per world and filter:
# EKF nn, EKF jcbb, EKF jcbb with config/association-cluttered.json, the FEJ iterated EKF with that
# file, FastSLAM 1.0 nn and FastSLAM 2.0 nn (100 particles), and the two FastSLAMs told to expect a
# false detection per scan (FastSLAM 2.0 with --pose-sample-fraction 0.01), all without identities.
#
# The split: settings are chosen on the tuning worlds and reported on the test worlds, which nothing
# is tuned on.
#   SPLIT=tuning   world seeds 1-20 (the default)
#   SPLIT=test     world seeds 101-120
# Environment: SPLIT, WORLDS (world seeds, overriding the split's, e.g. "$(seq 1 10)"), FAMILIES
# (default "sparse sparse-cluttered"), JOBS (default 2), OUT (default out/world-family-table/SPLIT),
# and FILTERS, THREADS, PARTICLES, SUMMARY_ONLY, SLAMKIT as association_table.sh reads them.
# One row again, e.g.: FAMILIES=sparse-cluttered FILTERS="fastslam2 nn" scripts/world_family_table.sh
set -euo pipefail

split=${SPLIT:-tuning}
case $split in
  tuning) split_worlds=$(seq 1 20) ;;
  test) split_worlds=$(seq 101 120) ;;
  *) echo "world_family_table.sh: SPLIT must be tuning or test, found '$split'" >&2; exit 1 ;;
esac
scenarios=
for family in ${FAMILIES:-sparse sparse-cluttered}; do scenarios+="family:$family "; done

SCENARIOS=$scenarios \
SEEDS=${WORLDS:-$split_worlds} \
FILTERS=${FILTERS:-ekf nn; ekf jcbb; ekf jcbb cluttered; ekf jcbb fej iterated cluttered; fastslam1 nn; fastslam2 nn; fastslam1 nn clutter; fastslam2 nn clutter 0.01} \
JOBS=${JOBS:-2} \
OUT=${OUT:-out/world-family-table/$split} \
  exec "$(dirname "$0")/association_table.sh"
