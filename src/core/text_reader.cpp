#include "slamkit/core/text_reader.hpp"

#include <fmt/format.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>

#include "slamkit/core/input_file.hpp"

namespace slamkit {

namespace {
// Large zlib and line buffers: lines of the laser logs run to a few kilobytes, and fewer, larger reads
// keep decompression the dominant cost.
constexpr unsigned kZlibBuffer = 1U << 17;

// Field separators, as a table: the laser log's millions of characters make this test the tokenizer's cost.
constexpr std::array<bool, 256> kSeparators = [] {
  std::array<bool, 256> table{};
  for (const unsigned char c : {' ', '\t', '\r', ','}) table[c] = true;
  return table;
}();
bool is_separator(char c) { return kSeparators[static_cast<unsigned char>(c)]; }
}  // namespace

TextReader::TextReader(std::string path) : path_(std::move(path)) {
  const int fd = open_input_file(path_);
  file_ = gzdopen(fd, "rb");
  if (file_ == nullptr) {
    ::close(fd);
    throw InputError(path_, 0, "cannot open file for reading (out of memory)");
  }
  gzbuffer(file_, kZlibBuffer);
  buffer_.resize(kZlibBuffer);
}

TextReader::~TextReader() { gzclose(file_); }

void TextReader::check_stream() const {
  int code = Z_OK;
  const char* message = gzerror(file_, &code);
  if (code == Z_OK) return;
  // The partial line is where the data stop, so that is the line the error names.
  if (code == Z_BUF_ERROR)
    throw InputError(path_, line_number_ + 1,
                     "the compressed data end abruptly; expected a complete gzip stream (truncated file?)");
  const std::string reason = code == Z_ERRNO ? std::strerror(errno) : message;
  throw InputError(path_, line_number_ + 1, "cannot decompress: " + reason);
}

bool TextReader::refill() {
  if (at_end_) return false;
  std::copy(buffer_.begin() + static_cast<std::ptrdiff_t>(begin_), buffer_.begin() + static_cast<std::ptrdiff_t>(end_),
            buffer_.begin());
  end_ -= begin_;
  begin_ = 0;
  // A line longer than the buffer: grow it, so any line up to kMaxLineBytes is read whole.
  if (end_ == buffer_.size()) buffer_.resize(2 * buffer_.size());
  const int got = gzread(file_, buffer_.data() + end_, static_cast<unsigned>(buffer_.size() - end_));
  if (got <= 0) {
    // The end of the data, or of a truncated stream: zlib reports the latter only here.
    check_stream();
    at_end_ = true;
    return false;
  }
  end_ += static_cast<std::size_t>(got);
  return true;
}

bool TextReader::read_line() {
  std::size_t searched = begin_;
  while (true) {
    const void* newline = std::memchr(buffer_.data() + searched, '\n', end_ - searched);
    if (newline != nullptr) {
      const std::size_t stop = static_cast<std::size_t>(static_cast<const char*>(newline) - buffer_.data());
      line_ = std::string_view(buffer_.data() + begin_, stop - begin_);
      begin_ = stop + 1;
      return true;
    }
    const std::size_t pending = end_ - begin_;
    // Checked before reading on, so a line without end costs at most twice the cap in memory.
    if (pending > kMaxLineBytes)
      throw InputError(path_, line_number_ + 1,
                       fmt::format("line longer than {} bytes; expected a text file of lines far shorter (the "
                                   "longest of any format slamkit reads are a few kilobytes)",
                                   kMaxLineBytes));
    if (!refill()) break;
    searched = pending;  // refill moved the unread bytes to the front
  }
  // The last line has no newline.
  line_ = std::string_view(buffer_.data() + begin_, end_ - begin_);
  begin_ = end_;
  return !line_.empty();
}

bool TextReader::next() {
  while (read_line()) {
    ++line_number_;
    fields_.clear();
    std::string_view rest(line_);
    if (const auto hash = rest.find('#'); hash != std::string_view::npos) rest = rest.substr(0, hash);
    std::size_t i = 0;
    while (i < rest.size()) {
      while (i < rest.size() && is_separator(rest[i])) ++i;
      const std::size_t start = i;
      while (i < rest.size() && !is_separator(rest[i])) ++i;
      if (i > start) fields_.push_back(rest.substr(start, i - start));
    }
    if (!fields_.empty()) return true;
  }
  return false;
}

std::string_view TextReader::field(std::size_t i) const {
  if (i >= fields_.size())
    fail("expected at least " + std::to_string(i + 1) + " fields, found " + std::to_string(fields_.size()));
  return fields_[i];
}

void TextReader::expect_fields(std::size_t min, std::size_t max, std::string_view what) const {
  if (fields_.size() < min || fields_.size() > max) {
    const std::string count = min == max ? std::to_string(min)
                                         : std::to_string(min) + " to " + std::to_string(max);
    fail("expected " + count + " fields (" + std::string(what) + "), found " +
         std::to_string(fields_.size()));
  }
}

double TextReader::number(std::size_t i, std::string_view what) const {
  double v = 0.0;
  if (!parse_double(field(i), v))
    fail("expected a finite number for " + std::string(what) + ", found '" + std::string(field(i)) + "'");
  return v;
}

double TextReader::coordinate(std::size_t i, std::string_view what) const {
  const double v = number(i, what);
  static_assert(kMaxAbsCoordinate == 2e6, "the message states the bound");
  if (std::abs(v) > kMaxAbsCoordinate) fail(fmt::format("expected {} within +-2e6 m, found {}", what, v));
  return v;
}

long TextReader::integer(std::size_t i, std::string_view what) const {
  long v = 0;
  if (!parse_long(field(i), v))
    fail("expected an integer for " + std::string(what) + ", found '" + std::string(field(i)) + "'");
  return v;
}

void TextReader::fail(const std::string& message) const { throw InputError(path_, line_number_, message); }

namespace {

// Plain decimals ("-12.375") with at most 15 significant digits, the whole of every laser log, take
// Clinger's fast path: the digits form an integer m < 2^53 and 10^k is exact for k <= 22, so m / 10^k
// is one correctly rounded IEEE division, the same double std::from_chars returns. Anything else
// (exponents, more digits, odd forms) is left to std::from_chars.
bool parse_plain_decimal(std::string_view s, double& out) {
  static constexpr double kPowersOfTen[] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,
                                            1e8,  1e9,  1e10, 1e11, 1e12, 1e13, 1e14, 1e15};
  std::size_t i = 0;
  const bool negative = !s.empty() && s[0] == '-';
  if (negative) ++i;
  std::uint64_t mantissa = 0;
  int digits = 0;
  int fraction_digits = 0;
  bool seen_point = false;
  const std::size_t first_digit = i;
  for (; i < s.size(); ++i) {
    const char c = s[i];
    if (c >= '0' && c <= '9') {
      if (++digits > 15) return false;
      mantissa = 10 * mantissa + static_cast<std::uint64_t>(c - '0');
      if (seen_point) ++fraction_digits;
    } else if (c == '.' && !seen_point && i > first_digit) {
      seen_point = true;
    } else {
      return false;
    }
  }
  if (digits == 0 || (seen_point && fraction_digits == 0)) return false;
  const double value = static_cast<double>(mantissa) / kPowersOfTen[fraction_digits];
  out = negative ? -value : value;
  return true;
}

}  // namespace

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (parse_plain_decimal(s, out)) return true;
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

bool parse_long(std::string_view s, long& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

}  // namespace slamkit
