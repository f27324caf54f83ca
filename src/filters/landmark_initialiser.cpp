#include "slamkit/filters/landmark_initialiser.hpp"

#include <fmt/format.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/chi_square.hpp"

namespace slamkit {

void validate(const DelayedInitialisationOptions& o) {
  const auto fail = [](const std::string& what) { throw std::invalid_argument("delayed initialisation: " + what); };
  if (o.min_views < 0 || o.min_views > 1000) fail(fmt::format("min_views must be from 0 to 1000, found {}", o.min_views));
  if (o.max_views < 2 || o.max_views > 1000) fail(fmt::format("max_views must be from 2 to 1000, found {}", o.max_views));
  if (o.min_views > o.max_views)
    fail(fmt::format("min_views ({}) must not exceed max_views ({})", o.min_views, o.max_views));
  if (!(o.max_std_m > 0.0 && o.max_std_m <= 1e4)) fail(fmt::format("max_std_m must be > 0 and <= 10000, found {}", o.max_std_m));
  if (!(o.window_s > 0.0 && o.window_s <= 1e7)) fail(fmt::format("window_s must be > 0 and <= 1e7, found {}", o.window_s));
  if (!(o.gate_probability > 0.5 && o.gate_probability < 1.0))
    fail(fmt::format("gate_probability must be > 0.5 and < 1, found {}", o.gate_probability));
}

DelayedInitialisationOptions expecting_outliers_of(DelayedInitialisationOptions options,
                                                   const MeasurementLikelihood& likelihood,
                                                   const ObservationModel& model) {
  require_range_for(likelihood, model.rows().range, model.name());
  options.outliers_expected = likelihood.robust();
  options.outliers_read_long = likelihood.outliers_read_long();
  return options;
}

Matrix23 attached_to_pose(const Pose2& x, const Vector2& m) {
  const Vector2 lever = m - x.head<2>();
  Matrix23 gx;
  gx << 1.0, 0.0, -lever[1], 0.0, 1.0, lever[0];
  return gx;
}

std::unique_ptr<LandmarkInitialiser> make_landmark_initialiser(std::optional<LandmarkInitialisation> initialisation,
                                                               std::shared_ptr<const ObservationModel> model,
                                                               bool known_identities, bool calibrating_ranges,
                                                               const DelayedInitialisationOptions& delayed,
                                                               const RingInitialisationOptions& ring) {
  const LandmarkInitialisation chosen =
      initialisation.value_or(model->invertible() ? LandmarkInitialisation::kImmediate : LandmarkInitialisation::kDelayed);
  if (chosen == LandmarkInitialisation::kInverseDistance)
    throw std::invalid_argument("the inverse-distance start puts a landmark in the filter's joint Gaussian at its "
                                "first bearing: the filter 'ekf' (variants full and fej) keeps it; use delayed here");
  if (chosen != LandmarkInitialisation::kImmediate && !known_identities)
    throw std::invalid_argument(
        "delayed and ring landmark starts gather the observations of one landmark by its identity; they need "
        "association 'known'");
  if (chosen == LandmarkInitialisation::kRing && calibrating_ranges)
    throw std::invalid_argument("the ring landmark start does not carry a range calibration's correlations; with "
                                "--range-calibration use the delayed start");
  switch (chosen) {
    case LandmarkInitialisation::kDelayed: return std::make_unique<DelayedInitialiser>(std::move(model), delayed);
    case LandmarkInitialisation::kRing: return std::make_unique<RingInitialiser>(std::move(model), delayed, ring);
    case LandmarkInitialisation::kImmediate:
    case LandmarkInitialisation::kInverseDistance: break;
  }
  if (!model->invertible())
    throw std::invalid_argument("immediate landmark initialisation needs a measurement that places a landmark, which "
                                "a " + model->name() + " measurement does not; use delayed");
  return nullptr;
}

void DeadReckoning::advance(const MotionModel& motion, const Control& u, double dt) {
  const Matrix3 f = motion.jacobian_state(pose, u, dt);
  covariance = f * covariance * f.transpose() + motion.process_noise(pose, u, dt);
  pose = motion.predict(pose, u, dt);
}

InitialLandmark DeadReckoning::carried_to(const Pose2& x, const InitialLandmark& placed) const {
  const Matrix2 r = Eigen::Rotation2Dd(x[2] - pose[2]).toRotationMatrix();
  InitialLandmark landmark;
  landmark.mean = x.head<2>() + r * (placed.mean - pose.head<2>());
  landmark.gx = attached_to_pose(x, landmark.mean);
  landmark.covariance = r * placed.covariance * r.transpose();
  landmark.range_gain = r * placed.range_gain;
  landmark.range_scale_gain = r * placed.range_scale_gain;
  return landmark;
}

namespace {

/// The nearest positive semi-definite matrix to the symmetric part of a (eigenvalues clipped at 0).
Matrix3 clipped_psd(const Matrix3& a) {
  const Eigen::SelfAdjointEigenSolver<Matrix3> eigen(0.5 * (a + a.transpose()));
  return eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
}

/// The unit direction of the sensors' spread (principal axis of their positions) and their centroid.
struct Spread {
  Vector2 centre;
  Vector2 axis;
};

Spread spread_of(const std::vector<Vector2>& sensors) {
  Spread s;
  s.centre = Vector2::Zero();
  for (const Vector2& p : sensors) s.centre += p;
  s.centre /= static_cast<double>(sensors.size());
  Matrix2 scatter = Matrix2::Zero();
  for (const Vector2& p : sensors) scatter += (p - s.centre) * (p - s.centre).transpose();
  scatter /= static_cast<double>(sensors.size());
  const Eigen::SelfAdjointEigenSolver<Matrix2> eigen(scatter);
  s.axis = eigen.eigenvectors().col(1);
  return s;
}

/// m reflected across the line through `spread`'s centre along its axis.
Vector2 mirrored(const Vector2& m, const Spread& spread) {
  const Vector2 d = m - spread.centre;
  return spread.centre + 2.0 * d.dot(spread.axis) * spread.axis - d;
}

}  // namespace

DelayedInitialiser::DelayedInitialiser(std::shared_ptr<const ObservationModel> model,
                                       const DelayedInitialisationOptions& options)
    : model_(std::move(model)), options_((validate(options), options)) {
  if (!model_) throw std::invalid_argument("delayed landmark initialisation needs an observation model");
  const MeasuredRows rows = model_->rows();
  measures_range_ = rows.range >= 0;
  measures_bearing_ = rows.bearing >= 0;
  if (!measures_range_ && !measures_bearing_)
    throw std::invalid_argument("delayed landmark initialisation triangulates ranges or bearings; a " + model_->name() +
                                " measurement holds neither");
  // A circle meets another in two points and a third picks one; two rays meet in one.
  min_views_ = options_.min_views > 0 ? options_.min_views : measures_bearing_ ? 2 : 3;
  view_gate_ = eval::chi_square_quantile(options_.gate_probability, model_->dim());
  rival_gate_ = eval::chi_square_quantile(options_.gate_probability, 2.0);
  for (int n = 0; n <= options_.max_views; ++n) {
    const double dof = n * model_->dim() - 2.0;
    gates_.push_back(dof > 0.0 ? eval::chi_square_quantile(options_.gate_probability, dof) : INFINITY);
  }
}

bool DelayedInitialiser::explains(const Fit& fit, std::size_t views) const {
  // A quarter: radio ranges by a longer path come one in ten or so, rarely a quarter of 40.
  if (4 * fit.outliers > views) return false;
  return fit.chi2 <= gates_[views - fit.outliers];
}

DelayedInitialiser::Starts DelayedInitialiser::starts(const std::vector<View>& views,
                                                      const std::vector<Vector2>& sensors) const {
  const MeasuredRows rows = model_->rows();
  if (measures_bearing_) {
    if (measures_range_) {
      const View& last = views.back();
      const double a = last.pose[2] + last.z[rows.bearing];
      return {{sensors.back() + last.z[rows.range] * Vector2(std::cos(a), std::sin(a))}, 1};
    }
    // The point nearest every ray's line: sum n n^T m = sum n n^T s, n each line's normal.
    Matrix2 a = Matrix2::Zero();
    Vector2 b = Vector2::Zero();
    for (std::size_t i = 0; i < views.size(); ++i) {
      const double angle = views[i].pose[2] + views[i].z[rows.bearing];
      const Vector2 n(-std::sin(angle), std::cos(angle));
      a += n * n.transpose();
      b += n * n.dot(sensors[i]);
    }
    const Eigen::SelfAdjointEigenSolver<Matrix2> eigen(a);
    // Parallel rays (to a degree and a half) meet nowhere useful.
    if (!(eigen.eigenvalues()[0] > 1e-3 * eigen.eigenvalues()[1])) return {};
    return {{a.ldlt().solve(b)}, 1};
  }
  // Ranges: |m - s_i|^2 = r_i^2, less their mean, is linear in m: 2 (s_i - s)^T m = b_i.
  const Spread spread = spread_of(sensors);
  double mean_square_range = 0.0, mean_square_sensor = 0.0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    mean_square_range += views[i].z[rows.range] * views[i].z[rows.range];
    mean_square_sensor += sensors[i].squaredNorm();
  }
  mean_square_range /= static_cast<double>(views.size());
  mean_square_sensor /= static_cast<double>(views.size());
  const auto b_of = [&](std::size_t i) {
    const double r = views[i].z[rows.range];
    return sensors[i].squaredNorm() - mean_square_sensor - (r * r - mean_square_range);
  };
  // Along the spread's axis the equations fix m; across it only where the sensors spread that way
  // too. So m = c + alpha u + beta n, alpha from the axis, beta from the ranges themselves.
  const Vector2 u = spread.axis, n(-u[1], u[0]);
  double along_num = 0.0, along_den = 0.0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const double a_i = 2.0 * (sensors[i] - spread.centre).dot(u);
    along_num += a_i * (b_of(i) - 2.0 * (sensors[i] - spread.centre).dot(spread.centre));
    along_den += a_i * a_i;
  }
  if (!(along_den > 0.0)) return {};
  const double alpha = along_num / along_den;
  // beta^2 = r_i^2 - |c + alpha u - s_i|^2 averaged, taken about the line through the sensors.
  double beta_square = 0.0;
  for (std::size_t i = 0; i < views.size(); ++i) {
    const double r = views[i].z[rows.range];
    const Vector2 foot = spread.centre + alpha * u;
    beta_square += r * r - (foot - sensors[i]).squaredNorm();
  }
  const double beta = std::sqrt(std::max(0.0, beta_square / static_cast<double>(views.size())));
  const Vector2 foot = spread.centre + alpha * u;
  return {{foot + beta * n, foot - beta * n}, 2};
}

