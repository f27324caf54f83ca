// The Python module `slamkit`: datasets with their events, filters stepped event by event or run
// whole, the evaluation and run folders, with NumPy arrays for every state, covariance, map and
// trajectory. Settings are the dicts run.json records (the keys of `slamkit run --print-config`'s
// "settings"), read by the library's own parser, and run folders are written by the library's own
// writers, so Python and the CLI accept the same settings, give the same numbers and leave the same
// folders.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <fmt/format.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "slamkit/campaign/campaign.hpp"
#include "slamkit/campaign/report.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/json_options.hpp"
#include "slamkit/core/version.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/models/motion_model.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/replay.hpp"
#include "slamkit/pipeline/run_folder.hpp"
#include "slamkit/pipeline/runner.hpp"
#include "slamkit/plot/replay_html.hpp"

namespace py = pybind11;
using namespace slamkit;

namespace {

// Python values cross into the library as JSON text, through Python's own json module.
nlohmann::json to_json(const py::object& value) {
  return nlohmann::json::parse(py::module_::import("json").attr("dumps")(value).cast<std::string>());
}
py::object to_python(const nlohmann::json& value) { return py::module_::import("json").attr("loads")(value.dump()); }

/// Rows t, x, y, theta.
py::array_t<double> poses_array(const std::vector<StampedPose>& poses) {
  py::array_t<double> out({static_cast<py::ssize_t>(poses.size()), py::ssize_t{4}});
  auto a = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const auto r = static_cast<py::ssize_t>(i);
    a(r, 0) = poses[i].t;
    for (py::ssize_t k = 0; k < 3; ++k) a(r, k + 1) = poses[i].pose(k);
  }
  return out;
}

/// Rows id, x, y.
py::array_t<double> landmarks_array(const std::vector<Landmark>& landmarks) {
  py::array_t<double> out({static_cast<py::ssize_t>(landmarks.size()), py::ssize_t{3}});
  auto a = out.mutable_unchecked<2>();
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    const auto r = static_cast<py::ssize_t>(i);
    a(r, 0) = landmarks[i].id;
    a(r, 1) = landmarks[i].position.x();
    a(r, 2) = landmarks[i].position.y();
  }
  return out;
}

/// Shape (n, 2, 2).
/// A GridMap as (log_odds, observed, origin, resolution), the arrays row 0 at the lowest y.
py::tuple grid_arrays(const GridMap& g) {
  const std::vector<py::ssize_t> shape = {g.height, g.width};
  py::array_t<double> log_odds(shape);
  py::array_t<bool> observed(shape);
  auto cells = log_odds.mutable_unchecked<2>();
  auto seen = observed.mutable_unchecked<2>();
  for (int j = 0; j < g.height; ++j)
    for (int i = 0; i < g.width; ++i) {
      cells(j, i) = g.log_odds[g.index(i, j)];
      seen(j, i) = g.observed[g.index(i, j)] != 0;
    }
  return py::make_tuple(log_odds, observed, Eigen::Vector2d(g.origin), g.resolution);
}

constexpr const char* kGridDoc =
    "a grid-mapping filter's occupancy grid (scan-matching, grid-fastslam: the best particle's): (log_odds, "
    "observed, origin, resolution), log_odds and observed of shape (height, width) with row 0 at the lowest y "
    "(observed: some beam reached the cell; log_odds 0 elsewhere), origin the lower-left corner [m], resolution "
    "the cell side [m]; empty arrays for a landmark filter";

py::array_t<double> landmark_covariances(const std::vector<Landmark>& landmarks) {
  py::array_t<double> out({static_cast<py::ssize_t>(landmarks.size()), py::ssize_t{2}, py::ssize_t{2}});
  auto a = out.mutable_unchecked<3>();
  for (std::size_t i = 0; i < landmarks.size(); ++i)
    for (py::ssize_t r = 0; r < 2; ++r)
      for (py::ssize_t c = 0; c < 2; ++c) a(static_cast<py::ssize_t>(i), r, c) = landmarks[i].covariance(r, c);
  return out;
}

