#include "slamkit/calib/calibration.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <utility>
#include <variant>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/chi_square.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/pose_at.hpp"

namespace slamkit {
namespace {

// ---- The logs' commands and truth ---------------------------------------------------------------

// The commands as the filter sees them: each held over (begin, end].
class CommandStream {
 public:
  CommandStream(const Dataset& log, const MotionModel& model) : model_(model) {
    for (const Event& e : log.events)
      if (const auto* c = std::get_if<ControlEvent>(&e); c && c->dt > 0.0) held_.push_back({c->t - c->dt, c->t, c->u});
  }
  double begin() const { return held_.empty() ? 0.0 : held_.front().begin; }
  double end() const { return held_.empty() ? 0.0 : held_.back().end; }

  /// The motion the commands held over [from, to] make, in the frame of the pose at `from`.
  Pose2 motion(double from, double to) const {
    Pose2 x = Pose2::Zero();
    auto it = std::upper_bound(held_.begin(), held_.end(), from, [](double t, const Held& h) { return t < h.end; });
    for (; it != held_.end() && it->begin < to; ++it) {
      const double dt = std::min(to, it->end) - std::max(from, it->begin);
      if (dt > 0.0) x = model_.predict(x, it->u, dt);
    }
    return x;
  }

 private:
  struct Held {
    double begin, end;
    Control u;
  };
  const MotionModel& model_;
  std::vector<Held> held_;
};

class Truth {
 public:
  Truth(const std::vector<StampedPose>& poses, double max_gap) : poses_(poses), max_gap_(max_gap) {}

  /// The true pose at t (pose_at, within max_gap).
  bool at(double t, Pose2& out) const { return pose_at(poses_, t, out, max_gap_); }

  /// The true motion over [from, to] in the frame of the pose at `from`.
  bool motion(double from, double to, Pose2& out) const {
    Pose2 a, b;
    if (!at(from, a) || !at(to, b)) return false;
    const double c = std::cos(a[2]), s = std::sin(a[2]);
    const Vector2 d = b.head<2>() - a.head<2>();
    out = Pose2(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), wrap_angle(b[2] - a[2]));
    return true;
  }

 private:
  const std::vector<StampedPose>& poses_;
  double max_gap_;
};

// The commanded motion's error over a window: along the commanded chord (the start heading when the
// command barely moves) and in heading.
struct MotionError {
  double along = 0.0, heading = 0.0;
};

MotionError motion_error(const Pose2& truth, const Pose2& commanded) {
  const Vector2 chord = commanded.head<2>();
  const Vector2 along = chord.norm() > 1e-6 ? Vector2(chord.normalized()) : Vector2(1.0, 0.0);
  return {along.dot(truth.head<2>() - chord), wrap_angle(truth[2] - commanded[2])};
}

struct Log {
  const Dataset* dataset;
  CommandStream commands;
  Truth truth;
  std::vector<double> scan_times;
};

// ---- Measurement residuals -------------------------------------------------------------------------

struct Residual {
  std::size_t log = 0;
  int landmark = 0;
  double t = 0.0, range = 0.0;
  Vector2 error = Vector2::Zero();  // measurement less prediction: range, bearing
};

constexpr int kMaxOutlierIterations = 50;

// sigma^2 of the white noise that gives each pass's mean residual the error it has: the mean over
// passes of n (mean of the pass)^2, per component. `residuals` are sorted by log, landmark and time.
Vector2 batch_means_variance(const std::vector<Residual>& residuals, double pass_gap, std::size_t& passes) {
  Vector2 sum_of_passes = Vector2::Zero();
  passes = 0;
  std::size_t first = 0;
  for (std::size_t i = 1; i <= residuals.size(); ++i) {
    const bool pass_ends = i == residuals.size() || residuals[i].log != residuals[first].log ||
                           residuals[i].landmark != residuals[first].landmark ||
                           residuals[i].t - residuals[i - 1].t > pass_gap;
    if (!pass_ends) continue;
    Vector2 sum = Vector2::Zero();
    for (std::size_t k = first; k < i; ++k) sum += residuals[k].error;
    const auto n = static_cast<double>(i - first);
    sum_of_passes += sum.cwiseProduct(sum) / n;  // n (sum / n)^2
    ++passes;
    first = i;
  }
  return sum_of_passes / static_cast<double>(passes);
}

void check_log(const Dataset& log, std::size_t index) {
  const std::string name = log.name.empty() ? fmt::format("log {}", index + 1) : log.name;
  const auto fail = [&](const std::string& what) { throw InputError(name, 0, "cannot calibrate: " + what); };
  if (!dynamic_cast<const VelocityModel*>(log.motion.get()))
    fail("expected commanded velocities (the velocity model, as MRCLAM logs them)");
  if (!dynamic_cast<const RangeBearingModel*>(log.observation.get())) fail("expected range-bearing measurements");
  if (log.truth.poses.size() < 2 || !log.truth.poses_have_heading)
    fail("expected a ground truth of poses with headings");
  if (log.truth.landmarks.empty()) fail("expected the true landmark positions");
}

}  // namespace

