#pragma once
// Test helpers. Where the tests find the shared real datasets: $SLAMKIT_DATA if set, else ../shared/datasets beside
// the source tree (where CI has them). Tests that need one skip, naming the path, when it is absent.
#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Core>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"

namespace slamkit::test_data {

/// A file's whole text, byte for byte ("" when it cannot be read).
inline std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

inline nlohmann::json read_json(const std::filesystem::path& path) { return nlohmann::json::parse(read_text(path)); }

/// Writes `text` to `path` as it is, replacing the file.
inline void write_text(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

inline std::filesystem::path shared_dataset(const std::string& folder) {
  const char* env = std::getenv("SLAMKIT_DATA");
  const std::filesystem::path root = env != nullptr && *env != '\0'
                                         ? std::filesystem::path(env)
                                         : std::filesystem::path(SLAMKIT_SOURCE_DIR) / ".." / "shared" / "datasets";
  return root / folder;
}

/// Runs `read`, which must throw an InputError naming `file` and `line`; returns its message.
template <typename F>
std::string input_error_at(F&& read, const std::string& file, std::size_t line) {
  try {
    read();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), file);
    EXPECT_EQ(e.line(), line) << e.what();
    return e.what();
  }
  ADD_FAILURE() << "expected an InputError in " << file;
  return {};
}

/// Central-difference Jacobian of f at x; the `angular_rows` of f are differenced the short way
/// round. What every model's analytic Jacobians are tested against. Rows may be Eigen::Dynamic (a
/// measurement of the model's dimension).
template <int Rows>
Eigen::MatrixXd numeric_jacobian(const std::function<Eigen::Matrix<double, Rows, 1>(const Eigen::VectorXd&)>& f,
                                 const Eigen::VectorXd& x, const std::vector<int>& angular_rows) {
  const double h = 1e-6;
  Eigen::MatrixXd j(f(x).size(), x.size());
  for (int i = 0; i < x.size(); ++i) {
    Eigen::VectorXd a = x, b = x;
    a[i] += h;
    b[i] -= h;
    Eigen::VectorXd d = f(a) - f(b);
    for (const int r : angular_rows) d[r] = wrap_angle(d[r]);
    j.col(i) = d / (2 * h);
  }
  return j;
}

/// The one tolerance every analytic Jacobian is held to against numeric_jacobian, entry by entry:
/// |analytic - numeric| <= kJacobianAbsTol + kJacobianRelTol |numeric|. The central difference is
/// off by about h^2 |f'''| / 6 (~1e-12 here) plus rounding, eps |f| / h (~4e-9 for |f| ~ 20 m), so
/// the bounds leave a margin over both while catching any wrong term.
inline constexpr double kJacobianAbsTol = 1e-7;
inline constexpr double kJacobianRelTol = 1e-6;

inline ::testing::AssertionResult jacobian_matches(const Eigen::MatrixXd& analytic, const Eigen::MatrixXd& numeric) {
  if (analytic.rows() != numeric.rows() || analytic.cols() != numeric.cols())
    return ::testing::AssertionFailure() << "analytic " << analytic.rows() << "x" << analytic.cols() << ", numeric "
                                         << numeric.rows() << "x" << numeric.cols();
  const Eigen::ArrayXXd excess =
      (analytic - numeric).array().abs() - (kJacobianAbsTol + kJacobianRelTol * numeric.array().abs());
  if ((excess <= 0.0).all()) return ::testing::AssertionSuccess();
  return ::testing::AssertionFailure() << "analytic\n" << analytic << "\nnumeric\n" << numeric;
}

/// A directory of the current test's own, removed afterwards.
class ScratchDir {
 public:
  ScratchDir() {
    const auto* test = ::testing::UnitTest::GetInstance()->current_test_info();
    path_ = std::filesystem::path(::testing::TempDir()) /
            (std::string("slamkit_") + test->test_suite_name() + "_" + test->name() + "_" + std::to_string(getpid()));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
};

/// Sets an environment variable for its lifetime, then puts back what was there (a test binary run
/// whole shares one environment between its tests).
class ScopedEnvironment {
 public:
  ScopedEnvironment(const char* name, const std::string& value) : name_(name) {
    if (const char* before = std::getenv(name)) before_ = before;
    ::setenv(name, value.c_str(), 1);
  }
  ~ScopedEnvironment() {
    if (before_)
      ::setenv(name_, before_->c_str(), 1);
    else
      ::unsetenv(name_);
  }
  ScopedEnvironment(const ScopedEnvironment&) = delete;
  ScopedEnvironment& operator=(const ScopedEnvironment&) = delete;

 private:
  const char* name_;
  std::optional<std::string> before_;
};

}  // namespace slamkit::test_data

/// Skips the current test when the dataset folder is missing.
#define SLAMKIT_REQUIRE_DATASET(path)                                                                     \
  do {                                                                                                    \
    if (!std::filesystem::exists(path))                                                                   \
      GTEST_SKIP() << "dataset not found at " << (path).string()                                          \
                   << " (set SLAMKIT_DATA to the folder holding the shared datasets)";                    \
  } while (0)
