// Outputs appear complete or not at all: an AtomicFile that is not committed (an error or an
// interruption mid-write) leaves the previous file as it was and no temporary behind. A folder of
// files that belong together is replaced as a whole or not at all, by one writer at a time; what a
// killed writer leaves is cleared by the next, and nothing of a live one's.
#include "slamkit/core/atomic_file.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "slamkit/core/atomic_folder.hpp"
#include "slamkit/core/error.hpp"
#include "test_data.hpp"

using slamkit::test_data::read_text;

namespace slamkit {
namespace {

namespace fs = std::filesystem;

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
    EXPECT_EQ(read_text(path), "old\n") << "the final name holds the old file until commit";
    file.commit();
  }
  EXPECT_EQ(read_text(path), "new\n");
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
  EXPECT_EQ(read_text(path), "complete\n");
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

class AtomicFolderTest : public AtomicFileTest {
 protected:
  void SetUp() override {
    AtomicFileTest::SetUp();
    folder_ = (dir_ / "run").string();
  }
  /// A complete folder: `run.json` and `map.txt` holding `text`.
  void write_whole(const std::string& text) {
    AtomicFolder folder(folder_, "run.json");
    write_file_atomically(folder.path() + "/run.json", text);
    write_file_atomically(folder.path() + "/map.txt", text);
    folder.commit();
  }
  std::string folder_;
};

TEST_F(AtomicFolderTest, CommitReplacesTheWholeFolder) {
  write_whole("old");
  std::ofstream(fs::path(folder_) / "extra.svg") << "of the old run only";
  {
    AtomicFolder folder(folder_, "run.json");
    EXPECT_NE(folder.path(), folder_);
    write_file_atomically(folder.path() + "/run.json", "new");
    EXPECT_EQ(read_text(fs::path(folder_) / "run.json"), "old") << "the folder keeps the old run until commit";
    folder.commit();
  }
  EXPECT_EQ(read_text(fs::path(folder_) / "run.json"), "new");
  EXPECT_FALSE(fs::exists(fs::path(folder_) / "map.txt")) << "nothing of the old run beside the new";
  EXPECT_FALSE(fs::exists(fs::path(folder_) / "extra.svg"));
  EXPECT_EQ(files(), 1u) << "no staging folder, old folder or lock file left";
}

TEST_F(AtomicFolderTest, AWriterThatFailsHalfWayLeavesThePreviousFolder) {
  write_whole("old");
  try {
    AtomicFolder folder(folder_, "run.json");
    write_file_atomically(folder.path() + "/run.json", "new");
    throw std::runtime_error("disk full");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(read_text(fs::path(folder_) / "run.json"), "old");
  EXPECT_EQ(read_text(fs::path(folder_) / "map.txt"), "old");
  EXPECT_EQ(files(), 1u);
}

TEST_F(AtomicFolderTest, TheStagingFolderSaysItIsIncomplete) {
  AtomicFolder folder(folder_, "run.json");
  const std::string message = [&] {
    try {
      require_complete_folder(folder.path());
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), folder.path());
      return std::string(e.what());
    }
    return std::string("no error");
  }();
  EXPECT_NE(message.find("an incomplete folder"), std::string::npos) << message;
  EXPECT_NE(message.find("slamkit process " + std::to_string(::getpid()) + " is writing this folder"),
            std::string::npos)
      << message;
  folder.commit();
  EXPECT_NO_THROW(require_complete_folder(folder_));
}

TEST_F(AtomicFolderTest, AFolderThatIsNotOneOfOursIsRefused) {
  fs::create_directories(folder_);
  std::ofstream(fs::path(folder_) / "notes.txt") << "mine";
  EXPECT_THROW(AtomicFolder(folder_, "run.json"), InputError);
  EXPECT_EQ(read_text(fs::path(folder_) / "notes.txt"), "mine");
  const std::string file = (dir_ / "a-file").string();
  std::ofstream(file) << "not a folder";
  EXPECT_THROW(AtomicFolder(file, "run.json"), InputError);
  EXPECT_EQ(files(), 2u) << "no lock file or staging folder left by the refusals";
}

// A writer killed between moving the old folder aside and the new one in leaves no folder under the
// name; the next writer puts the old one back before it starts.
TEST_F(AtomicFolderTest, AFolderLeftAsideByAKilledWriterComesBack) {
  write_whole("old");
  fs::rename(folder_, folder_ + ".old-4000001");
  { AtomicFolder next(folder_, "run.json"); }  // starts, then fails before commit
  EXPECT_EQ(read_text(fs::path(folder_) / "run.json"), "old");
  EXPECT_EQ(files(), 1u);
}

TEST_F(AtomicFolderTest, TwoLocksOfOneFolderExcludeEachOtherInOneProcess) {
  const FolderLock first(folder_);
  EXPECT_THROW(FolderLock second(folder_), InputError);
  EXPECT_THROW(AtomicFolder(folder_, "run.json"), InputError);
}

// A real writer in another process: while it lives its lock refuses us (naming it) and its staging
// folder is left alone; killed with SIGKILL, it leaves its staging folder, a temporary and its lock
// file, and the next writer takes the folder and clears them.
TEST_F(AtomicFolderTest, AKilledWritersLockDiesWithItAndItsLeftoversAreCleared) {
  write_whole("old");
  int ready[2];
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t child = ::fork();
  if (child == 0) {  // never returns into the test framework; a failure closes the pipe unwritten
    ::close(ready[0]);
    try {
      AtomicFolder folder(folder_, "run.json");
      AtomicFile half(folder.path() + "/trajectory.tum");
      half.stream() << "half a trajectory" << std::flush;
      const char byte = 1;
      if (::write(ready[1], &byte, 1) == 1) ::pause();  // until killed
    } catch (...) {
    }
    ::_exit(1);
  }
  ::close(ready[1]);
  char byte = 0;
  ASSERT_EQ(::read(ready[0], &byte, 1), 1) << "the child holds the folder";
  ::close(ready[0]);
  const std::string staging = folder_ + ".partial-" + std::to_string(child);
  try {
    AtomicFolder second(folder_, "run.json");
    ADD_FAILURE() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("in use by slamkit process " + std::to_string(child)), std::string::npos)
        << e.what();
  }
  EXPECT_TRUE(fs::exists(fs::path(staging) / ("trajectory.tum.partial-" + std::to_string(child))))
      << "a live writer's files are not touched";

  ASSERT_EQ(::kill(child, SIGKILL), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(child, &status, 0), child);
  ASSERT_TRUE(WIFSIGNALED(status));
  EXPECT_TRUE(fs::exists(staging));
  EXPECT_TRUE(fs::exists(folder_ + ".lock"));

  write_whole("new");
  EXPECT_EQ(read_text(fs::path(folder_) / "run.json"), "new");
  EXPECT_EQ(files(), 1u) << "the killed writer's staging folder and lock file are gone";
}

TEST_F(AtomicFileTest, StaleTemporariesAreNamesEndingInPartialAndAProcessId) {
  const fs::path& dir = dir_;
  fs::create_directories(dir / "trajectory.tum.partial-77");
  for (const char* name : {"map.txt.partial-123", "map.txt", "map.txt.partial-", "map.txt.partial-12a",
                           "notes.partial-x", "map.txt.old-123"})
    std::ofstream(dir / name) << "x";
  remove_stale_temporaries(dir.string());
  EXPECT_FALSE(fs::exists(dir / "map.txt.partial-123"));
  EXPECT_FALSE(fs::exists(dir / "trajectory.tum.partial-77"));
  EXPECT_EQ(files(), 5u);
}

}  // namespace
}  // namespace slamkit