Calibration calibrate(std::span<const Dataset> datasets, const CalibrationOptions& options) {
  if (datasets.empty()) throw InputError("calibrate: expected at least one log");
  std::vector<Log> logs;
  logs.reserve(datasets.size());
  for (std::size_t i = 0; i < datasets.size(); ++i) {
    check_log(datasets[i], i);
    Log& log = logs.emplace_back(
        Log{&datasets[i], CommandStream(datasets[i], *datasets[i].motion), Truth(datasets[i].truth.poses, options.max_truth_gap_s), {}});
    for (const Event& e : datasets[i].events)
      if (const auto* s = std::get_if<ScanEvent>(&e)) log.scan_times.push_back(s->t);
  }
  const auto& first_model = dynamic_cast<const RangeBearingModel&>(*datasets.front().observation);
  Calibration out;
  out.measurement = first_model.params();

  // The delay: the grid point with the least heading error over windows every delay can reach.
  const double window = options.delay_window_s;
  const double reach = std::max(std::abs(options.min_command_delay_s), std::abs(options.max_command_delay_s));
  double best = std::numeric_limits<double>::infinity();
  // The bounds' 1e-9 keeps one that is a whole number of steps on the grid through rounding.
  for (auto k = static_cast<long>(std::ceil(options.min_command_delay_s / options.delay_step_s - 1e-9));
       static_cast<double>(k) * options.delay_step_s <= options.max_command_delay_s + 1e-9; ++k) {
    const double delay = static_cast<double>(k) * options.delay_step_s;
    double sum = 0.0;
    std::size_t windows = 0;
    for (const Log& log : logs) {
      for (double a = log.commands.begin() + reach; a + window + reach <= log.commands.end(); a += window) {
        Pose2 truth;
        if (!log.truth.motion(a, a + window, truth)) continue;
        const double e = motion_error(truth, log.commands.motion(a - delay, a + window - delay)).heading;
        sum += e * e;
        ++windows;
      }
    }
    if (windows > 0 && sum < best) {
      best = sum;
      out.command_delay_s = delay;
    }
  }
  if (!std::isfinite(best)) throw InputError("calibrate: the logs' commands and truth share no window to measure the delay on");

  // Motion noise over the stretches between scans, with the delay.
  const double delay = out.command_delay_s;
  const auto commanded = [&](const Log& log, double a, double b) { return log.commands.motion(a - delay, b - delay); };
  double sum_along = 0.0, sum_heading = 0.0, duration = 0.0;
  for (const Log& log : logs) {
    for (std::size_t i = 1; i < log.scan_times.size(); ++i) {
      const double a = log.scan_times[i - 1], b = log.scan_times[i];
      Pose2 truth;
      if (b <= a || a - delay < log.commands.begin() || b - delay > log.commands.end() || !log.truth.motion(a, b, truth))
        continue;
      const MotionError e = motion_error(truth, commanded(log, a, b));
      sum_along += e.along * e.along;
      sum_heading += e.heading * e.heading;
      duration += b - a;
      ++out.motion_windows;
    }
  }
  if (out.motion_windows < 2) throw InputError("calibrate: fewer than two stretches between scans with truth at both ends");
  out.motion.q_v = sum_along / duration;
  out.motion.q_omega = sum_heading / duration;

  for (const double horizon : options.report_horizons_s) {
    MotionErrorAtHorizon row{.horizon_s = horizon};
    double along = 0.0, heading = 0.0;
    for (const Log& log : logs) {
      for (double a = log.commands.begin() + std::max(delay, 0.0); a + horizon - std::min(delay, 0.0) <= log.commands.end();
           a += horizon) {
        Pose2 truth;
        if (!log.truth.motion(a, a + horizon, truth)) continue;
        const MotionError e = motion_error(truth, commanded(log, a, a + horizon));
        row.q_v += e.along * e.along;
        row.q_omega += e.heading * e.heading;
        along += e.along;
        heading += e.heading;
        ++row.windows;
      }
    }
    if (row.windows == 0) continue;
    const double time = horizon * static_cast<double>(row.windows);
    row.q_v /= time;
    row.q_omega /= time;
    row.speed_bias_mps = along / time;
    row.turn_rate_bias_radps = heading / time;
    out.motion_by_horizon.push_back(row);
  }

  // Measurement residuals from the true pose to the true landmark.
  std::vector<Residual> residuals;
  for (std::size_t li = 0; li < logs.size(); ++li) {
    const Dataset& d = *logs[li].dataset;
    std::map<int, Vector2> landmarks;
    for (const Landmark& l : d.truth.landmarks) landmarks[l.id] = l.position;
    for (const Event& e : d.events) {
      const auto* scan = std::get_if<ScanEvent>(&e);
      Pose2 x;
      if (!scan || !logs[li].truth.at(scan->t, x)) continue;
      for (const Observation& o : scan->observations) {
        const auto m = landmarks.find(o.id);
        if (m == landmarks.end()) continue;
        const Vector2 predicted = d.observation->predict(x, m->second);
        residuals.push_back({li, o.id, scan->t, predicted[0], d.observation->residual(o.z, predicted)});
      }
    }
  }
  if (residuals.size() < 2) throw InputError("calibrate: fewer than two observations of true landmarks with truth");
  // Gross outliers are what the known-identity gate would reject with the pose and the map known
  // exactly (innovation covariance R) under the noise being measured: a fixed point, reached by
  // measuring on the residuals the last estimate keeps until the kept set no longer changes.
  std::stable_sort(residuals.begin(), residuals.end(), [](const Residual& a, const Residual& b) {
    return std::tie(a.log, a.landmark, a.t) < std::tie(b.log, b.landmark, b.t);
  });
  const double gate = eval::chi_square_quantile(options.outlier_probability, 2.0);
  std::vector<Residual> kept = residuals;
  Vector2 white = Vector2::Zero();
  for (int iteration = 0; iteration < kMaxOutlierIterations; ++iteration) {
    white = batch_means_variance(kept, options.pass_gap_s, out.passes);
    const std::size_t before = kept.size();
    kept.clear();
    for (const Residual& r : residuals)
      if (r.error.cwiseProduct(r.error).cwiseQuotient(white).sum() <= gate) kept.push_back(r);
    if (kept.size() == before || kept.size() < 2) break;
  }
  if (kept.size() < 2) throw InputError("calibrate: the measurements hold fewer than two that are not gross outliers");
  out.gross_outliers = residuals.size() - kept.size();
  out.observations = kept.size();
  residuals = std::move(kept);
  out.measurement.sigma_range = std::sqrt(white[0]);
  out.measurement.sigma_bearing = std::sqrt(white[1]);
  Vector2 squares = Vector2::Zero();
  for (const Residual& r : residuals) squares += r.error.cwiseProduct(r.error);
  out.rms_range_m = std::sqrt(squares[0] / static_cast<double>(residuals.size()));
  out.rms_bearing_rad = std::sqrt(squares[1] / static_cast<double>(residuals.size()));

  std::map<long, MeasurementErrorAtRange> bins;
  for (const Residual& r : residuals) {
    const auto bin = static_cast<long>(std::floor(r.range / options.report_range_bin_m));
    MeasurementErrorAtRange& row = bins[bin];
    ++row.observations;
    row.rms_range_m += r.error[0] * r.error[0];
    row.rms_bearing_rad += r.error[1] * r.error[1];
    row.mean_range_m += r.error[0];
    row.mean_bearing_rad += r.error[1];
  }
  for (auto& [bin, row] : bins) {
    const auto n = static_cast<double>(row.observations);
    row.range_from_m = static_cast<double>(bin) * options.report_range_bin_m;
    row.range_to_m = row.range_from_m + options.report_range_bin_m;
    row.rms_range_m = std::sqrt(row.rms_range_m / n);
    row.rms_bearing_rad = std::sqrt(row.rms_bearing_rad / n);
    row.mean_range_m /= n;
    row.mean_bearing_rad /= n;
    out.measurement_by_range.push_back(row);
  }
  return out;
}

