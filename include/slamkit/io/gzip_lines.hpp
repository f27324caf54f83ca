#pragma once
// Line-oriented reading of gzip-compressed text (zlib), with TextReader's conventions: fields split
// on blanks, tabs, carriage returns and commas, '#' starts a comment, blank lines are skipped, and
// every failure is an InputError naming the file, the line and what was expected. A file that is
// not gzip-compressed is read as it is, so a decompressed copy works too.
//
// A stream cut short (a truncated download or copy) is an error at the line where it ends, never a
// silently shorter file: zlib reports it and this reader turns it into an InputError.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "slamkit/error.hpp"

struct gzFile_s;  // zlib's handle type, declared here so that users of this header need no zlib.h

namespace slamkit {

class GzipLineReader {
 public:
  /// Opens `path`; throws InputError if it cannot be opened.
  explicit GzipLineReader(std::string path);
  ~GzipLineReader();
  GzipLineReader(const GzipLineReader&) = delete;
  GzipLineReader& operator=(const GzipLineReader&) = delete;

  /// Advances to the next line that is neither blank nor a '#' comment. False at the end of the
  /// data; throws InputError on a corrupt or truncated stream.
  bool next();

  std::size_t line_number() const { return line_number_; }
  const std::string& path() const { return path_; }
  const std::vector<std::string_view>& fields() const { return fields_; }
  std::size_t size() const { return fields_.size(); }
  std::string_view field(std::size_t i) const;

  /// Requires the current line to have between `min` and `max` fields.
  void expect_fields(std::size_t min, std::size_t max, std::string_view what) const;
  void expect_fields(std::size_t n, std::string_view what) const { expect_fields(n, n, what); }

  /// A finite number from field i (parsed as TextReader does, with parse_double).
  double number(std::size_t i, std::string_view what) const;
  /// An integer from field i (parsed as TextReader does, with parse_long).
  long integer(std::size_t i, std::string_view what) const;

  /// An InputError at the current line.
  [[noreturn]] void fail(const std::string& message) const;

 private:
  /// Reads one physical line into line_ (without its '\n'); false at the end of the data.
  bool read_line();
  /// The zlib error state as an InputError, if there is one.
  void check_stream() const;

  std::string path_;
  gzFile_s* file_ = nullptr;
  std::string line_;
  std::vector<std::string_view> fields_;
  std::size_t line_number_ = 0;
};

}  // namespace slamkit
