// The Python module `slamkit`: datasets, filters stepped event by event or run whole, and the
// evaluation, with NumPy arrays for every state, covariance, map and trajectory. Settings are the
// dicts run.json records (the keys of `slamkit run --print-config`'s "settings"), read by the
// library's own parser, so Python and the CLI accept the same settings and give the same numbers.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/core/version.hpp"
#include "slamkit/eval/evaluation.hpp"
#include "slamkit/filters/ekf_slam.hpp"
#include "slamkit/io/load_dataset.hpp"
#include "slamkit/pipeline/factory.hpp"
#include "slamkit/pipeline/runner.hpp"

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
py::array_t<double> landmark_covariances(const std::vector<Landmark>& landmarks) {
  py::array_t<double> out({static_cast<py::ssize_t>(landmarks.size()), py::ssize_t{2}, py::ssize_t{2}});
  auto a = out.mutable_unchecked<3>();
  for (std::size_t i = 0; i < landmarks.size(); ++i)
    for (py::ssize_t r = 0; r < 2; ++r)
      for (py::ssize_t c = 0; c < 2; ++c) a(static_cast<py::ssize_t>(i), r, c) = landmarks[i].covariance(r, c);
  return out;
}

/// A filter built for a dataset, stepped through the dataset's events by the caller.
class Filter {
 public:
  Filter(std::shared_ptr<const Dataset> dataset, const py::dict& settings)
      : dataset_(std::move(dataset)),
        config_(filter_config_from_json(to_json(settings), "settings")),
        filter_(make_filter(config_, *dataset_)) {}

  /// Applies the next event; returns "control" or "scan", or None at the end of the dataset.
  py::object step() {
    if (next_ >= dataset_->events.size()) return py::none();
    const Event& event = dataset_->events[next_++];
    if (const auto* control = std::get_if<ControlEvent>(&event)) {
      filter_->predict(*control);
      return py::str("control");
    }
    filter_->update(std::get<ScanEvent>(event));
    return py::str("scan");
  }

  std::size_t events_done() const { return next_; }
  const SlamFilter& filter() const { return *filter_; }
  const Dataset& dataset() const { return *dataset_; }

  /// The EKF's whole state and covariance (pose, then each landmark); the pose and its covariance
  /// for FastSLAM, whose map is per particle.
  Eigen::VectorXd state() const {
    if (const auto* ekf = dynamic_cast<const EkfSlam*>(filter_.get())) return ekf->estimator().state();
    return filter_->pose();
  }
  Eigen::MatrixXd covariance() const {
    if (const auto* ekf = dynamic_cast<const EkfSlam*>(filter_.get())) return ekf->estimator().covariance();
    return filter_->pose_covariance();
  }

 private:
  std::shared_ptr<const Dataset> dataset_;
  FilterConfig config_;
  std::unique_ptr<SlamFilter> filter_;
  std::size_t next_ = 0;
};

}  // namespace

