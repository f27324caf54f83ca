#pragma once
// The one error type for bad input: it always names where the problem is (file and line when there is
// one) and what was expected, so the CLI can print it as a single line.
#include <stdexcept>
#include <string>

namespace slamkit {

class InputError : public std::runtime_error {
 public:
  /// `line` is 1-based; 0 means the problem is not tied to a line (missing file, bad option).
  InputError(std::string file, std::size_t line, const std::string& what)
      : std::runtime_error(format(file, line, what)), file_(std::move(file)), line_(line) {}
  explicit InputError(const std::string& what) : std::runtime_error(what), line_(0) {}

  const std::string& file() const { return file_; }
  std::size_t line() const { return line_; }

 private:
  static std::string format(const std::string& file, std::size_t line, const std::string& what) {
    if (line == 0) return file + ": " + what;
    return file + ":" + std::to_string(line) + ": " + what;
  }
  std::string file_;
  std::size_t line_;
};

}  // namespace slamkit