nlohmann::json to_json(const Calibration& c) {
  nlohmann::json motion = nlohmann::json::array();
  for (const MotionErrorAtHorizon& r : c.motion_by_horizon)
    motion.push_back({{"horizon_s", r.horizon_s},
                      {"windows", r.windows},
                      {"q_v_m2_per_s", r.q_v},
                      {"q_omega_rad2_per_s", r.q_omega},
                      {"speed_bias_mps", r.speed_bias_mps},
                      {"turn_rate_bias_radps", r.turn_rate_bias_radps}});
  nlohmann::json measurement = nlohmann::json::array();
  for (const MeasurementErrorAtRange& r : c.measurement_by_range)
    measurement.push_back({{"range_from_m", r.range_from_m},
                           {"range_to_m", r.range_to_m},
                           {"observations", r.observations},
                           {"rms_range_m", r.rms_range_m},
                           {"rms_bearing_rad", r.rms_bearing_rad},
                           {"mean_range_m", r.mean_range_m},
                           {"mean_bearing_rad", r.mean_bearing_rad}});
  return {{"command_delay_s", c.command_delay_s},
          {"q_v_m2_per_s", c.motion.q_v},
          {"q_omega_rad2_per_s", c.motion.q_omega},
          {"sigma_range_m", c.measurement.sigma_range},
          {"sigma_bearing_rad", c.measurement.sigma_bearing},
          {"motion_windows", c.motion_windows},
          {"observations", c.observations},
          {"gross_outliers", c.gross_outliers},
          {"passes", c.passes},
          {"rms_range_m", c.rms_range_m},
          {"rms_bearing_rad", c.rms_bearing_rad},
          {"motion_by_horizon", motion},
          {"measurement_by_range", measurement}};
}

}  // namespace slamkit
