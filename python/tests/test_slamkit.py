"""The Python module against the CLI: the same dataset and seed give the same numbers to the last
digit; stepping a filter event by event ends where a whole run does, and shows the time, the scan and
the association decisions the CLI's run folder records; a dataset's events read back as its log
file holds them; a run saved from Python is a run folder the CLI evaluates and repeats; states,
covariances and maps come out as arrays of the right shapes; bad settings raise, None raises
TypeError, a missing NumPy fails at import; help() documents every function and property; the
plotting example runs."""
import json
import os
import pydoc
import subprocess
import sys
import textwrap

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


def cli(*args):
    return subprocess.run([CLI, *map(str, args)], capture_output=True, text=True, env=CLI_ENV)


def cli_metrics(work, name, args, data="sim"):
    subprocess.run([CLI, "run", "--data", f"sim:{work / data}", "--out", str(work / name), "--quiet", *args],
                   check=True, capture_output=True, env=CLI_ENV)
    with open(work / name / "metrics.json") as f:
        return json.load(f)


def read_text(path):
    with open(path) as f:
        return f.read()


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
    assert len(kinds) == len(dataset.events) == stepped.events_done
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


def test_none_and_wrong_types_raise_type_error_not_crash(sim):
    # In a child interpreter: the crash these replace (SIGSEGV) would take pytest down with it.
    script = textwrap.dedent(f"""
        import slamkit
        ds = slamkit.load_dataset("sim:{sim / 'sim'}")
        run = slamkit.run(ds, {{}})
        calls = {{
            "run(None, {{}})": lambda: slamkit.run(None, {{}}),
            "run(None)": lambda: slamkit.run(None),
            "run(str)": lambda: slamkit.run("sim:x", {{}}),
            "run(ds, None)": lambda: slamkit.run(ds, None),
            "Filter(None)": lambda: slamkit.Filter(None),
            "Filter(None, {{}})": lambda: slamkit.Filter(None, {{}}),
            "Filter(ds, None)": lambda: slamkit.Filter(ds, None),
            "evaluate(None)": lambda: slamkit.evaluate(None),
            "evaluate(None, ds)": lambda: slamkit.evaluate(None, ds),
            "evaluate(run, 3)": lambda: slamkit.evaluate(run, 3),
            "load_dataset(None)": lambda: slamkit.load_dataset(None),
            "save(None)": lambda: run.save(None),
        }}
        for name, call in calls.items():
            try:
                call()
                print(name, "returned")
            except Exception as e:
                print(name, type(e).__name__)
        """)
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, env=os.environ)
    assert result.returncode == 0, f"the interpreter died ({result.returncode}): {result.stderr}"
    lines = result.stdout.splitlines()
    assert len(lines) == 12, result.stdout
    for line in lines:
        assert line.endswith(" TypeError"), line


def test_a_missing_numpy_fails_at_import_saying_what_to_install():
    result = subprocess.run([sys.executable, "-c", "import sys; sys.modules['numpy'] = None; import slamkit"],
                            capture_output=True, text=True, env=os.environ)
    assert result.returncode != 0
    assert "ImportError" in result.stderr
    assert "slamkit needs NumPy" in result.stderr and "python3-numpy" in result.stderr, result.stderr


def test_help_documents_every_function_and_property():
    for name in ("load_dataset", "run", "evaluate"):
        assert getattr(slamkit, name).__doc__.strip(), name
    for cls in (slamkit.Dataset, slamkit.Events, slamkit.Event, slamkit.Filter, slamkit.Run):
        assert cls.__doc__ and cls.__doc__.strip(), cls.__name__
        for name, member in vars(cls).items():
            if name.startswith("_"):
                continue
            doc = member.__doc__ or ""
            # pybind11 writes a method's signature first; a property has only the text given.
            text = doc.split("\n", 1)[-1] if doc.startswith(name + "(") else doc
            assert text.strip(), f"{cls.__name__}.{name} has no docstring"
    text = pydoc.render_doc(slamkit, renderer=pydoc.plaintext)
    for phrase in ("[x y theta | m1x m1y | m2x m2y | ...]", "rows id, x [m], y [m]", "shape (n, 2, 2) [m^2]",
                   "rows t [s], x [m], y [m], theta [rad]", "'update'", "range [m], bearing [rad]",
                   "Units: metres, radians, seconds"):
        assert phrase in text, phrase


def sim_log_events(folder):
    """events.txt read as the file says: ("control", t, dt, [speed, steer]) or ("scan", t, [(id, range,
    bearing), ...])."""
    events = []
    for line in read_text(folder / "events.txt").splitlines():
        fields = line.split()
        if not fields or fields[0].startswith("#"):
            continue
        if fields[0] == "control":
            events.append(("control", float(fields[1]), float(fields[2]), [float(v) for v in fields[3:]]))
        elif events and events[-1][0] == "scan" and events[-1][1] == float(fields[1]):
            events[-1][2].append((int(fields[2]), float(fields[3]), float(fields[4])))
        else:
            events.append(("scan", float(fields[1]), [(int(fields[2]), float(fields[3]), float(fields[4]))]))
    return events


