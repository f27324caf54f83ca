#pragma once
// Noise settings measured from logs with ground truth: what a filter should assume about a robot
// that logs commanded velocities (VelocityModel) and range-bearing measurements of identified
// landmarks (RangeBearingModel), such as the MRCLAM robots.
//
// The errors of such a log are neither white nor unbiased, and the estimates below say how each one
// is turned into the white-noise terms the models have:
//
// - Command delay. A robot carries out a command some time after it logs it, so over short windows
//   the commanded motion leads the true one and their difference looks like large turn-rate noise
//   that cancels over longer windows. The delay is the one that minimises the heading error of the
//   commanded motion over windows of delay_window_s (the maximum-likelihood delay for white
//   turn-rate noise), searched on a grid of delay_step_s; the motion noise is then measured with it.
// - Motion noise. Over each stretch between two consecutive scans (the horizons over which a filter
//   predicts without a measurement) the commanded motion, integrated from the true pose at the start,
//   is compared with the true motion. q_v is the along-track error's variance and q_omega the
//   heading error's, per unit time, pooled over the stretches (sum of squares over sum of durations):
//   biases and slowly varying errors enter as the variance they add over the horizons the log has.
// - Measurement noise. Residuals are the measurement less the model's prediction from the true pose
//   to the true landmark. Gross outliers are left out: those the filters' known-identity gate would
//   reject with the pose and map known exactly (normalised squared residual beyond the chi-square
//   quantile of outlier_probability, 2 dof) under the noise measured on the others. The errors are strongly correlated in time (the same landmark seen from nearly the same
//   place), and a filter averaging n observations of a pass believes the error of their mean is
//   sigma^2 / n; the equivalent white noise is therefore measured by batch means, the mean over the
//   passes of n times the squared mean residual of the pass (a pass: observations of one landmark
//   with no gap longer than pass_gap_s), which equals sigma^2 for white noise and grows with the
//   correlation. rms_range_m and rms_bearing_rad are the per-observation figures for comparison.
#include <cstddef>
#include <nlohmann/json_fwd.hpp>
#include <span>
#include <vector>

#include "slamkit/core/dataset.hpp"
#include "slamkit/models/observation_model.hpp"
#include "slamkit/models/velocity_model.hpp"

namespace slamkit {

struct CalibrationOptions {
  /// The delay search covers [min_command_delay_s, max_command_delay_s] relative to the log as read
  /// (a negative delay undoes part of one the reader already applies).
  double min_command_delay_s = -1.0;
  double max_command_delay_s = 1.0;
  double delay_step_s = 0.01;
  double delay_window_s = 1.0;
  /// A landmark unobserved for longer than this starts a new pass.
  double pass_gap_s = 2.0;
  /// Residuals beyond this chi-square quantile (2 dof) of the measured noise are gross outliers: the
  /// default is the known-identity gate's (AssociationConfig::new_landmark_probability).
  double outlier_probability = 0.9999;
  /// Truth samples further apart than this are not interpolated between: a window or an observation
  /// that needs the truth inside such a gap is left out.
  double max_truth_gap_s = 0.5;
  /// Horizons of the motion report (the noise itself comes from the stretches between scans).
  std::vector<double> report_horizons_s = {0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 20.0};
  /// Width of the range bins of the measurement report [m].
  double report_range_bin_m = 1.0;
};

/// The commanded motion's error over windows of one length, per unit time.
struct MotionErrorAtHorizon {
  double horizon_s = 0.0;
  std::size_t windows = 0;
  double q_v = 0.0;      // along-track error variance per second [m^2/s]
  double q_omega = 0.0;  // heading error variance per second [rad^2/s]
  double speed_bias_mps = 0.0;        // mean along-track error per second
  double turn_rate_bias_radps = 0.0;  // mean heading error per second
};

/// Per-observation measurement residuals of one range bin.
struct MeasurementErrorAtRange {
  double range_from_m = 0.0, range_to_m = 0.0;
  std::size_t observations = 0;
  double rms_range_m = 0.0, rms_bearing_rad = 0.0;
  double mean_range_m = 0.0, mean_bearing_rad = 0.0;
};

struct Calibration {
  /// Added to the delay the logs were read with.
  double command_delay_s = 0.0;
  VelocityModel::Params motion;
  /// The logs' observation model with sigma_range and sigma_bearing replaced.
  RangeBearingModel::Params measurement;

  std::size_t motion_windows = 0;  // stretches between scans used for the motion noise
  std::size_t observations = 0;    // residuals used (gross outliers excluded)
  std::size_t gross_outliers = 0;
  std::size_t passes = 0;
  double rms_range_m = 0.0, rms_bearing_rad = 0.0;  // per observation, about zero
  std::vector<MotionErrorAtHorizon> motion_by_horizon;
  std::vector<MeasurementErrorAtRange> measurement_by_range;
};

/// Calibrates from `logs`, each with the truth's poses (with headings) and landmarks, identified
/// observations, a VelocityModel and a RangeBearingModel (all logs the same observation model).
/// Throws InputError naming the log for one that lacks any of these, or when the logs hold too few
/// windows or observations to estimate from.
Calibration calibrate(std::span<const Dataset> logs, const CalibrationOptions& options = {});

/// The calibration and its evidence (the tables above), for reports.
nlohmann::json to_json(const Calibration& calibration);

}  // namespace slamkit
