"""The Python module against the CLI: the same dataset and seed give the same numbers to the last
digit; stepping a filter event by event ends where a whole run does; states, covariances and maps
come out as arrays of the right shapes; bad settings raise; the plotting example runs."""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

import slamkit

CLI = os.environ["SLAMKIT_CLI"]
SOURCE = os.environ["SLAMKIT_SOURCE_DIR"]
# A sanitized build preloads the sanitizer's runtime for the interpreter (CMakeLists.txt); the command
# line links its own, and refuses to start with a second one.
CLI_ENV = {name: value for name, value in os.environ.items() if name != "LD_PRELOAD"}


@pytest.fixture(scope="module")
def sim(tmp_path_factory):
    work = tmp_path_factory.mktemp("sim")
    subprocess.run([CLI, "simulate", "--seed", "4", "--out", str(work / "sim")], check=True, capture_output=True,
                   env=CLI_ENV)
    return work


def cli_metrics(work, name, args):
    subprocess.run([CLI, "run", "--data", f"sim:{work / 'sim'}", "--out", str(work / name), "--quiet", *args],
                   check=True, capture_output=True, env=CLI_ENV)
    with open(work / name / "metrics.json") as f:
        return json.load(f)


# Run-specific (time, the dataset as spelt) or not metrics of the run at all.
IGNORED = {"wall_time_s", "dataset", "metric_definitions"}


@pytest.mark.parametrize("name,args,settings", [
    ("ekf", ["--filter", "ekf"], {"filter": "ekf"}),
    ("fastslam2", ["--filter", "fastslam2", "--particles", "20", "--seed", "7", "--assoc", "nn"],
     {"filter": "fastslam2", "particles": 20, "seed": 7, "association": {"method": "nn"}}),
])
def test_python_matches_the_cli_to_the_last_digit(sim, name, args, settings):
    expected = cli_metrics(sim, name, args)
    dataset = slamkit.load_dataset(f"sim:{sim / 'sim'}")
    got = slamkit.evaluate(slamkit.run(dataset, settings), dataset)
    assert {k: v for k, v in got.items() if k not in IGNORED} == \
        {k: v for k, v in expected.items() if k not in IGNORED}
    assert isinstance(got["ate_rmse_m"], float) and got["ate_rmse_m"] > 0


def test_stepping_ends_where_a_whole_run_ends(sim):
    dataset = slamkit.load_dataset(f"sim:{sim / 'sim'}")
    settings = {"filter": "fastslam1", "particles": 10, "seed": 3}
    stepped = slamkit.Filter(dataset, settings)
    kinds = []
    while (kind := stepped.step()) is not None:
        kinds.append(kind)
    assert len(kinds) == dataset.events == stepped.events_done
    assert set(kinds) == {"control", "scan"}
    run = slamkit.run(dataset, settings)
    np.testing.assert_array_equal(stepped.pose, run.filtered[-1, 1:])
    np.testing.assert_array_equal(stepped.map, run.map)
    assert stepped.particles.shape == (10, 4)
    assert abs(stepped.particles[:, 3].sum() - 1.0) < 1e-9


def test_ekf_state_covariance_and_map(sim):
    dataset = slamkit.load_dataset(f"sim:{sim / 'sim'}")
    ekf = slamkit.Filter(dataset)
    for _ in range(400):
        ekf.step()
    n = len(ekf.map)
    assert n > 0
    assert ekf.state.shape == (3 + 2 * n,)
    assert ekf.covariance.shape == (3 + 2 * n, 3 + 2 * n)
    np.testing.assert_allclose(ekf.covariance, ekf.covariance.T, atol=0)
    assert np.linalg.eigvalsh(ekf.covariance).min() > -1e-9
    np.testing.assert_array_equal(ekf.state[:3], ekf.pose)
    np.testing.assert_array_equal(ekf.state[3:5], ekf.map[0, 1:])
    assert ekf.map_covariances.shape == (n, 2, 2)
    assert ekf.particles.shape == (0, 4)


def test_bad_settings_raise_with_the_libraries_message(sim):
    dataset = slamkit.load_dataset(f"sim:{sim / 'sim'}")
    with pytest.raises(ValueError, match="particles must be an integer from 1 to 1000000"):
        slamkit.Filter(dataset, {"filter": "fastslam1", "particles": 0})
    with pytest.raises(ValueError, match="unknown key 'particle'"):
        slamkit.run(dataset, {"particle": 5})
    with pytest.raises(ValueError, match="unknown dataset kind"):
        slamkit.load_dataset("nowhere:x")


def test_the_plotting_example_runs(sim, tmp_path):
    out = tmp_path / "run.png"
    result = subprocess.run([sys.executable, os.path.join(SOURCE, "examples", "python", "plot_run.py"),
                             f"sim:{sim / 'sim'}", str(out), '{"filter": "ekf"}'],
                            capture_output=True, text=True, env=os.environ)
    assert result.returncode == 0, result.stderr
    assert "ATE RMSE" in result.stdout
    assert out.stat().st_size > 10000
