// Trajectory, covariance and map files: exact round trips, files from other tools, and every way a
// file can be rejected (with the offending line named).
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/io/trajectory_io.hpp"
#include "test_data.hpp"

using namespace slamkit;

namespace {

/// A fresh directory per test, so tests may run in parallel processes.
class TrajectoryIo : public testing::Test {
 protected:
  void SetUp() override {
    const testing::TestInfo* info = testing::UnitTest::GetInstance()->current_test_info();
    dir_ = std::filesystem::temp_directory_path() /
           ("slamkit_trajectory_io_" + std::to_string(::getpid()) + "_" + info->name());
    std::filesystem::remove_all(dir_);
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  std::string write_text(const std::string& name, const std::string& text) const {
    const std::string p = path(name);
    std::ofstream(p) << text;
    return p;
  }

  /// Runs `f`, which must throw an InputError at `line` of `file`, and returns its message.
  template <typename F>
  static std::string input_error(F f, const std::string& file, std::size_t line) {
    const std::string message = test_data::input_error_at(f, file, line);
    if (line > 0 && !message.empty())
      EXPECT_NE(message.find(file + ":" + std::to_string(line) + ":"), std::string::npos);
    return message;
  }

  std::filesystem::path dir_;
};

bool contains(const std::string& haystack, const std::string& needle) {
  return haystack.find(needle) != std::string::npos;
}

}  // namespace

TEST_F(TrajectoryIo, TumRoundTripIsExact) {
  const std::vector<StampedPose> poses{
      {1700000000.123456, Pose2(0.0, 0.0, 0.0)},
      {1700000000.123456, Pose2(-12.5, 3.25, kPi)},  // repeated time is allowed
      {1700000000.2, Pose2(1e-9, -7.123456789012345, -kPi + 1e-12)},
      {1700000001.0, Pose2(123456.789, -0.1, 1.0)},
      {1700000002.5, Pose2(1e6, 2e-300, -2.9)},
  };
  write_tum(path("t.tum"), poses);
  const std::vector<StampedPose> back = read_tum(path("t.tum"));
  ASSERT_EQ(back.size(), poses.size());
  for (std::size_t i = 0; i < poses.size(); ++i) {
    SCOPED_TRACE(testing::Message() << "pose " << i);
    EXPECT_EQ(back[i].t, poses[i].t);
    EXPECT_EQ(back[i].pose[0], poses[i].pose[0]);
    EXPECT_EQ(back[i].pose[1], poses[i].pose[1]);
    EXPECT_NEAR(wrap_angle(back[i].pose[2] - poses[i].pose[2]), 0.0, 1e-14);
    EXPECT_GT(back[i].pose[2], -kPi);
    EXPECT_LE(back[i].pose[2], kPi);
  }
}

TEST_F(TrajectoryIo, TumLinesHoldAPlanarYawQuaternion) {
  write_tum(path("t.tum"), {{2.5, Pose2(1.0, -2.0, kPi / 2)}});
  std::istringstream lines(test_data::read_text(path("t.tum")));
  std::string header;
  std::getline(lines, header);
  EXPECT_EQ(header.front(), '#');
  double t, x, y, z, qx, qy, qz, qw;
  lines >> t >> x >> y >> z >> qx >> qy >> qz >> qw;
  ASSERT_TRUE(lines);
  EXPECT_EQ(t, 2.5);
  EXPECT_EQ(z, 0.0);
  EXPECT_EQ(qx, 0.0);
  EXPECT_EQ(qy, 0.0);
  EXPECT_NEAR(qz, std::sqrt(0.5), 1e-15);
  EXPECT_NEAR(qw, std::sqrt(0.5), 1e-15);
  std::string rest;
  lines >> rest;
  EXPECT_TRUE(rest.empty());
}

TEST_F(TrajectoryIo, ReadsTumFilesOfOtherTools) {
  // A 3-D orientation (yaw 0.5, pitch 0.2, roll 0.1) projects to its yaw; a quaternion printed with four
  // digits (norm 0.99998) is accepted; comments, blank lines and a nonzero z are fine.
  const Eigen::Quaterniond q = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX());
  std::ostringstream text;
  text.precision(17);
  text << "# timestamp tx ty tz qx qy qz qw\n\n"
       << "1.0 2.0 3.0 0.7 " << q.x() << ' ' << q.y() << ' ' << q.z() << ' ' << q.w() << "\n"
       << "2.0 4.0 5.0 0.0 0 0 0.7071 0.7071  # a quarter turn\n";
  const std::vector<StampedPose> poses = read_tum(write_text("other.tum", text.str()));
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_EQ(poses[0].pose.head<2>(), Vector2(2.0, 3.0));
  EXPECT_NEAR(poses[0].pose[2], 0.5, 1e-14);
  EXPECT_EQ(poses[1].t, 2.0);
  EXPECT_NEAR(poses[1].pose[2], kPi / 2, 1e-12);
}