PYBIND11_MODULE(slamkit, m) {
  m.doc() = "slamkit: landmark-based SLAM (EKF-SLAM, FastSLAM 1.0/2.0) with datasets and evaluation";
  m.attr("__version__") = version();
  py::register_exception<InputError>(m, "InputError", PyExc_ValueError);

  py::class_<Dataset, std::shared_ptr<Dataset>>(m, "Dataset")
      .def_readonly("spec", &Dataset::spec)
      .def_readonly("name", &Dataset::name)
      .def_property_readonly("events", [](const Dataset& d) { return d.events.size(); })
      .def_readonly("initial_pose", &Dataset::initial_pose)
      .def_property_readonly("truth_poses", [](const Dataset& d) { return poses_array(d.truth.poses); },
                             "ground-truth trajectory, rows t, x, y, theta")
      .def_property_readonly("truth_landmarks", [](const Dataset& d) { return landmarks_array(d.truth.landmarks); },
                             "true landmarks, rows id, x, y");

  m.def(
      "load_dataset",
      [](const std::string& spec, const py::object& settings) {
        return std::make_shared<Dataset>(
            load_dataset(spec, settings.is_none() ? nlohmann::json() : to_json(settings), "settings"));
      },
      py::arg("spec"), py::arg("settings") = py::none(),
      "Opens a dataset by its 'kind:PATH' spec, as `slamkit run --data`; `settings` is a dict of the "
      "dataset's settings (the contents of a config/*.json), None for the defaults.");

  py::class_<RunResult>(m, "Run")
      .def_readonly("filter", &RunResult::filter)
      .def_property_readonly("trajectory", [](const RunResult& r) { return poses_array(r.trajectory); })
      .def_property_readonly("filtered", [](const RunResult& r) { return poses_array(r.filtered); })
      .def_property_readonly("pose_covariances",
                             [](const RunResult& r) {
                               py::array_t<double> out({static_cast<py::ssize_t>(r.pose_covariances.size()),
                                                        py::ssize_t{3}, py::ssize_t{3}});
                               auto a = out.mutable_unchecked<3>();
                               for (std::size_t i = 0; i < r.pose_covariances.size(); ++i)
                                 for (py::ssize_t j = 0; j < 3; ++j)
                                   for (py::ssize_t k = 0; k < 3; ++k)
                                     a(static_cast<py::ssize_t>(i), j, k) = r.pose_covariances[i](j, k);
                               return out;
                             })
      .def_property_readonly("dead_reckoning", [](const RunResult& r) { return poses_array(r.dead_reckoning); })
      .def_property_readonly("map", [](const RunResult& r) { return landmarks_array(r.map); })
      .def_property_readonly("map_covariances", [](const RunResult& r) { return landmark_covariances(r.map); })
      .def_readonly("statistics", &RunResult::statistics);

  py::class_<Filter>(m, "Filter")
      .def(py::init<std::shared_ptr<const Dataset>, const py::dict&>(), py::arg("dataset"),
           py::arg("settings") = py::dict(),
           "A filter for `dataset`; `settings` as run.json's 'settings', e.g. {'filter': 'fastslam2', "
           "'particles': 50, 'seed': 3, 'association': {'method': 'nn'}}. Missing keys keep their defaults.")
      .def("step", &Filter::step, "Applies the dataset's next event: 'control', 'scan', or None at the end")
      .def_property_readonly("events_done", &Filter::events_done)
      .def_property_readonly("name", [](const Filter& f) { return f.filter().name(); })
      .def_property_readonly("pose", [](const Filter& f) { return Eigen::Vector3d(f.filter().pose()); })
      .def_property_readonly("pose_covariance", [](const Filter& f) { return Eigen::Matrix3d(f.filter().pose_covariance()); })
      .def_property_readonly("state", &Filter::state)
      .def_property_readonly("covariance", &Filter::covariance)
      .def_property_readonly("map", [](const Filter& f) { return landmarks_array(f.filter().landmarks()); })
      .def_property_readonly("map_covariances",
                             [](const Filter& f) { return landmark_covariances(f.filter().landmarks()); })
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
                             "rows x, y, theta, weight (FastSLAM; empty for the EKF)");

  m.def(
      "run",
      [](const std::shared_ptr<const Dataset>& dataset, const py::dict& settings) {
        const FilterConfig config = filter_config_from_json(to_json(settings), "settings");
        auto filter = make_filter(config, *dataset);
        RunResult run;
        {
          py::gil_scoped_release release;
          run = run_filter(*filter, *dataset);
        }
        run.association = to_string(config.association.method);
        return run;
      },
      py::arg("dataset"), py::arg("settings") = py::dict(),
      "Runs a filter over the whole dataset, as `slamkit run` does.");

  m.def(
      "evaluate",
      [](const RunResult& run, const Dataset& dataset) { return to_python(to_json(evaluate_run(run, dataset.truth))); },
      py::arg("run"), py::arg("dataset"), "The evaluation as metrics.json holds it, as a dict.");
}