/// A dataset as Python holds it: shared by the events, filters and runs made from it (none copies
/// it), with what a run folder needs to name it again from any working directory.
struct PyDataset {
  std::shared_ptr<const Dataset> data;
  std::string absolute_spec;
  nlohmann::json settings;  // the dataset settings it was read with; null for the reader's defaults
};

/// One event of a dataset, read in place.
class PyEvent {
 public:
  PyEvent(std::shared_ptr<const Dataset> dataset, std::size_t index) : dataset_(std::move(dataset)), index_(index) {}

  const Event& event() const { return dataset_->events[index_]; }
  std::size_t index() const { return index_; }
  double t() const { return event_time(event()); }
  const char* kind() const {
    if (std::holds_alternative<ControlEvent>(event())) return "control";
    return std::holds_alternative<RangeScanEvent>(event()) ? "range_scan" : "scan";
  }
  py::object dt() const {
    const auto* control = std::get_if<ControlEvent>(&event());
    return control ? py::object(py::float_(control->dt)) : py::object(py::none());
  }
  py::object control() const {
    const auto* control = std::get_if<ControlEvent>(&event());
    if (!control) return py::none();
    return py::array_t<double>(control->u.size(), control->u.data());
  }
  py::array_t<double> observations() const {
    const std::vector<Observation>* obs = scan_observations();
    const auto n = static_cast<py::ssize_t>(obs ? obs->size() : 0);
    py::array_t<double> out({n, py::ssize_t{2}});
    auto a = out.mutable_unchecked<2>();
    for (py::ssize_t i = 0; i < n; ++i)
      for (py::ssize_t k = 0; k < 2; ++k) a(i, k) = (*obs)[static_cast<std::size_t>(i)].z(k);
    return out;
  }
  py::array_t<int> ids() const {
    const std::vector<Observation>* obs = scan_observations();
    const auto n = static_cast<py::ssize_t>(obs ? obs->size() : 0);
    py::array_t<int> out(n);
    auto a = out.mutable_unchecked<1>();
    for (py::ssize_t i = 0; i < n; ++i) a(i) = (*obs)[static_cast<std::size_t>(i)].id;
    return out;
  }

 private:
  const std::vector<Observation>* scan_observations() const {
    const auto* scan = std::get_if<ScanEvent>(&event());
    return scan ? &scan->observations : nullptr;
  }

  std::shared_ptr<const Dataset> dataset_;
  std::size_t index_;
};

/// A dataset's events as a sequence of PyEvent, made on access.
struct PyEvents {
  std::shared_ptr<const Dataset> dataset;

  std::size_t size() const { return dataset->events.size(); }
  PyEvent at(py::ssize_t index) const {
    const auto n = static_cast<py::ssize_t>(size());
    if (index < 0) index += n;
    if (index < 0 || index >= n) throw py::index_error("event index out of range");
    return PyEvent(dataset, static_cast<std::size_t>(index));
  }
};

/// The provenance run.json records of a run made from Python: what `slamkit run` records, with the
/// interpreter and its script in place of a command line.
nlohmann::json python_provenance(const PyDataset& dataset, const FilterConfig& config) {
  const py::module_ sys = py::module_::import("sys");
  nlohmann::json provenance = {
      {"slamkit_version", version()},
      {"front_end", "python"},
      {"python_version", sys.attr("version").cast<std::string>()},
      {"python_argv", sys.attr("argv").cast<std::vector<std::string>>()},
      {"working_directory", std::filesystem::current_path().string()},
      {"dataset_as_given", dataset.data->spec},
      {"dataset_settings_contents", dataset.settings},
      {"settings", to_json(config)},
  };
  add_dataset_provenance(provenance, dataset.absolute_spec, *dataset.data);
  return provenance;
}

/// A whole run: its result, the dataset it ran on, and its scan-by-scan recording if it made one.
struct PyRun {
  RunResult result;
  PyDataset dataset;
  std::shared_ptr<const ReplayRecorder> recorder;
};