def test_dataset_events_are_the_logs_events(sim):
    dataset = slamkit.load_dataset(f"sim:{sim / 'sim'}")
    expected = sim_log_events(sim / "sim")
    events = dataset.events
    assert len(events) == len(expected) > 1000
    assert dataset.motion_model == "ackermann"
    seen = 0
    for i, (event, want) in enumerate(zip(events, expected)):
        seen += 1
        assert event.index == i and event.kind == want[0] and event.t == want[1]
        if event.kind == "control":
            assert event.dt == want[2]
            np.testing.assert_array_equal(event.control, want[3])
            assert event.observations.shape == (0, 2) and event.ids.shape == (0,)
        else:
            assert event.dt is None and event.control is None
            np.testing.assert_array_equal(event.ids, [o[0] for o in want[2]])
            np.testing.assert_array_equal(event.observations, [o[1:] for o in want[2]])
            assert event.ids.dtype.kind == "i"
    assert seen == len(expected)
    assert events[-1].index == len(events) - 1
    assert [e.index for e in events[3:10:2]] == [3, 5, 7, 9]
    with pytest.raises(IndexError):
        events[len(events)]
    # An event keeps its dataset alive, whatever happens to the names that held it.
    last = slamkit.load_dataset(f"sim:{sim / 'sim'}").events[-1]
    assert last.t == expected[-1][1]
    assert "scan" in repr(last) or "control" in repr(last)


def test_stepping_shows_the_time_scan_and_the_decisions_the_run_folder_records(sim):
    subprocess.run([CLI, "simulate", "--seed", "4", "--no-ids", "--out", str(sim / "sim-no-ids")], check=True,
                   capture_output=True, env=CLI_ENV)
    cli_metrics(sim, "nn", ["--assoc", "nn"], data="sim-no-ids")
    recorded = {}
    for line in read_text(sim / "nn" / "associations.txt").splitlines():
        fields = line.split()
        if fields[0].startswith("#") or fields[2] == "none":
            continue
        recorded.setdefault(int(fields[0]), []).append((fields[3], int(fields[4])))

    dataset = slamkit.load_dataset(f"sim:{sim / 'sim-no-ids'}")
    stepped = slamkit.Filter(dataset, {"association": {"method": "nn"}})
    assert stepped.time is None and stepped.last_scan is None and stepped.associations == []
    scans, started = [], set()
    while (kind := stepped.step()) is not None:
        event = dataset.events[stepped.events_done - 1]
        assert stepped.time == event.t
        if kind == "scan":
            scan = stepped.last_scan
            assert scan.index == event.index and len(stepped.associations) == len(scan.observations)
            assert (scan.ids == -1).all()
            scans.append(stepped.associations)
            # A landmark is started once, under a new id, and updated only after that (a relocalised
            # duplicate may leave the state in the same scan, so the state is no reference).
            for decision, landmark in stepped.associations:
                if decision == "new":
                    assert landmark not in started
                    started.add(landmark)
                else:
                    assert landmark in started if decision == "update" else landmark == -1
        else:
            assert stepped.last_scan is None if not scans else stepped.last_scan.index < event.index
    assert {i: a for i, a in enumerate(scans) if a} == recorded
    decisions = {d for scan in scans for d, _ in scan}
    assert {"update", "new"} <= decisions


