#pragma once
// An output file that appears complete or not at all: written under a temporary name beside its
// final one and renamed over it by commit(). A run that fails, is interrupted or killed leaves the
// previous file (or none) and at most a temporary whose name says it is one, never a half-written
// file under the final name that looks complete. The rename is atomic within a file system.
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

}  // namespace slamkit