PyRun run_dataset(const PyDataset& dataset, const py::dict& settings, bool replay) {
  const FilterConfig config = filter_config_from_json(to_json(settings), "settings");
  auto filter = make_filter(config, *dataset.data);
  PyRun run{{}, dataset, nullptr};
  RunOptions options;
  std::shared_ptr<ReplayRecorder> recorder;
  if (replay)
    options.observers.push_back(
        (recorder = std::make_shared<ReplayRecorder>(*dataset.data, ReplayOptions{}, filter->maps_range_scans())).get());
  {
    py::gil_scoped_release release;
    run.result = run_filter(*filter, *dataset.data, options);
  }
  run.recorder = recorder;
  run.result.association = to_string(config.association.method);
  run.result.dataset = dataset.absolute_spec;
  run.result.provenance = python_provenance(dataset, config);
  return run;
}

/// A filter built for a dataset, stepped through the dataset's events by the caller.
class Filter {
 public:
  Filter(const PyDataset& dataset, const py::dict& settings)
      : dataset_(dataset.data),
        config_(filter_config_from_json(to_json(settings), "settings")),
        filter_(make_filter(config_, *dataset_)) {}

  /// Applies the next event; returns "control", "scan" or "range_scan", or None at the end of the dataset.
  py::object step() {
    if (next_ >= dataset_->events.size()) return py::none();
    const std::size_t index = next_++;
    const Event& event = dataset_->events[index];
    if (const auto* control = std::get_if<ControlEvent>(&event)) {
      filter_->predict(*control);
      last_event_ = index;
      return py::str("control");
    }
    // A log can hold both kinds of scan (Victoria Park): the one the filter does not map with passes
    // it by and leaves last_scan as it was.
    last_event_ = index;
    if (const auto* range_scan = std::get_if<RangeScanEvent>(&event)) {
      if (filter_->maps_range_scans()) {
        filter_->update_range_scan(*range_scan);
        last_scan_ = index;
      }
      return py::str("range_scan");
    }
    if (!filter_->maps_range_scans()) {
      filter_->update(std::get<ScanEvent>(event));
      last_scan_ = index;
    }
    return py::str("scan");
  }

  std::size_t events_done() const { return next_; }
  const SlamFilter& filter() const { return *filter_; }

  py::object time() const {
    return last_event_ ? py::object(py::float_(PyEvent(dataset_, *last_event_).t())) : py::object(py::none());
  }
  std::optional<PyEvent> last_scan() const {
    if (!last_scan_) return std::nullopt;
    return PyEvent(dataset_, *last_scan_);
  }
  py::list associations() const {
    py::list out;
    if (!last_scan_) return out;
    for (const AssociationRecord& r : filter_->last_associations())
      out.append(py::make_tuple(to_string(r.decision), r.landmark_id));
    return out;
  }

  /// The EKF's whole state and covariance (pose, then each landmark); the pose and its covariance
  /// for FastSLAM, whose map is per particle.
  Eigen::VectorXd state() const {
    if (const auto* ekf = ekf_slam()) return ekf->estimator().state();
    return filter_->pose();
  }
  Eigen::MatrixXd covariance() const {
    if (const auto* ekf = ekf_slam()) return ekf->estimator().covariance();
    return filter_->pose_covariance();
  }
  py::array_t<int> state_ids() const {
    const EkfSlam* ekf = ekf_slam();
    if (!ekf) return py::array_t<int>(0);
    const std::vector<int>& ids = ekf->landmark_ids();
    return py::array_t<int>(static_cast<py::ssize_t>(ids.size()), ids.data());
  }

 private:
  const EkfSlam* ekf_slam() const { return dynamic_cast<const EkfSlam*>(filter_.get()); }

  std::shared_ptr<const Dataset> dataset_;
  FilterConfig config_;
  std::unique_ptr<SlamFilter> filter_;
  std::size_t next_ = 0;
  std::optional<std::size_t> last_event_, last_scan_;
};