std::optional<DelayedInitialiser::Fit> DelayedInitialiser::fit(const std::vector<View>& views,
                                                               const Matrix3& odometry_covariance_now,
                                                               Vector2 start, double trim_above) const {
  const MeasurementCovariance r = model_->noise();
  FitScratch& scratch = fit_scratch_;
  // Each view's weight: R and the pose uncertainty the vehicle has gained since (the landmark is
  // placed relative to the current pose, so what was already uncertain then it inherits through
  // the current pose's covariance instead).
  std::vector<Matrix3>& gained = scratch.gained;
  gained.clear();
  for (const View& v : views) gained.push_back(clipped_psd(odometry_covariance_now - v.odometry_covariance));
  Fit out;
  out.position = start;
  PoseJacobian hx;
  LandmarkJacobian hm;
  const int range_row = model_->rows().range;
  Eigen::VectorXd& common_range = scratch.common_range;
  common_range.setZero(model_->dim());
  if (range_row >= 0) common_range[range_row] = 1.0;
  constexpr int kMaxIterations = 30;
  bool converged = false;
  for (int iteration = 0;; ++iteration) {
    Matrix2 information = Matrix2::Zero();
    Vector2 gradient = Vector2::Zero();
    Vector2 range_pull = Vector2::Zero(), range_scale_pull = Vector2::Zero();
    out.chi2 = 0.0;
    out.outliers = 0;
    out.worst_chi2 = -1.0;
    for (std::size_t i = 0; i < views.size(); ++i) {
      const View& v = views[i];
      model_->jacobians(v.pose, out.position, hx, hm);
      Eigen::VectorXd& residual = scratch.residual;
      residual = model_->residual(v.z, model_->predict(v.pose, out.position));
      scratch.s = r + hx * gained[i] * hx.transpose();
      const Eigen::LLT<Eigen::MatrixXd>& llt = scratch.llt.compute(scratch.s);
      if (llt.info() != Eigen::Success) return std::nullopt;
      Eigen::VectorXd& w_residual = scratch.w_residual;
      w_residual = llt.solve(residual);
      const double chi2 = residual.dot(w_residual);
      const bool read_short = options_.outliers_read_long && range_row >= 0 && residual[range_row] < 0.0;
      if (chi2 > trim_above && !read_short) {
        ++out.outliers;
        continue;
      }
      scratch.hm = hm;
      const Eigen::MatrixXd& w_hm = scratch.w_hm = llt.solve(scratch.hm);
      information.noalias() += hm.transpose() * w_hm;
      gradient += hm.transpose() * w_residual;
      // At the optimum sum Hm^T W (z - h(m)) = 0; changes dz of the ranges move m by
      // information^-1 sum Hm^T W e_range dz: dz = 1 for an offset, dz = r for a scale.
      scratch.w_range = llt.solve(common_range);
      const Vector2 pull = hm.transpose() * scratch.w_range;
      range_pull += pull;
      if (range_row >= 0) range_scale_pull += v.z[range_row] * pull;
      out.chi2 += chi2;
      if (chi2 > out.worst_chi2) {
        out.worst_chi2 = chi2;
        out.worst = i;
      }
    }
    const Eigen::LLT<Matrix2> llt(information);
    if (llt.info() != Eigen::Success || !information.allFinite()) return std::nullopt;
    out.covariance = llt.solve(Matrix2::Identity());
    out.range_gain = out.covariance * range_pull;
    out.range_scale_gain = out.covariance * range_scale_pull;
    // The last pass evaluates the information and residuals at the converged position.
    if (converged || iteration == kMaxIterations) break;
    const Vector2 step = llt.solve(gradient);
    if (!step.allFinite()) return std::nullopt;
    out.position += step;
    converged = step.norm() < 1e-9 * (1.0 + out.position.norm());
  }
  return out;
}