TEST_F(TrajectoryIo, RejectsMalformedTumFiles) {
  const std::string missing = path("missing.tum");
  input_error([&] { read_tum(missing); }, missing, 0);

  const std::string few = write_text("few.tum", "# header\n0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n");
  EXPECT_TRUE(contains(input_error([&] { read_tum(few); }, few, 3), "expected 8 fields"));

  const std::string nan = write_text("nan.tum", "0 0 0 0 0 0 0 1\n\n1 nan 0 0 0 0 0 1\n");
  EXPECT_TRUE(contains(input_error([&] { read_tum(nan); }, nan, 3), "'nan'"));

  const std::string garbage = write_text("garbage.tum", "0 0 0 0 0 0 0 1x\n");
  input_error([&] { read_tum(garbage); }, garbage, 1);

  const std::string norm = write_text("norm.tum", "0 0 0 0 0 0 0 1\n1 0 0 0 0 0 0.5 0.5\n");
  EXPECT_TRUE(contains(input_error([&] { read_tum(norm); }, norm, 2), "quaternion"));

  const std::string order = write_text("order.tum", "5 0 0 0 0 0 0 1\n# comment\n4 0 0 0 0 0 0 1\n");
  EXPECT_TRUE(contains(input_error([&] { read_tum(order); }, order, 3), "line 1"));
}

TEST_F(TrajectoryIo, RefusesToWriteWhatCannotBeReadBack) {
  const std::string p = path("bad.tum");
  EXPECT_THROW(write_tum(p, {{0.0, Pose2(std::nan(""), 0, 0)}}), std::invalid_argument);
  EXPECT_THROW(write_tum(p, {{1.0, Pose2::Zero()}, {0.5, Pose2::Zero()}}), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(p));

  const std::string unwritable = path("no/such/dir/t.tum");
  input_error([&] { write_tum(unwritable, {}); }, unwritable, 0);
}

TEST_F(TrajectoryIo, EmptyTrajectoryRoundTrips) {
  write_tum(path("empty.tum"), {});
  EXPECT_TRUE(read_tum(path("empty.tum")).empty());
}

TEST_F(TrajectoryIo, CovarianceRoundTripIsExactAndSymmetric) {
  std::vector<double> t;
  std::vector<Matrix3> covariances;
  for (int i = 0; i < 5; ++i) {
    const Matrix3 a = Matrix3::Random();
    const Matrix3 c = a * a.transpose() + 1e-6 * Matrix3::Identity();
    t.push_back(0.1 * i);
    covariances.push_back(0.5 * (c + c.transpose()));  // the product is symmetric only up to rounding
  }
  covariances[2](0, 2) = covariances[2](2, 0) = -1e-17;
  write_pose_covariances(path("c.txt"), t, covariances);
  const PoseCovariances back = read_pose_covariances(path("c.txt"));
  ASSERT_EQ(back.t, t);
  ASSERT_EQ(back.covariance.size(), covariances.size());
  for (std::size_t i = 0; i < covariances.size(); ++i) EXPECT_EQ(back.covariance[i], covariances[i]) << i;
}

