#include "slamkit/io/text_reader.hpp"

#include <charconv>
#include <cmath>

namespace slamkit {

TextReader::TextReader(std::string path) : path_(std::move(path)), in_(path_) {
  if (!in_) throw InputError(path_, 0, "cannot open file for reading");
}

bool TextReader::next() {
  while (std::getline(in_, line_)) {
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
  if (in_.bad()) throw InputError(path_, line_number_, "read error");
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