std::optional<InitialLandmark> DelayedInitialiser::offer(int id, const Pose2& x, const Matrix3& odometry_covariance,
                                                         const Measurement& z, double t,
                                                         const RangeCorrection& correction) {
  latest_t_ = std::max(latest_t_, t);
  std::vector<View>& raw = views_[id];
  if (const auto found = candidates_.find(id); found != candidates_.end()) found->second.fits.clear();  // found afresh below
  raw.push_back({x, odometry_covariance, z, t});
  std::erase_if(raw, [&](const View& v) { return v.t < t - options_.window_s; });
  if (raw.size() > static_cast<std::size_t>(options_.max_views)) raw.erase(raw.begin());
  if (raw.size() < static_cast<std::size_t>(min_views_)) return std::nullopt;

  // The views read through the calibration, copied only where there is one.
  const bool calibrated = measures_range_ && (correction.offset_m != 0.0 || correction.scale_error != 0.0);
  if (calibrated) {
    corrected_.assign(raw.begin(), raw.end());
    for (View& v : corrected_) v.z[model_->rows().range] = correction.distance(v.z[model_->rows().range]);
  }
  const std::vector<View>& views = calibrated ? corrected_ : raw;
  std::vector<Vector2>& sensors = sensors_;
  sensors.clear();
  for (const View& v : views) sensors.push_back(model_->sensor_position(v.pose));
  const double trim = options_.outliers_expected ? view_gate_ : INFINITY;
  std::vector<Fit>& fits = fits_;
  fits.clear();
  const Starts start_points = starts(views, sensors);
  for (const Vector2& start : start_points.all())
    if (const std::optional<Fit> f = fit(views, odometry_covariance, start, trim)) fits.push_back(*f);
  if (fits.empty()) return std::nullopt;
  // A copy: the ambiguity test below adds to `fits`. An outlier costs what the gate allows one view.
  const auto cost = [&](const Fit& f) { return f.chi2 + static_cast<double>(f.outliers) * view_gate_; };
  const Fit best =
      *std::min_element(fits.begin(), fits.end(), [&](const Fit& a, const Fit& b) { return cost(a) < cost(b); });
  if (!explains(best, views.size())) {
    // Where outliers are expected each fit has left them out already: wait for more views.
    if (options_.outliers_expected) return std::nullopt;
    // An observation no position explains with the others, most likely an outlier: the one whose
    // absence leaves the others fitting best.
    std::size_t drop = best.worst;
    double least = INFINITY;
    std::vector<View>& others = others_;
    for (std::size_t i = 0; i < views.size(); ++i) {
      others.assign(views.begin(), views.end());
      others.erase(others.begin() + static_cast<std::ptrdiff_t>(i));
      if (const std::optional<Fit> f = fit(others, odometry_covariance, best.position, INFINITY); f && f->chi2 < least) {
        least = f->chi2;
        drop = i;
      }
    }
    raw.erase(raw.begin() + static_cast<std::ptrdiff_t>(drop));
    return std::nullopt;
  }
  std::vector<Fit>& held = candidates_[id].fits;
  candidates_[id].t = t;
  held.push_back(best);
  const Eigen::SelfAdjointEigenSolver<Matrix2> eigen(best.covariance);
  if (!(eigen.eigenvalues()[1] <= options_.max_std_m * options_.max_std_m)) return std::nullopt;
  // Ranges along a line fit the landmark and its mirror image equally: wait while another position
  // beyond the best's 3-sigma (the mirror image, or another fit's answer) explains the views too, or,
  // where outliers are expected, scores within the 2-dof gate of the best. Those it waits on are
  // held for hypotheses().
  if (!measures_bearing_)
    if (const std::optional<Fit> m =
            fit(views, odometry_covariance, mirrored(best.position, spread_of(sensors)), trim))
      fits.push_back(*m);
  const Matrix2 information = best.covariance.inverse();
  const auto distinct = [&](const Fit& f) {
    return std::none_of(held.begin(), held.end(), [&](const Fit& h) {
      const Vector2 apart = f.position - h.position;
      return apart.dot(information * apart) <= 9.0;
    });
  };
  for (const Fit& other : fits) {
    const bool rival = explains(other, views.size()) ||
                       (options_.outliers_expected && cost(other) <= cost(best) + rival_gate_);
    if (rival && distinct(other)) held.push_back(other);
  }
  if (held.size() > 1) return std::nullopt;
  if (measures_bearing_) {
    // A bearing sees forward along its ray: a position behind any sensor is not the landmark.
    const int row = model_->rows().bearing;
    for (std::size_t i = 0; i < views.size(); ++i) {
      const double angle = views[i].pose[2] + views[i].z[row];
      if ((best.position - sensors[i]).dot(Vector2(std::cos(angle), std::sin(angle))) <= 0.0) return std::nullopt;
    }
  }
  InitialLandmark landmark;
  landmark.mean = best.position;
  landmark.gx = attached_to_pose(x, landmark.mean);
  landmark.covariance = 0.5 * (best.covariance + best.covariance.transpose());
  landmark.range_gain = best.range_gain;
  landmark.range_scale_gain = best.range_scale_gain;
  views_.erase(id);
  candidates_.erase(id);
  return landmark;
}

