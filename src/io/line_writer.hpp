#pragma once
// The io module's writer of line-oriented text files (trajectories, landmark deviations,
// associations): lines gathered into one buffer and handed to the file in 64 KiB blocks, since these
// files run to millions of numbers and a stream call per number is what would make writing them slow.
#include <fmt/compile.h>
#include <fmt/format.h>

#include <charconv>
#include <iterator>
#include <string>
#include <string_view>
#include <utility>

#include "slamkit/core/atomic_file.hpp"

namespace slamkit {

class LineWriter {
 public:
  explicit LineWriter(const std::string& path) : file_(path) {}

  /// One whole line, formatted by fmt from a format compiled with FMT_COMPILE (parsed once at
  /// compile time rather than at every line).
  template <typename CompiledFormat, typename... Args>
  void line(const CompiledFormat& format, Args&&... args) {
    fmt::format_to(std::back_inserter(buffer_), format, std::forward<Args>(args)...);
    end_line();
  }

  // A line piece by piece, for the largest files. Numbers to a precision go through std::to_chars:
  // the same characters as fmt's "{:.6f}" and "{:.6g}" (printf's), at a fraction of the cost, since
  // fmt formats to a precision through Dragon4. landmark_std.txt has a line per landmark per
  // second (420,000 on a 1,000-landmark run), and formatting them that way was most of a compressed
  // EKF run outside its filter loop.
  LineWriter& fixed(double v, int precision) { return number(v, std::chars_format::fixed, precision); }
  LineWriter& general(double v, int precision) { return number(v, std::chars_format::general, precision); }
  LineWriter& integer(long long v) {
    char digits[24];
    buffer_.append(digits, std::to_chars(digits, digits + sizeof digits, v).ptr);
    return *this;
  }
  LineWriter& text(std::string_view s) {
    buffer_.append(s.data(), s.data() + s.size());
    return *this;
  }
  void end_line() {
    buffer_.push_back('\n');
    if (buffer_.size() >= kFlushSize) flush();
  }

  /// Writes what is left and closes the file; a disk-full or similar failure surfaces here.
  void finish() {
    flush();
    file_.commit();
  }

 private:
  static constexpr std::size_t kFlushSize = 1 << 16;

  LineWriter& number(double v, std::chars_format format, int precision) {
    char digits[400];  // the longest fixed-point double: 309 digits, a sign, a point and the precision
    buffer_.append(digits, std::to_chars(digits, digits + sizeof digits, v, format, precision).ptr);
    return *this;
  }
  void flush() {
    file_.stream().write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

  AtomicFile file_;
  fmt::memory_buffer buffer_;
};

}  // namespace slamkit
