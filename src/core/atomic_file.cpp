#include "slamkit/core/atomic_file.hpp"

#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <system_error>

#include "slamkit/core/error.hpp"

namespace slamkit {

AtomicFile::AtomicFile(std::string path, std::ios::openmode mode)
    : path_(std::move(path)), temporary_(name_with_pid(path_, kTemporaryTag)) {
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

std::string name_with_pid(const std::string& path, std::string_view tag) {
  return path + std::string(tag) + std::to_string(::getpid());
}

std::string_view stem_of_name_with_pid(std::string_view name, std::string_view tag) {
  const std::size_t at = name.rfind(tag);
  if (at == std::string_view::npos || at == 0) return {};
  const std::string_view pid = name.substr(at + tag.size());
  const bool digits = !pid.empty() && std::all_of(pid.begin(), pid.end(), [](char c) {
    return std::isdigit(static_cast<unsigned char>(c)) != 0;
  });
  return digits ? name.substr(0, at) : std::string_view();
}

void remove_stale_temporaries(const std::string& folder) {
  std::error_code list_error;
  for (const auto& entry : std::filesystem::directory_iterator(folder, list_error)) {
    const std::string name = entry.path().filename().string();
    if (stem_of_name_with_pid(name, kTemporaryTag).empty()) continue;
    std::error_code error;
    std::filesystem::remove_all(entry.path(), error);
    if (error) throw InputError(entry.path().string(), 0, "cannot remove this stale temporary: " + error.message());
  }
  if (list_error) throw InputError(folder, 0, "cannot list the folder: " + list_error.message());
}

}  // namespace slamkit