std::vector<LandmarkHypothesis> DelayedInitialiser::hypotheses() const {
  std::vector<LandmarkHypothesis> out;
  for (const auto& [id, found] : candidates_) {
    if (found.t < latest_t_ - options_.window_s) continue;
    for (const Fit& f : found.fits)
      out.push_back({{id, f.position, f.covariance}, 1.0 / static_cast<double>(found.fits.size())});
  }
  return out;
}

RingInitialiser::RingInitialiser(std::shared_ptr<const ObservationModel> model,
                                 const DelayedInitialisationOptions& options, const RingInitialisationOptions& ring)
    : model_(std::move(model)),
      options_((validate(options), options)),
      ring_(ring),
      range_gate_(eval::chi_square_quantile(options_.gate_probability, 1.0)),
      worse_gate_(eval::chi_square_quantile(options_.gate_probability, 2.0)) {
  if (!model_) throw std::invalid_argument("the ring landmark start needs an observation model");
  if (model_->rows().range < 0 || model_->rows().bearing >= 0)
    throw std::invalid_argument("the ring landmark start is for a range alone; a " + model_->name() +
                                " measurement is not one");
  if (ring_.max_hypotheses < 4 || ring_.max_hypotheses > 10000)
    throw std::invalid_argument(
        fmt::format("the ring start's max_hypotheses must be from 4 to 10000, found {}", ring_.max_hypotheses));
}