const ReplayRecorder& recording_of(const PyRun& run) {
  if (!run.recorder)
    throw py::value_error("this run was not recorded for a replay: run it with slamkit.run(dataset, settings, "
                          "replay=True)");
  return *run.recorder;
}

/// Fails at import, not at the first array, when NumPy is missing: every state, map and trajectory
/// is a NumPy array.
void require_numpy() {
  try {
    py::module_::import("numpy");
  } catch (py::error_already_set& e) {
    if (!e.matches(PyExc_ImportError)) throw;
    throw py::import_error(
        "slamkit needs NumPy, which could not be imported (" + std::string(py::str(e.value())) +
        "); install it with apt-get install python3-numpy");
  }
}

constexpr const char* kModuleDoc = R"(slamkit: landmark SLAM (EKF-SLAM and its consistent variants, UKF, FastSLAM 1.0/2.0) with
datasets, evaluation against ground truth and run folders, as the `slamkit` command line has them.

A session:

    ds = slamkit.load_dataset("sim:out/sim")            # a Dataset; ds.events is its event stream
    run = slamkit.run(ds, {"filter": "ekf"}, replay=True)
    metrics = slamkit.evaluate(run)                     # metrics.json as a dict
    run.save("out/run")                                 # the folder `slamkit run` writes
    f = slamkit.Filter(ds, {"filter": "fastslam2", "particles": 50})
    while f.step(): ...                                 # f.time, f.last_scan, f.associations, f.map

Units: metres, radians, seconds throughout; headings are wrapped to (-pi, pi]. The map frame is the
vehicle's start pose. Settings dicts are run.json's "settings" (see `slamkit run --print-config`);
missing keys keep their defaults. Bad settings or data raise slamkit.InputError, a ValueError
naming the file or key.)";

}  // namespace

/// A campaign's tally and failures, as campaign() returns them.
py::dict to_python(const campaign::CampaignSpec& spec, const campaign::CampaignResult& result) {
  const campaign::CampaignTally& t = result.tally;
  py::list failures;
  for (const campaign::JobOutcome& f : result.failures)
    failures.append(py::dict(py::arg("folder") = spec.jobs[f.index].folder, py::arg("error") = f.error));
  return py::dict(py::arg("jobs") = t.total, py::arg("run") = t.run, py::arg("already_done") = t.already_done,
                  py::arg("diverged") = t.diverged, py::arg("stopped") = t.stopped, py::arg("failed") = t.failed,
                  py::arg("failures") = failures);
}

/// One row per run folder under `paths`: where it is, its configuration, the job's seeds (a campaign's
/// run.json records them) and every number metrics.json holds; a pandas DataFrame where pandas is
/// installed, else a list of dicts.
py::object campaign_results(const py::object& given) {
  const py::object path_like = py::module_::import("os").attr("PathLike");
  const bool one_path = py::isinstance<py::str>(given) || py::isinstance(given, path_like);
  const std::vector<std::string> paths =
      one_path ? std::vector<std::string>{py::str(given)} : given.cast<std::vector<std::string>>();
  campaign::ReportOptions options;
  options.nees_test = false;
  const campaign::Report report = campaign::collect_report(paths, options);
  nlohmann::json rows = nlohmann::json::array();
  for (const campaign::ReportRun& run : report.runs) {
    nlohmann::json row = {{"folder", run.dir},   {"configuration", run.configuration}, {"filter", run.filter},
                          {"dataset", run.dataset}, {"partial", run.partial},
                          {"diverged_at_s", run.diverged_at_s ? nlohmann::json(*run.diverged_at_s) : nlohmann::json()}};
    for (const char* key : {"seed", "world_seed", "filter_seed"})
      row[key] = run.campaign_job.is_object() && run.campaign_job.contains(key) ? run.campaign_job.at(key)
                                                                                : nlohmann::json();
    for (const auto& [key, value] : run.metrics.items())
      if (value.is_primitive() && !row.contains(key)) row[key] = value;
    rows.push_back(std::move(row));
  }
  py::object table = to_python(rows);
  try {
    return py::module_::import("pandas").attr("DataFrame")(table);
  } catch (const py::error_already_set& e) {
    if (!e.matches(PyExc_ImportError)) throw;
    return table;
  }
}

