#include "slamkit/core/atomic_folder.hpp"

#include <fcntl.h>
#include <fmt/format.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "slamkit/core/atomic_file.hpp"
#include "slamkit/core/error.hpp"

namespace slamkit {

namespace fs = std::filesystem;

namespace {

// Where commit() keeps the previous folder between moving it aside and deleting it.
constexpr std::string_view kAsideTag = ".old-";

std::string errno_message(int error) { return std::error_code(error, std::generic_category()).message(); }

/// The folder as an absolute path without a trailing separator, through any symbolic link to it, so
/// that its lock and staging folder lie beside the real folder, on its file system (a rename does
/// not cross file systems).
fs::path resolved(const std::string& folder) {
  std::error_code error;
  fs::path path = fs::weakly_canonical(fs::absolute(folder), error);
  if (error) throw InputError(folder, 0, "cannot resolve the path: " + error.message());
  if (!path.has_filename()) path = path.parent_path();
  if (!path.has_filename()) throw InputError(folder, 0, "expected a folder below the root");
  return path;
}

/// Who holds a lock, from the id its holder wrote into the lock file.
std::string holder_of(int fd) {
  char text[32] = {};
  const ssize_t n = ::pread(fd, text, sizeof text - 1, 0);
  if (n <= 0) return "another process";  // the holder has locked the file but not written its id yet
  return "slamkit process " + std::string(text, static_cast<std::size_t>(n));
}

}  // namespace

FolderLock::FolderLock(const std::string& folder) {
  const fs::path target = resolved(folder);
  std::error_code error;
  fs::create_directories(target.parent_path(), error);
  if (error) throw InputError(folder, 0, "cannot create the folder it is in: " + error.message());
  path_ = target.string() + ".lock";
  // A holder removes the lock file before it unlocks. A file opened just before that is no longer
  // the folder's lock file, and a lock taken on it would exclude no one: so the lock counts only if
  // the name still leads to the file locked, and otherwise the name is opened again.
  for (;;) {
    fd_ = ::open(path_.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd_ < 0) throw InputError(path_, 0, "cannot create the lock file: " + errno_message(errno));
    if (::flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      const int cause = errno;
      const std::string holder = holder_of(fd_);
      ::close(fd_);
      if (cause == EWOULDBLOCK)
        throw InputError(folder, 0,
                         fmt::format("in use by {}, which is writing it (lock file {}); wait for it to end or choose "
                                     "another folder",
                                     holder, path_));
      throw InputError(path_, 0, "cannot lock the file: " + errno_message(cause));
    }
    struct stat opened {}, named {};
    if (::fstat(fd_, &opened) == 0 && ::stat(path_.c_str(), &named) == 0 && opened.st_dev == named.st_dev &&
        opened.st_ino == named.st_ino)
      break;
    ::close(fd_);
  }
  const std::string pid = std::to_string(::getpid());
  if (::ftruncate(fd_, 0) != 0 || ::pwrite(fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size())) {
    const int cause = errno;
    release();
    throw InputError(path_, 0, "cannot write the lock file: " + errno_message(cause));
  }
}

FolderLock::~FolderLock() { release(); }

void FolderLock::release() {
  ::unlink(path_.c_str());  // while still locked: see the constructor
  ::close(fd_);
}

AtomicFolder::AtomicFolder(const std::string& folder, const std::string& identifying_file)
    : lock_(folder),
      given_(folder),
      final_(resolved(folder).string()),
      staging_(name_with_pid(final_, kTemporaryTag)) {
  const fs::path target(final_);
  const std::string stem = target.filename().string();
  // Under the lock, every staging folder of this folder belongs to a writer that died, and so does a
  // previous folder moved aside: it goes back if nothing replaced it (the writer died between the
  // two moves of commit), and is deleted otherwise.
  std::error_code error;
  for (const auto& entry : fs::directory_iterator(target.parent_path(), error)) {
    const std::string name = entry.path().filename().string();
    std::error_code cleanup;
    if (stem_of_name_with_pid(name, kTemporaryTag) == stem) {
      fs::remove_all(entry.path(), cleanup);
    } else if (stem_of_name_with_pid(name, kAsideTag) == stem) {
      if (fs::exists(target))
        fs::remove_all(entry.path(), cleanup);
      else
        fs::rename(entry.path(), target, cleanup);
    }
    if (cleanup) throw InputError(entry.path().string(), 0, "cannot clear what a killed writer left: " + cleanup.message());
  }
  if (error) throw InputError(target.parent_path().string(), 0, "cannot list the folder: " + error.message());

  const fs::file_status status = fs::status(target, error);
  if (fs::exists(status)) {
    if (!fs::is_directory(status)) throw InputError(folder, 0, "exists and is not a folder");
    if (!fs::is_empty(target, error) && !fs::exists(target / identifying_file))
      throw InputError(folder, 0,
                       fmt::format("is not empty and holds no {}, so it is not a folder slamkit wrote and is not "
                                   "replaced; choose a new or empty folder",
                                   identifying_file));
  }
  fs::create_directory(staging_, error);
  if (error) throw InputError(staging_, 0, "cannot create the folder: " + error.message());
  write_file_atomically((fs::path(staging_) / kIncompleteMarker).string(),
                        fmt::format("slamkit process {} is writing this folder; it replaces {} when complete.\n"
                                    "If that process has ended, it was killed; the next writer of {} removes this "
                                    "folder.\n",
                                    ::getpid(), final_, final_));
}

AtomicFolder::~AtomicFolder() {
  if (committed_) return;
  std::error_code ignored;  // a destructor reports nothing; the staging folder was never the result
  fs::remove_all(staging_, ignored);
}

void AtomicFolder::commit() {
  std::error_code error;
  fs::remove(fs::path(staging_) / kIncompleteMarker, error);
  if (error) throw InputError(staging_, 0, "cannot mark the folder complete: " + error.message());
  const std::string aside = name_with_pid(final_, kAsideTag);
  const bool replacing = fs::exists(final_);
  if (replacing) {
    fs::rename(final_, aside, error);
    if (error) throw InputError(given_, 0, "cannot move the previous folder aside: " + error.message());
  }
  fs::rename(staging_, final_, error);
  if (error) {
    std::error_code ignored;  // the error to report is the one above
    if (replacing) fs::rename(aside, final_, ignored);
    throw InputError(given_, 0, "cannot move the new folder in: " + error.message());
  }
  committed_ = true;
  // The new folder is in place whatever happens here; what cannot be deleted now, the next writer
  // deletes.
  if (replacing) fs::remove_all(aside, error);
}

void require_complete_folder(const std::string& folder) {
  std::ifstream marker(fs::path(folder) / kIncompleteMarker);
  if (!marker) return;
  std::string why;
  std::getline(marker, why);
  throw InputError(folder, 0, "an incomplete folder, whose files do not make a whole: " + why);
}

}  // namespace slamkit