RingInitialiser::Ring RingInitialiser::draw(const Pose2& x, const Matrix3& odometry_covariance, double distance,
                                            double t) const {
  const int row = model_->rows().range;
  const double sigma = std::sqrt(model_->noise()(row, row));
  const Vector2 sensor = model_->sensor_position(x);
  // One range deviation apart along the ring, each hypothesis half a spacing wide along it: the
  // neighbours overlap at one deviation, so the ring leaves no gap where the landmark could hide.
  const double circumference = 2.0 * kPi * std::max(distance, sigma);
  const int n = static_cast<int>(
      std::clamp(std::ceil(circumference / sigma), 4.0, static_cast<double>(ring_.max_hypotheses)));
  const double along = 0.5 * circumference / n;
  Ring ring;
  ring.t0 = t;
  ring.odometry_covariance = odometry_covariance;
  ring.hypotheses.reserve(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const double angle = 2.0 * kPi * k / n;
    const Vector2 radial(std::cos(angle), std::sin(angle)), tangent(-radial[1], radial[0]);
    const Matrix2 covariance =
        sigma * sigma * radial * radial.transpose() + along * along * tangent * tangent.transpose();
    ring.hypotheses.push_back({sensor + distance * radial, covariance, -std::log(static_cast<double>(n)), 0.0});
  }
  return ring;
}