PYBIND11_MODULE(slamkit, m) {
  require_numpy();
  m.doc() = kModuleDoc;
  m.attr("__version__") = version();
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);

  py::class_<PyEvent>(m, "Event", "One event of a dataset: a control applied up to time t, or a scan of observations.")
      .def_property_readonly("index", &PyEvent::index, "position in Dataset.events")
      .def_property_readonly("t", &PyEvent::t, "time [s]")
      .def_property_readonly("kind", &PyEvent::kind, "'control' or 'scan'")
      .def_property_readonly("dt", &PyEvent::dt, "a control's duration [s], from the previous event to t; None for a scan")
      .def_property_readonly("control", &PyEvent::control,
                             "a control's vector, shape (k,), as Dataset.motion_model takes it (ackermann: speed "
                             "[m/s], steering [rad]; velocity: speed [m/s], turn rate [rad/s]; acfr-car: speed "
                             "[m/s], steering [rad]; odometry: rot1 [rad], trans [m], rot2 [rad]); None for a scan")
      .def_property_readonly("observations", &PyEvent::observations,
                             "a scan's observations, shape (n, 2): rows range [m], bearing [rad] in the sensor "
                             "frame; shape (0, 2) for a control")
      .def_property_readonly("ids", &PyEvent::ids,
                             "the landmark id the sensor gave each observation, shape (n,), int; -1 where it gives "
                             "none (logs without identities, clutter)")
      .def("__repr__", [](const PyEvent& e) {
        const auto* scan = std::get_if<ScanEvent>(&e.event());
        return fmt::format("<slamkit.Event {} {} t={}{}>", e.index(), e.kind(), e.t(),
                           scan ? fmt::format(" observations={}", scan->observations.size()) : "");
      });

  py::class_<PyEvents>(m, "Events",
                       "A dataset's events in time order, read in place: len(), indexing (negative too), "
                       "slicing and iteration give Event objects.")
      .def("__len__", &PyEvents::size)
      .def("__getitem__", &PyEvents::at, py::arg("index"))
      .def("__getitem__",
           [](const PyEvents& events, const py::slice& slice) {
             py::ssize_t start = 0, stop = 0, step = 0, length = 0;
             if (!slice.compute(static_cast<py::ssize_t>(events.size()), &start, &stop, &step, &length))
               throw py::error_already_set();
             py::list out;
             for (py::ssize_t i = 0; i < length; ++i) out.append(events.at(start + i * step));
             return out;
           },
           py::arg("slice"));

  py::class_<PyDataset>(m, "Dataset",
                        "A dataset: its event stream, the models it is read with, and its ground truth. Made by "
                        "load_dataset().")
      .def_property_readonly("spec", [](const PyDataset& d) { return d.data->spec; }, "the 'kind:PATH' spec as given")
      .def_property_readonly("absolute_spec", [](const PyDataset& d) { return d.absolute_spec; },
                             "the spec with its folder made absolute, as run.json records it")
      .def_property_readonly("name", [](const PyDataset& d) { return d.data->name; }, "short label for titles")
      .def_property_readonly("events", [](const PyDataset& d) { return PyEvents{d.data}; },
                             "the event stream (Events): len(ds.events) events, each an Event")
      .def_property_readonly("motion_model", [](const PyDataset& d) { return d.data->motion->name(); },
                             "the motion model's name, which fixes what Event.control holds")
      .def_property_readonly("initial_pose", [](const PyDataset& d) { return Eigen::Vector3d(d.data->initial_pose); },
                             "start pose, shape (3,): x [m], y [m], theta [rad]")
      .def_property_readonly("truth_poses", [](const PyDataset& d) { return poses_array(d.data->truth.poses); },
                             "ground-truth trajectory, shape (n, 4): rows t [s], x [m], y [m], theta [rad] (theta 0 "
                             "where the truth has positions only, e.g. GPS)")
      .def_property_readonly("truth_has_headings", [](const PyDataset& d) { return d.data->truth.poses_have_heading; },
                             "whether truth_poses carries headings (False for GPS; then there is no pose NEES)")
      .def_property_readonly("truth_landmarks", [](const PyDataset& d) { return landmarks_array(d.data->truth.landmarks); },
                             "true landmarks, shape (n, 3): rows id, x [m], y [m]");

  m.def(
      "load_dataset",
      [](const std::string& spec, const py::object& settings) {
        const nlohmann::json contents = settings.is_none() ? nlohmann::json() : to_json(settings);
        return PyDataset{std::make_shared<const Dataset>(load_dataset(spec, contents, "settings")),
                         absolute_dataset_spec(spec), contents};
      },
      py::arg("spec"), py::arg("settings") = py::none(),
      "Opens a dataset by its 'kind:PATH' spec, as `slamkit run --data` does (sim:DIR, victoria-park:DIR, "
      "mrclam:DIR:robotN, course:DIR, plaza:DIR:Plaza1); `settings` is a dict of the dataset's settings (the contents of a "
      "config/*.json), None for the defaults. Returns a Dataset.");

  py::class_<PyRun>(m, "Run", "The result of run(): estimates, map and statistics, which save() writes as a run folder.")
      .def_property_readonly("filter", [](const PyRun& r) { return r.result.filter; }, "the filter's name")
      .def_property_readonly("dataset", [](const PyRun& r) { return r.dataset; }, "the Dataset it ran on")
      .def_property_readonly("trajectory", [](const PyRun& r) { return poses_array(r.result.trajectory); },
                             "the estimated trajectory, shape (n, 4): rows t [s], x [m], y [m], theta [rad]; FastSLAM's "
                             "best particle's path, else the same as filtered")
      .def_property_readonly("filtered", [](const PyRun& r) { return poses_array(r.result.filtered); },
                             "the per-step estimates, shape (n, 4): rows t [s], x [m], y [m], theta [rad]; what ATE "
                             "and NEES are computed on")
      .def_property_readonly("pose_covariances",
                             [](const PyRun& r) {
                               const std::vector<Matrix3>& covs = r.result.pose_covariances;
                               py::array_t<double> out(
                                   {static_cast<py::ssize_t>(covs.size()), py::ssize_t{3}, py::ssize_t{3}});
                               auto a = out.mutable_unchecked<3>();
                               for (std::size_t i = 0; i < covs.size(); ++i)
                                 for (py::ssize_t j = 0; j < 3; ++j)
                                   for (py::ssize_t k = 0; k < 3; ++k) a(static_cast<py::ssize_t>(i), j, k) = covs[i](j, k);
                               return out;
                             },
                             "the covariance of each filtered pose, shape (n, 3, 3), over (x [m], y [m], theta [rad])")
      .def_property_readonly("dead_reckoning", [](const PyRun& r) { return poses_array(r.result.dead_reckoning); },
                             "the controls integrated without observations, shape (n, 4): rows t, x, y, theta")
      .def_property_readonly("map", [](const PyRun& r) { return landmarks_array(r.result.map); },
                             "the final map, shape (n, 3): rows id, x [m], y [m]")
      .def_property_readonly("grid", [](const PyRun& r) { return grid_arrays(r.result.grid); }, kGridDoc)
      .def_property_readonly("map_covariances", [](const PyRun& r) { return landmark_covariances(r.result.map); },
                             "each map landmark's position covariance, shape (n, 2, 2) [m^2], in map's row order")
      .def_property_readonly("statistics", [](const PyRun& r) { return r.result.statistics; },
                             "filter-specific figures at the end of the run (dict), as run.json's 'statistics'")
      .def_property_readonly("partial", [](const PyRun& r) { return r.result.partial; },
                             "True if the run stopped early (its estimate stopped being finite)")
      .def_property_readonly("recorded", [](const PyRun& r) { return r.recorder != nullptr; },
                             "whether the run was recorded for a replay (run(..., replay=True))")
      .def(
          "save",
          [](const PyRun& r, const std::string& folder) {
            return to_python(to_json(write_run_folder(folder, r.result, *r.dataset.data, r.recorder.get())));
          },
          py::arg("folder"),
          "Writes the run folder `slamkit run --out FOLDER` writes (trajectory.tum, map.txt, run.json, metrics.json, "
          "the SVG pictures, ...; with a recorded run also replay.json and replay.html), readable by `slamkit "
          "evaluate` and repeatable by `slamkit run --config FOLDER/run.json`; run.json's provenance says "
          "'front_end': 'python'. Returns the evaluation (metrics.json as a dict).")
      .def(
          "write_replay",
          [](const PyRun& r, const std::string& path) {
            const Metrics metrics = evaluate_run(r.result, *r.dataset.data);
            plot::write_replay_html(path, replay_recording(recording_of(r), r.result, *r.dataset.data, metrics));
          },
          py::arg("path"),
          "Writes the replay page (one self-contained HTML file) of a run made with run(..., replay=True) to `path`.");

  py::class_<Filter>(m, "Filter",
                     "A filter for a dataset, stepped by the caller one event at a time; between steps it shows "
                     "its estimate, the time, the last scan and what it did with each of its observations.")
      .def(py::init<const PyDataset&, const py::dict&>(), py::arg("dataset").none(false),
           py::arg("settings") = py::dict(),
           "A filter for `dataset`; `settings` as run.json's 'settings', e.g. {'filter': 'fastslam2', "
           "'particles': 50, 'seed': 3, 'association': {'method': 'nn'}}. Missing keys keep their defaults.")
      .def("step", &Filter::step, "Applies the dataset's next event; returns 'control', 'scan' (landmark observations), "
           "'range_scan' (a laser scan) or None at the end. A filter passes by the kind of scan it does not "
           "map with")
      .def_property_readonly("events_done", &Filter::events_done, "events applied so far")
      .def_property_readonly("time", &Filter::time, "time of the last event applied [s]; None before the first step")
      .def_property_readonly("last_scan", &Filter::last_scan,
                             "the last scan the filter applied, of the kind it maps with (an Event: its observations and "
                             "their sensor ids); None before the first")
      .def_property_readonly("associations", &Filter::associations,
                             "what the filter did with each observation of last_scan, in its order: a list of "
                             "(decision, landmark_id) with decision 'update' (landmark_id updated), 'new' (landmark_id "
                             "started) or 'discard' (landmark_id -1), as associations.txt of a run folder")
      .def_property_readonly("name", [](const Filter& f) { return f.filter().name(); }, "the filter's name")
      .def_property_readonly("pose", [](const Filter& f) { return Eigen::Vector3d(f.filter().pose()); },
                             "current pose estimate, shape (3,): x [m], y [m], theta [rad]")
      .def_property_readonly("pose_covariance", [](const Filter& f) { return Eigen::Matrix3d(f.filter().pose_covariance()); },
                             "covariance of pose, shape (3, 3), over (x [m], y [m], theta [rad]); FastSLAM: of its "
                             "particles' poses")
      .def_property_readonly("state", &Filter::state,
                             "EKF and UKF: the joint state, shape (3 + 2n,): [x y theta | m1x m1y | m2x m2y | ...] "
                             "[m, rad], landmark i being state_ids[i] (provisional landmarks included, so it can "
                             "hold more than map). A range calibration (offset, scale error) comes before the "
                             "landmarks where it is estimated, and a landmark at inverse distance holds four rows "
                             "(theta, rho, origin x, origin y) until it becomes a point. FastSLAM: pose, shape (3,); "
                             "its maps are per particle")
      .def_property_readonly("covariance", &Filter::covariance,
                             "EKF and UKF: the joint covariance of state, shape (3 + 2n, 3 + 2n), symmetric. "
                             "FastSLAM: pose_covariance")
      .def_property_readonly("state_ids", &Filter::state_ids,
                             "EKF and UKF: the id of each landmark of state, in state order, shape (n,), int; empty for "
                             "FastSLAM")
      .def_property_readonly("map", [](const Filter& f) { return landmarks_array(f.filter().landmarks()); },
                             "current map of confirmed landmarks, shape (n, 3): rows id, x [m], y [m] (FastSLAM: the "
                             "best particle's)")
      .def_property_readonly("grid", [](const Filter& f) { return grid_arrays(f.filter().grid_map()); }, kGridDoc)
      .def_property_readonly("map_covariances",
                             [](const Filter& f) { return landmark_covariances(f.filter().landmarks()); },
                             "each map landmark's position covariance, shape (n, 2, 2) [m^2], in map's row order")
      .def_property_readonly("particles",
                             [](const Filter& f) {
                               const std::vector<WeightedPose> samples = f.filter().pose_samples();
                               py::array_t<double> out({static_cast<py::ssize_t>(samples.size()), py::ssize_t{4}});
                               auto a = out.mutable_unchecked<2>();
                               for (std::size_t i = 0; i < samples.size(); ++i) {
                                 const auto r = static_cast<py::ssize_t>(i);
                                 for (py::ssize_t k = 0; k < 3; ++k) a(r, k) = samples[i].pose(k);
                                 a(r, 3) = samples[i].weight;
                               }
                               return out;
                             },
                             "FastSLAM's particles, shape (N, 4): rows x [m], y [m], theta [rad], weight (normalised, "
                             "summing to 1); shape (0, 4) for the EKF and UKF");

  m.def("run", &run_dataset, py::arg("dataset").none(false), py::arg("settings") = py::dict(),
        py::arg("replay") = false,
        "Runs a filter over the whole dataset, as `slamkit run` does, and returns a Run; `settings` as for Filter. "
        "With replay=True it also records the run scan by scan, for Run.write_replay() and the replay page of "
        "Run.save().");

  m.def(
      "campaign",
      [](const std::string& spec_path, const std::string& out, unsigned jobs) {
        const campaign::CampaignSpec spec = campaign::read_campaign_spec(spec_path);
        campaign::CampaignOptions options;
        options.workers = jobs;
        campaign::CampaignResult result;
        {
          py::gil_scoped_release release;
          result = campaign::run_campaign(spec, out, options);
        }
        return to_python(spec, result);
      },
      py::arg("spec"), py::arg("out"), py::arg("jobs") = 0,
      "Runs the campaign of the spec file `spec` (docs/campaigns.md) into the folder `out`, `jobs` runs at once "
      "(0: one per core), as `slamkit campaign` does without its report; jobs already done there are skipped. "
      "Returns a dict: jobs, run, already_done, diverged, stopped, failed, and failures (a list of {folder, "
      "error}).");

  m.def("campaign_results", &campaign_results, py::arg("paths"),
        "The run folders under `paths` (a folder or a list of them: a campaign's, or folders written by `slamkit "
        "run`) as a table, one row per run: folder, configuration (as `slamkit report` groups them), filter, "
        "dataset, partial, diverged_at_s, the campaign's seed, world_seed and filter_seed (None outside a "
        "campaign), then every number of metrics.json (ate_rmse_m, nees_pose_mean, ...). A pandas DataFrame "
        "where pandas is installed, else a list of dicts.");

  m.def(
      "evaluate",
      [](const PyRun& run, const PyDataset* dataset) {
        const Dataset& truth_of = dataset ? *dataset->data : *run.dataset.data;
        return to_python(to_json(evaluate_run(run.result, truth_of)));
      },
      py::arg("run").none(false), py::arg("dataset") = py::none(),
      "The evaluation of `run` against its dataset's truth (or `dataset`'s), as metrics.json holds it, as a dict: "
      "ate_rmse_m (after SE(2) alignment), map_rmse_m, nees_pose_* (unaligned), association counts, ...");
}
