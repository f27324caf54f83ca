#include "slamkit/io/text_reader.hpp"

#include <zlib.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>

namespace slamkit {

namespace {
// A large zlib buffer: lines of the laser logs run to a few kilobytes, and fewer, larger reads keep
// decompression the dominant cost.
constexpr unsigned kZlibBuffer = 1U << 17;
}  // namespace

TextReader::TextReader(std::string path) : path_(std::move(path)) {
  errno = 0;
  file_ = gzopen(path_.c_str(), "rb");
  if (file_ == nullptr) {
    const std::string reason = errno != 0 ? std::strerror(errno) : "out of memory";
    throw InputError(path_, 0, "cannot open file for reading (" + reason + ")");
  }
  gzbuffer(file_, kZlibBuffer);
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

bool TextReader::read_line() {
  line_.clear();
  char chunk[8192];
  while (gzgets(file_, chunk, sizeof chunk) != nullptr) {
    const std::size_t n = std::strlen(chunk);
    if (n > 0 && chunk[n - 1] == '\n') {
      line_.append(chunk, n - 1);
      return true;
    }
    // No newline: the line is longer than the chunk, or the data end here (or were cut off).
    line_.append(chunk, n);
  }
  check_stream();
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
      while (i < rest.size() && (rest[i] == ' ' || rest[i] == '\t' || rest[i] == '\r' || rest[i] == ','))
        ++i;
      const std::size_t start = i;
      while (i < rest.size() && rest[i] != ' ' && rest[i] != '\t' && rest[i] != '\r' && rest[i] != ',')
        ++i;
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

long TextReader::integer(std::size_t i, std::string_view what) const {
  long v = 0;
  if (!parse_long(field(i), v))
    fail("expected an integer for " + std::string(what) + ", found '" + std::string(field(i)) + "'");
  return v;
}

void TextReader::fail(const std::string& message) const { throw InputError(path_, line_number_, message); }

bool parse_double(std::string_view s, double& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size() && std::isfinite(out);
}

bool parse_long(std::string_view s, long& out) {
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(s.data(), s.data() + s.size(), out);
  return ec == std::errc() && ptr == s.data() + s.size();
}

}  // namespace slamkit