std::optional<InitialLandmark> RingInitialiser::offer(int id, const Pose2& x, const Matrix3& odometry_covariance,
                                                      const Measurement& z, double t,
                                                      const RangeCorrection& correction) {
  latest_t_ = std::max(latest_t_, t);
  const int row = model_->rows().range;
  Measurement distance = z;
  distance[row] = correction.distance(z[row]);
  // Nothing a ring could be drawn from (or updated with).
  if (!(distance[row] > 0.0)) return std::nullopt;
  const auto found = rings_.find(id);
  if (found == rings_.end() || t - found->second.t0 > options_.window_s) {
    rings_[id] = draw(x, odometry_covariance, distance[row], t);
    return std::nullopt;
  }
  Ring& ring = found->second;
  // The hypotheses are kept relative to the current pose, as a landmark joins the state: relative to
  // it, each drifts by what dead reckoning has gained since the last range.
  const Matrix3 gained = clipped_psd(odometry_covariance - ring.odometry_covariance);
  const MeasurementCovariance r = model_->noise();
  std::vector<Hypothesis> updated = ring.hypotheses;
  bool explained = false;
  PoseJacobian hx;
  LandmarkJacobian hm;
  for (Hypothesis& h : updated) {
    const Matrix23 attached = attached_to_pose(x, h.mean);
    h.covariance += attached * gained * attached.transpose();
    model_->jacobians(x, h.mean, hx, hm);
    const Eigen::VectorXd residual = model_->residual(distance, model_->predict(x, h.mean));
    const Eigen::MatrixXd s = hm * h.covariance * hm.transpose() + r;
    const Eigen::LLT<Eigen::MatrixXd> llt(s);
    if (llt.info() != Eigen::Success) return std::nullopt;
    const Eigen::MatrixXd gain = h.covariance * hm.transpose() * llt.solve(Eigen::MatrixXd::Identity(s.rows(), s.cols()));
    const double chi2 = residual.dot(llt.solve(residual));
    explained = explained || chi2 <= range_gate_;
    h.chi2 += chi2;
    h.mean += gain * residual;
    const Matrix2 p = h.covariance - gain * s * gain.transpose();
    h.covariance = 0.5 * (p + p.transpose());
    const double log_det = 2.0 * Eigen::MatrixXd(llt.matrixL()).diagonal().array().log().sum();
    h.log_weight += -0.5 * (chi2 + log_det + static_cast<double>(s.rows()) * std::log(2.0 * kPi));
  }
  // A range no hypothesis explains is most likely an outlier: the ring waits for the next.
  if (!explained) return std::nullopt;
  ++ring.updates;
  // Dropped: a hypothesis inconsistent with the ranges on its own, or one that explains them worse
  // than the best does by more than two degrees of freedom (its position) allow.
  const double consistent = eval::chi_square_quantile(options_.gate_probability, ring.updates);
  double least = INFINITY;
  for (const Hypothesis& h : updated) least = std::min(least, h.chi2);
  // Written so that a NaN fails too.
  std::erase_if(updated,
                [&](const Hypothesis& h) { return !(h.chi2 <= consistent && h.chi2 <= least + worse_gate_); });
  if (updated.empty()) {
    rings_[id] = draw(x, odometry_covariance, distance[row], t);
    return std::nullopt;
  }
  double best = -INFINITY;
  for (const Hypothesis& h : updated) best = std::max(best, h.log_weight);
  double total = 0.0;
  for (const Hypothesis& h : updated) total += std::exp(h.log_weight - best);
  for (Hypothesis& h : updated) h.log_weight -= best + std::log(total);
  ring.hypotheses = std::move(updated);
  ring.odometry_covariance = odometry_covariance;

  // It starts when every live hypothesis, however unlikely, lies near the others: the spread of
  // them all, equally weighted, within max_std_m. The likelihoods only weigh where it starts (the
  // mixture's moment-matched Gaussian): hypotheses of different widths are weighed by their own
  // innovation covariances, which says more about their widths than about which side of a road the
  // landmark is on.
  const auto moments = [&](const auto& weight) {
    Vector2 mean = Vector2::Zero();
    for (const Hypothesis& h : ring.hypotheses) mean += weight(h) * h.mean;
    Matrix2 covariance = Matrix2::Zero();
    for (const Hypothesis& h : ring.hypotheses)
      covariance += weight(h) * (h.covariance + (h.mean - mean) * (h.mean - mean).transpose());
    return std::pair{mean, covariance};
  };
  const double equal = 1.0 / static_cast<double>(ring.hypotheses.size());
  const Matrix2 spread = moments([&](const Hypothesis&) { return equal; }).second;
  const Eigen::SelfAdjointEigenSolver<Matrix2> eigen(spread);
  if (!(eigen.eigenvalues()[1] <= options_.max_std_m * options_.max_std_m)) return std::nullopt;
  const auto [mean, covariance] = moments([](const Hypothesis& h) { return std::exp(h.log_weight); });
  InitialLandmark landmark;
  landmark.mean = mean;
  landmark.gx = attached_to_pose(x, mean);
  landmark.covariance = 0.5 * (covariance + covariance.transpose());
  rings_.erase(id);
  return landmark;
}

