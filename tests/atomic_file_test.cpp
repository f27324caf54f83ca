// Outputs appear complete or not at all: an AtomicFile that is not committed (an error or an
// interruption mid-write) leaves the previous file as it was and no temporary behind.
#include "slamkit/core/atomic_file.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "slamkit/core/error.hpp"

namespace slamkit {
namespace {

namespace fs = std::filesystem;

std::string read(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("slamkit_atomic_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::size_t files() const {
    return static_cast<std::size_t>(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()));
  }
  fs::path dir_;
};

TEST_F(AtomicFileTest, CommitReplacesTheFileAndLeavesNoTemporary) {
  const fs::path path = dir_ / "map.txt";
  write_file_atomically(path.string(), "old\n");
  {
    AtomicFile file(path.string());
    file.stream() << "new\n";
    EXPECT_EQ(read(path), "old\n") << "the final name holds the old file until commit";
    file.commit();
  }
  EXPECT_EQ(read(path), "new\n");
  EXPECT_EQ(files(), 1u);
}

TEST_F(AtomicFileTest, AWriteThatFailsHalfWayLeavesThePreviousFile) {
  const fs::path path = dir_ / "trajectory.tum";
  write_file_atomically(path.string(), "complete\n");
  try {
    AtomicFile file(path.string());
    file.stream() << "half of a ";
    throw std::runtime_error("interrupted");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(read(path), "complete\n");
  EXPECT_EQ(files(), 1u) << "the temporary is removed";
}

TEST_F(AtomicFileTest, AnUnwritablePlaceIsAnErrorNamingTheFile) {
  const std::string path = (dir_ / "no" / "such" / "folder" / "run.json").string();
  try {
    write_file_atomically(path, "{}\n");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
  }
}

}  // namespace
}  // namespace slamkit