TEST_F(TrajectoryIo, RejectsMalformedCovarianceFiles) {
  const std::string few = write_text("few.txt", "0 1 0 0 1 0 1\n1 1 0 0 1 0\n");
  EXPECT_TRUE(contains(input_error([&] { read_pose_covariances(few); }, few, 2), "expected 7 fields"));

  const std::string negative = write_text("negative.txt", "0 1 0 0 -1 0 1\n");
  EXPECT_TRUE(contains(input_error([&] { read_pose_covariances(negative); }, negative, 1), "negative"));

  const std::string order = write_text("order.txt", "1 1 0 0 1 0 1\n0 1 0 0 1 0 1\n");
  input_error([&] { read_pose_covariances(order); }, order, 2);

  const std::string inf = write_text("inf.txt", "0 1 0 0 1 0 inf\n");
  input_error([&] { read_pose_covariances(inf); }, inf, 1);

  EXPECT_THROW(write_pose_covariances(path("w.txt"), {0.0, 1.0}, {Matrix3::Identity()}),
               std::invalid_argument);
  EXPECT_THROW(write_pose_covariances(path("w.txt"), {0.0}, {-Matrix3::Identity()}), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(path("w.txt")));
}

TEST_F(TrajectoryIo, MapRoundTripIsExact) {
  Matrix2 c;
  c << 0.25, -0.05, -0.05, 0.125;
  // Unidentified landmarks (kUnknownId) may repeat.
  const std::vector<Landmark> landmarks{{7, Vector2(1.5, -2.25), c},
                                        {kUnknownId, Vector2(4.0, 4.0), c},
                                        {0, Vector2(-1e5, 3.3333333333333335), Matrix2::Zero()},
                                        {kUnknownId, Vector2(-4.0, 4.0), c},
                                        {42, Vector2(0.1, 0.2), c}};
  write_map(path("m.txt"), landmarks);
  const std::vector<Landmark> back = read_map(path("m.txt"));
  ASSERT_EQ(back.size(), landmarks.size());
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    EXPECT_EQ(back[i].id, landmarks[i].id);
    EXPECT_EQ(back[i].position, landmarks[i].position);
    EXPECT_EQ(back[i].covariance, landmarks[i].covariance);
  }
}

TEST_F(TrajectoryIo, RejectsMalformedMapFiles) {
  const std::string duplicate = write_text("dup.txt", "1 0 0 1 0 1\n2 0 0 1 0 1\n# x\n1 5 5 1 0 1\n");
  EXPECT_TRUE(contains(input_error([&] { read_map(duplicate); }, duplicate, 4), "line 1"));

  const std::string fractional = write_text("frac.txt", "1.5 0 0 1 0 1\n");
  EXPECT_TRUE(contains(input_error([&] { read_map(fractional); }, fractional, 1), "integer"));

  const std::string negative_id = write_text("negid.txt", "-2 0 0 1 0 1\n");
  input_error([&] { read_map(negative_id); }, negative_id, 1);

  const std::string huge_id = write_text("huge.txt", "99999999999 0 0 1 0 1\n");
  input_error([&] { read_map(huge_id); }, huge_id, 1);

  const std::string variance = write_text("var.txt", "1 0 0 1 0 -1\n");
  input_error([&] { read_map(variance); }, variance, 1);

  const std::string fields = write_text("fields.txt", "1 0 0 1 0 1 9\n");
  input_error([&] { read_map(fields); }, fields, 1);

  EXPECT_THROW(write_map(path("w.txt"), {{1, Vector2::Zero()}, {1, Vector2::Ones()}}), std::invalid_argument);
  EXPECT_THROW(write_map(path("w.txt"), {{-3, Vector2::Zero()}}), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists(path("w.txt")));
}