std::vector<LandmarkHypothesis> RingInitialiser::hypotheses() const {
  std::vector<LandmarkHypothesis> out;
  for (const auto& [id, ring] : rings_) {
    if (ring.t0 < latest_t_ - options_.window_s) continue;  // drawn afresh at its next range
    // Normalised already: drawn at -log n each, renormalised after every update.
    for (const Hypothesis& h : ring.hypotheses) out.push_back({{id, h.mean, h.covariance}, std::exp(h.log_weight)});
  }
  return out;
}

std::vector<LandmarkHypothesis> hypotheses_at(const LandmarkInitialiser& initialiser, const DeadReckoning& dead_reckoning,
                                              const Pose2& x) {
  std::vector<LandmarkHypothesis> out = initialiser.hypotheses();
  for (LandmarkHypothesis& h : out) {
    InitialLandmark placed;
    placed.mean = h.landmark.position;
    placed.covariance = h.landmark.covariance;
    const InitialLandmark here = dead_reckoning.carried_to(x, placed);
    h.landmark.position = here.mean;
    h.landmark.covariance = here.covariance;
  }
  return out;
}

std::vector<RingInitialiser::Hypothesis> RingInitialiser::hypotheses(int id) const {
  const auto found = rings_.find(id);
  return found == rings_.end() ? std::vector<Hypothesis>{} : found->second.hypotheses;
}

}  // namespace slamkit
