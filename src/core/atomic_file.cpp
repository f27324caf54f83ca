#include "slamkit/core/atomic_file.hpp"

#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <system_error>

#include "slamkit/core/error.hpp"

namespace slamkit {

AtomicFile::AtomicFile(std::string path, std::ios::openmode mode)
    : path_(std::move(path)), temporary_(path_ + ".partial-" + std::to_string(::getpid())) {
  out_.open(temporary_, mode | std::ios::out | std::ios::trunc);
  if (!out_) throw InputError(path_, 0, "cannot open file for writing");
}

AtomicFile::~AtomicFile() {
  if (committed_) return;
  out_.close();
  std::error_code ignored;  // a destructor reports nothing; the file was never the result
  std::filesystem::remove(temporary_, ignored);
}

void AtomicFile::commit() {
  out_.close();
  if (!out_) throw InputError(path_, 0, "write failed (disk full or the file system refused it)");
  std::error_code error;
  std::filesystem::rename(temporary_, path_, error);
  if (error) throw InputError(path_, 0, "cannot replace the file: " + error.message());
  committed_ = true;
}

void write_file_atomically(const std::string& path, std::string_view content) {
  AtomicFile file(path, std::ios::binary);
  file.stream().write(content.data(), static_cast<std::streamsize>(content.size()));
  file.commit();
}

}  // namespace slamkit
