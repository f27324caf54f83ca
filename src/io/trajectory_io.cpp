#include "slamkit/io/trajectory_io.hpp"

#include <fmt/format.h>

#include <climits>
#include <cmath>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>
#include <utility>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/text_reader.hpp"
#include "line_writer.hpp"

namespace slamkit {

namespace {

/// The writers' counterpart of the readers' checks, run before the file is created.
[[noreturn]] void refuse(const std::string& path, const std::string& message) {
  throw std::invalid_argument("cannot write " + path + ": " + message);
}

template <typename Covariance>
bool variances_valid(const Covariance& c) {
  return c.allFinite() && (c.diagonal().array() >= 0.0).all();
}

/// Tracks the previous line's time for the non-decreasing check of the readers.
class TimeOrder {
 public:
  void check(const TextReader& reader, double t) {
    if (line_ != 0 && t < previous_)
      reader.fail(
          fmt::format("time {} is before time {} on line {}; times must not decrease", t, previous_, line_));
    previous_ = t;
    line_ = reader.line_number();
  }

 private:
  double previous_ = 0.0;
  std::size_t line_ = 0;
};

}  // namespace

void write_tum(const std::string& path, const std::vector<StampedPose>& poses) {
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!std::isfinite(poses[i].t) || !poses[i].pose.allFinite())
      refuse(path, fmt::format("pose {} is not finite", i));
    if (i > 0 && poses[i].t < poses[i - 1].t)
      refuse(path, fmt::format("pose {} is earlier than pose {}", i, i - 1));
  }
  LineWriter out(path);
  out.text("# t x y z qx qy qz qw");
  out.end_line();
  for (const StampedPose& p : poses) {
    const double half = 0.5 * p.pose[2];
    out.line(FMT_COMPILE("{} {} {} 0 0 0 {} {}"), p.t, p.pose[0], p.pose[1], std::sin(half), std::cos(half));
  }
  out.finish();
}

std::vector<StampedPose> read_tum(const std::string& path) {
  TextReader reader(path);
  std::vector<StampedPose> poses;
  TimeOrder order;
  while (reader.next()) {
    reader.expect_fields(8, "t x y z qx qy qz qw");
    StampedPose p;
    p.t = reader.number(0, "t");
    p.pose[0] = reader.number(1, "x");
    p.pose[1] = reader.number(2, "y");
    reader.number(3, "z");  // dropped, but a malformed value is still an error
    double qx = reader.number(4, "qx");
    double qy = reader.number(5, "qy");
    double qz = reader.number(6, "qz");
    double qw = reader.number(7, "qw");
    const double norm = std::sqrt(qx * qx + qy * qy + qz * qz + qw * qw);
    // A looser norm would accept columns in the wrong order or a quaternion that is no rotation at all;
    // a tighter one would reject files printed with a few significant digits.
    if (std::abs(norm - 1.0) > 1e-3)
      reader.fail(fmt::format("quaternion (qx qy qz qw) has norm {}, expected 1 within 1e-3", norm));
    qx /= norm;
    qy /= norm;
    qz /= norm;
    qw /= norm;
    p.pose[2] = wrap_angle(std::atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz)));
    order.check(reader, p.t);
    poses.push_back(p);
  }
  return poses;
}

void write_pose_covariances(const std::string& path, const std::vector<double>& t,
                            const std::vector<Matrix3>& covariances) {
  if (t.size() != covariances.size())
    refuse(path, fmt::format("{} times but {} covariances", t.size(), covariances.size()));
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (!std::isfinite(t[i])) refuse(path, fmt::format("time {} is not finite", i));
    if (i > 0 && t[i] < t[i - 1]) refuse(path, fmt::format("time {} is earlier than time {}", i, i - 1));
    if (!variances_valid(covariances[i]))
      refuse(path, fmt::format("covariance {} is not finite or has a negative variance", i));
  }
  LineWriter out(path);
  out.text("# t c_xx c_xy c_xt c_yy c_yt c_tt");
  out.end_line();
  for (std::size_t i = 0; i < t.size(); ++i) {
    const Matrix3& c = covariances[i];
    out.line(FMT_COMPILE("{} {} {} {} {} {} {}"), t[i], c(0, 0), c(0, 1), c(0, 2), c(1, 1), c(1, 2), c(2, 2));
  }
  out.finish();
}

PoseCovariances read_pose_covariances(const std::string& path) {
  TextReader reader(path);
  PoseCovariances result;
  TimeOrder order;
  while (reader.next()) {
    reader.expect_fields(7, "t c_xx c_xy c_xt c_yy c_yt c_tt");
    const double t = reader.number(0, "t");
    Matrix3 c;
    c(0, 0) = reader.number(1, "c_xx");
    c(0, 1) = c(1, 0) = reader.number(2, "c_xy");
    c(0, 2) = c(2, 0) = reader.number(3, "c_xt");
    c(1, 1) = reader.number(4, "c_yy");
    c(1, 2) = c(2, 1) = reader.number(5, "c_yt");
    c(2, 2) = reader.number(6, "c_tt");
    if (!variances_valid(c)) reader.fail("variances (c_xx, c_yy, c_tt) must not be negative");
    order.check(reader, t);
    result.t.push_back(t);
    result.covariance.push_back(c);
  }
  return result;
}

void write_map(const std::string& path, const std::vector<Landmark>& landmarks) {
  std::unordered_set<int> ids;
  ids.reserve(landmarks.size());
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    const Landmark& l = landmarks[i];
    if (l.id < kUnknownId) refuse(path, fmt::format("landmark {} has invalid id {}", i, l.id));
    if (l.id != kUnknownId && !ids.insert(l.id).second)
      refuse(path, fmt::format("landmark id {} occurs more than once", l.id));
    if (!l.position.allFinite() || !variances_valid(l.covariance))
      refuse(path, fmt::format("landmark {} is not finite or has a negative variance", l.id));
  }
  LineWriter out(path);
  out.text("# id x y c_xx c_xy c_yy");
  out.end_line();
  for (const Landmark& l : landmarks)
    out.line(FMT_COMPILE("{} {} {} {} {} {}"), l.id, l.position.x(), l.position.y(), l.covariance(0, 0),
             l.covariance(0, 1), l.covariance(1, 1));
  out.finish();
}

std::vector<Landmark> read_map(const std::string& path) {
  TextReader reader(path);
  std::vector<Landmark> landmarks;
  std::unordered_map<int, std::size_t> line_of_id;
  while (reader.next()) {
    reader.expect_fields(6, "id x y c_xx c_xy c_yy");
    const long id = reader.integer(0, "id");
    if (id < kUnknownId || id > INT_MAX)
      reader.fail(
          fmt::format("landmark id {} is neither {} (unidentified) nor in 0..{}", id, kUnknownId, INT_MAX));
    Landmark l;
    l.id = static_cast<int>(id);
    l.position.x() = reader.number(1, "x");
    l.position.y() = reader.number(2, "y");
    l.covariance(0, 0) = reader.number(3, "c_xx");
    l.covariance(0, 1) = l.covariance(1, 0) = reader.number(4, "c_xy");
    l.covariance(1, 1) = reader.number(5, "c_yy");
    if (!variances_valid(l.covariance)) reader.fail("variances (c_xx, c_yy) must not be negative");
    if (l.id != kUnknownId) {
      if (const auto [it, inserted] = line_of_id.emplace(l.id, reader.line_number()); !inserted)
        reader.fail(fmt::format("landmark id {} already appears on line {}", l.id, it->second));
    }
    landmarks.push_back(l);
  }
  return landmarks;
}

}  // namespace slamkit
