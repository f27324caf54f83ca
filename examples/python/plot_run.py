#!/usr/bin/python3
"""Runs a filter on a dataset from Python, steps it to show the map growing, and plots the result
with matplotlib: the true and estimated paths, the map with 2-sigma ellipses, and the pose error
with the filter's 2-sigma band.

    plot_run.py DATASET OUT.png [SETTINGS_JSON]

e.g. plot_run.py sim:out/demo/sim run.png '{"filter": "fastslam2", "particles": 50}'
(the module is built into <build>/python: PYTHONPATH=build/python).
"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Ellipse  # noqa: E402

import slamkit  # noqa: E402


def ellipse(mean, cov, sigmas=2.0, **style):
    values, vectors = np.linalg.eigh(cov)
    angle = np.degrees(np.arctan2(vectors[1, 1], vectors[0, 1]))
    width, height = 2 * sigmas * np.sqrt(np.maximum(values[::-1], 0))
    return Ellipse(mean, width, height, angle=angle, fill=False, **style)


def main(argv):
    if len(argv) not in (3, 4):
        print(__doc__, file=sys.stderr)
        return 2
    dataset = slamkit.load_dataset(argv[1])
    settings = json.loads(argv[3]) if len(argv) == 4 else {}

    # Stepping a filter by hand: how many landmarks it holds after each scan.
    stepped = slamkit.Filter(dataset, settings)
    growth = []
    while (kind := stepped.step()) is not None:
        if kind == "scan":
            growth.append(len(stepped.map))

    run = slamkit.run(dataset, settings)
    metrics = slamkit.evaluate(run, dataset)
    print(f"{run.filter} on {dataset.name}: ATE RMSE {metrics.get('ate_rmse_m', float('nan')):.4f} m, "
          f"{len(run.map)} landmarks")

    fig, (ax_map, ax_err, ax_growth) = plt.subplots(1, 3, figsize=(15, 5))
    truth = dataset.truth_poses
    if len(truth):
        ax_map.plot(truth[:, 1], truth[:, 2], color="0.6", label="truth")
    ax_map.plot(run.trajectory[:, 1], run.trajectory[:, 2], color="tab:orange", label="estimate")
    if len(dataset.truth_landmarks):
        ax_map.scatter(dataset.truth_landmarks[:, 1], dataset.truth_landmarks[:, 2], s=8, color="0.4",
                       marker="s", label="true landmarks")
    ax_map.scatter(run.map[:, 1], run.map[:, 2], s=8, color="tab:blue", label="map")
    for lm, cov in zip(run.map, run.map_covariances):
        ax_map.add_patch(ellipse(lm[1:3], cov, color="tab:blue", linewidth=0.6))
    ax_map.set_aspect("equal")
    ax_map.legend(loc="best", fontsize=8)
    ax_map.set_title("map and paths (2-sigma ellipses)")

    if len(truth):
        filtered = run.filtered
        true_x = np.interp(filtered[:, 0], truth[:, 0], truth[:, 1])
        sigma_x = np.sqrt(run.pose_covariances[:, 0, 0])
        ax_err.fill_between(filtered[:, 0], -2 * sigma_x, 2 * sigma_x, color="tab:blue", alpha=0.2,
                            label="2-sigma")
        ax_err.plot(filtered[:, 0], filtered[:, 1] - true_x, color="tab:blue", label="x error")
        ax_err.legend(fontsize=8)
    ax_err.set_title("pose error x [m]")
    ax_err.set_xlabel("t [s]")

    ax_growth.plot(growth)
    ax_growth.set_title("landmarks in the map")
    ax_growth.set_xlabel("scan")
    fig.tight_layout()
    fig.savefig(argv[2], dpi=80)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
