#pragma once
// Text files for estimated and true trajectories, their pose covariances and landmark maps: what the
// CLI writes after a run and what evaluation reads back, also from other tools.
//
// All three are whitespace-separated, one record per line, with '#' comment lines (each writer starts
// its file with one naming the columns). Writers print the shortest decimal form that reads back to
// the identical double. Readers report every problem as an InputError naming the file and line;
// writers refuse, with std::invalid_argument and before creating the file, any data their reader
// would reject, so every file slamkit writes it can read again. Failing to create or write a file is
// an InputError naming the file.
#include <string>
#include <vector>

#include "slamkit/core/types.hpp"

namespace slamkit {

/// TUM RGB-D trajectory format, `t x y z qx qy qz qw`: the planar pose as z = 0 and the quaternion of
/// a rotation by the heading about the vertical axis. Times must be non-decreasing; values finite.
void write_tum(const std::string& path, const std::vector<StampedPose>& poses);

/// Reads a TUM trajectory onto the plane: x and y are kept, z is dropped and the heading is the yaw
/// (rotation about z, ZYX convention) of the quaternion, so 3-D trajectories are projected rather than
/// rejected. Each line needs 8 finite numbers, a quaternion of norm 1 within 1e-3, and a time not
/// before the previous line's.
std::vector<StampedPose> read_tum(const std::string& path);

/// Pose covariances over time, one per line: `t c_xx c_xy c_xt c_yy c_yt c_tt` (the upper triangle of
/// the 3x3 covariance of x, y, heading). Read-back matrices are symmetric by construction.
struct PoseCovariances {
  std::vector<double> t;
  std::vector<Matrix3> covariance;
};

/// Writes t[i] with covariances[i]. Only the upper triangle of each matrix is written. Sizes must
/// match, times be non-decreasing, values finite and variances (diagonal) non-negative.
void write_pose_covariances(const std::string& path, const std::vector<double>& t,
                            const std::vector<Matrix3>& covariances);

/// Reads a file written by write_pose_covariances, with the same rules.
PoseCovariances read_pose_covariances(const std::string& path);

/// A landmark map, one landmark per line: `id x y c_xx c_xy c_yy`. Ids are unique non-negative
/// numbers (maps are compared by id) or kUnknownId (-1, any number of times) for landmarks a filter
/// mapped without knowing which true landmark they are. Values finite, variances non-negative.
void write_map(const std::string& path, const std::vector<Landmark>& landmarks);

/// Reads a file written by write_map, with the same rules. Landmarks are returned in file order.
std::vector<Landmark> read_map(const std::string& path);

}  // namespace slamkit