def test_a_run_saved_from_python_is_a_run_folder_the_cli_evaluates_and_repeats(sim, tmp_path):
    cli_metrics(sim, "ekf-cli", ["--filter", "ekf"])
    dataset = slamkit.load_dataset(f"sim:{sim / 'sim'}")
    run = slamkit.run(dataset, {"filter": "ekf"}, replay=True)
    folder = tmp_path / "from-python"
    metrics = run.save(str(folder))
    assert metrics == slamkit.evaluate(run) == json.loads(read_text(folder / "metrics.json"))
    # The same files as the CLI's folder of the same run; the pictures differ only in the wall time.
    for name in ("trajectory.tum", "pose_covariance.txt", "dead_reckoning.tum", "map.txt", "landmark_std.txt",
                 "associations.txt", "truth.tum"):
        assert read_text(folder / name) == read_text(sim / "ekf-cli" / name), name
    for name in ("map.svg", "landmark_std.svg", "pose_error.svg", "nees.svg", "replay.json", "replay.html"):
        assert (folder / name).exists(), name
    info = json.loads(read_text(folder / "run.json"))
    assert info["front_end"] == "python" and info["python_version"] == sys.version
    assert info["dataset"] == f"sim:{sim / 'sim'}" and info["settings"]["filter"] == "ekf"
    assert info["simulator"] == json.loads(read_text(sim / "sim" / "params.json"))

    evaluated = cli("evaluate", folder)
    assert evaluated.returncode == 0, evaluated.stderr
    assert json.loads(read_text(folder / "metrics.json"))["ate_rmse_m"] == metrics["ate_rmse_m"]
    repeated = cli("run", "--config", folder / "run.json", "--out", tmp_path / "repeated", "--quiet")
    assert repeated.returncode == 0, repeated.stderr
    assert read_text(tmp_path / "repeated" / "trajectory.tum") == read_text(folder / "trajectory.tum")

    page = tmp_path / "page.html"
    run.write_replay(str(page))
    assert read_text(page) == read_text(folder / "replay.html")
    unrecorded = slamkit.run(dataset, {"filter": "ekf"})
    assert not unrecorded.recorded and run.recorded
    with pytest.raises(ValueError, match="replay=True"):
        unrecorded.write_replay(str(tmp_path / "none.html"))


def test_a_grid_filter_maps_a_laser_log_and_scores_its_map_as_the_cli_does(tmp_path):
    subprocess.run([CLI, "simulate", "--building", "office", "--loops", "1", "--seed", "3", "--out", str(tmp_path)],
                   check=True, capture_output=True, env=CLI_ENV)
    spec = f"carmen:{tmp_path / 'office.log'}"
    subprocess.run([CLI, "run", "--filter", "scan-matching", "--data", spec, "--out", str(tmp_path / "sm"), "--quiet"],
                   check=True, capture_output=True, env=CLI_ENV)
    with open(tmp_path / "sm" / "metrics.json") as f:
        expected = json.load(f)
    dataset = slamkit.load_dataset(spec)
    run = slamkit.run(dataset, {"filter": "scan-matching"})
    got = slamkit.evaluate(run, dataset)
    assert {k: v for k, v in got.items() if k not in IGNORED} == \
        {k: v for k, v in expected.items() if k not in IGNORED}
    assert got["grid_map_precision"] > 0.9
    log_odds, observed, origin, resolution = run.grid
    assert log_odds.shape == observed.shape and log_odds.ndim == 2 and observed.any()
    assert resolution == 0.05 and origin.shape == (2,)
    assert (log_odds[observed] > 0).any() and (log_odds[~observed] == 0).all()

    # Recorded, its replay page draws the grid; stepping, the filter takes the laser scans.
    recorded = slamkit.run(dataset, {"filter": "scan-matching"}, replay=True)
    page = tmp_path / "grid.html"
    recorded.write_replay(str(page))
    assert '"beam_ends"' in read_text(page) and '"grid":{"h"' in read_text(page)
    stepper = slamkit.Filter(dataset, {"filter": "scan-matching"})
    kinds = [stepper.step() for _ in range(40)]
    assert "range_scan" in kinds and "scan" not in kinds and stepper.last_scan is not None


def test_a_campaign_runs_from_python_and_its_results_load_as_a_table(tmp_path):
    spec = tmp_path / "small.json"
    spec.write_text(json.dumps({
        "datasets": [{"name": "default", "spec": "scenario:default", "seeds": [1, 2], "settings": {"loops": 1}}],
        "filters": [{"name": "ekf"}, {"name": "fej", "settings": {"ekf_variant": "fej"}}],
        "outputs": "metrics"}))
    tally = slamkit.campaign(str(spec), str(tmp_path / "out"), jobs=2)
    assert (tally["jobs"], tally["run"], tally["failed"], tally["failures"]) == (4, 4, 0, [])
    assert slamkit.campaign(str(spec), str(tmp_path / "out"))["already_done"] == 4
    table = slamkit.campaign_results(tmp_path / "out")
    try:
        import pandas  # noqa: F401  (optional: a DataFrame where it is installed)
        rows = table.to_dict("records")
    except ImportError:
        rows = table
    assert len(rows) == 4
    assert sorted((r["configuration"], r["seed"]) for r in rows) == [
        ("ekf | default", 1), ("ekf | default", 2), ("fej | default", 1), ("fej | default", 2)]
    for r in rows:
        with open(os.path.join(r["folder"], "metrics.json")) as f:
            assert r["ate_rmse_m"] == json.load(f)["ate_rmse_m"]
        assert r["world_seed"] is None and not r["partial"]
    spec.write_text(json.dumps({"datasets": [], "filters": []}))
    with pytest.raises(slamkit.InputError, match="small.json: datasets: expected a non-empty list"):
        slamkit.campaign(str(spec), str(tmp_path / "other"))
