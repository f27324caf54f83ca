#pragma once
// Line-oriented reading of the whitespace-separated text files slamkit reads and writes, plain or
// gzip-compressed (zlib reads a file without a gzip header as it is). Every parse failure becomes an
// InputError naming the file, the line and what was expected; numbers must be finite (a NaN or inf
// in a log is an error, not a value); a truncated .gz is an error at the line where the data stop.
// Only regular files are opened (core/input_file.hpp), and a line longer than kMaxLineBytes is an
// error at that line, found before more than twice the cap is held in memory.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "slamkit/core/coordinates.hpp"
#include "slamkit/core/error.hpp"

struct gzFile_s;  // zlib's file handle, kept out of the header

namespace slamkit {

/// The longest line any reader accepts: hundreds of times the longest real one (a Victoria Park
/// laser scan, 361 ranges, is about 2 kB), so only a file of the wrong kind reaches it.
inline constexpr std::size_t kMaxLineBytes = std::size_t{1} << 20;

class TextReader {
 public:
  /// Opens `path`; throws InputError if it cannot be read or is not a regular file.
  explicit TextReader(std::string path);
  ~TextReader();
  TextReader(const TextReader&) = delete;
  TextReader& operator=(const TextReader&) = delete;

  /// Advances to the next line that is neither blank nor a '#' comment. False at end of file.
  bool next();

  std::size_t line_number() const { return line_number_; }
  const std::string& path() const { return path_; }
  const std::vector<std::string_view>& fields() const { return fields_; }
  std::size_t size() const { return fields_.size(); }
  std::string_view field(std::size_t i) const;

  /// Requires the current line to have between `min` and `max` fields.
  void expect_fields(std::size_t min, std::size_t max, std::string_view what) const;
  void expect_fields(std::size_t n, std::string_view what) const { expect_fields(n, n, what); }

  double number(std::size_t i, std::string_view what) const;
  /// A number within +-kMaxAbsCoordinate (core/coordinates.hpp): a position in metres.
  double coordinate(std::size_t i, std::string_view what) const;
  long integer(std::size_t i, std::string_view what) const;

  /// An InputError at the current line.
  [[noreturn]] void fail(const std::string& message) const;

 private:
  /// Points line_ at the next physical line (without its '\n'); false at the end of the data.
  bool read_line();
  /// Moves the unread tail to the front of buffer_ and appends decompressed data; false at the end.
  bool refill();
  /// Turns a zlib error (e.g. a truncated stream) into an InputError at the current line.
  void check_stream() const;

  std::string path_;
  ::gzFile_s* file_ = nullptr;
  // Decompressed data are read in large blocks and lines are found with memchr; line_ and fields_
  // point into buffer_ and stay valid until the next call to next().
  std::vector<char> buffer_;
  std::size_t begin_ = 0;  // first unread byte in buffer_
  std::size_t end_ = 0;    // one past the last valid byte in buffer_
  bool at_end_ = false;
  std::string_view line_;
  std::vector<std::string_view> fields_;
  std::size_t line_number_ = 0;
};

/// Parses a finite double from the whole of `s`; false if it is not one.
bool parse_double(std::string_view s, double& out);
/// Parses a base-10 integer from the whole of `s`; false if it is not one.
bool parse_long(std::string_view s, long& out);

}  // namespace slamkit
