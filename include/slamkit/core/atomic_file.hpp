#pragma once
// An output file that appears complete or not at all: written under a temporary name beside its
// final one and renamed over it by commit(). A run that fails, is interrupted or killed leaves the
// previous file (or none) and at most a temporary whose name says it is one, never a half-written
// file under the final name that looks complete. The rename is atomic within a file system. A killed
// process cannot remove its temporary; the next writer of the folder does (remove_stale_temporaries).
#include <fstream>
#include <string>
#include <string_view>

namespace slamkit {

class AtomicFile {
 public:
  /// Opens `<path>.partial-<pid>` for writing; InputError naming `path` if it cannot.
  explicit AtomicFile(std::string path, std::ios::openmode mode = std::ios::out);
  /// Removes the temporary unless commit() has run.
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ofstream& stream() { return out_; }
  const std::string& path() const { return path_; }
  /// Flushes, checks that every write succeeded and renames the temporary to the final name;
  /// InputError naming the final path otherwise.
  void commit();

 private:
  std::string path_, temporary_;
  std::ofstream out_;
  bool committed_ = false;
};

/// Writes `content` to `path` through an AtomicFile.
void write_file_atomically(const std::string& path, std::string_view content);

/// What marks the name of a temporary: `<final name>.partial-<pid>`.
inline constexpr std::string_view kTemporaryTag = ".partial-";
/// `<path><tag><id of this process>`: a name no other live process uses for the same path.
std::string name_with_pid(const std::string& path, std::string_view tag);
/// The `<path>` of a name made by name_with_pid with `tag` (the tag followed by digits only), or an
/// empty view if `name` is not one.
std::string_view stem_of_name_with_pid(std::string_view name, std::string_view tag);

/// Removes every temporary in `folder` (entries named `<name>.partial-<digits>`). Only for a caller
/// that knows no live process writes there, one holding the folder's FolderLock: the id in the name
/// cannot tell, since ids are reused and processes of other hosts or containers share file systems.
void remove_stale_temporaries(const std::string& folder);

}  // namespace slamkit
