#include "slamkit/core/json_options.hpp"

#include <algorithm>

#include "slamkit/core/input_file.hpp"

namespace slamkit {
namespace {

// Finds where parsing fails without building anything: nlohmann reports the position of a syntax
// error in its exception, but not that of a number beyond the range of a double.
class ErrorLocator final : public nlohmann::json_sax<nlohmann::json> {
 public:
  std::size_t position = 0;

  bool null() override { return true; }
  bool boolean(bool) override { return true; }
  bool number_integer(number_integer_t) override { return true; }
  bool number_unsigned(number_unsigned_t) override { return true; }
  bool number_float(number_float_t, const string_t&) override { return true; }
  bool string(string_t&) override { return true; }
  bool binary(binary_t&) override { return true; }
  bool start_object(std::size_t) override { return true; }
  bool key(string_t&) override { return true; }
  bool end_object() override { return true; }
  bool start_array(std::size_t) override { return true; }
  bool end_array() override { return true; }
  bool parse_error(std::size_t byte, const std::string&, const nlohmann::json::exception&) override {
    position = byte;
    return false;
  }
};

std::size_t line_of(const std::string& text, std::size_t byte) {
  const auto upto = text.begin() + static_cast<std::ptrdiff_t>(std::min(byte, text.size()));
  return static_cast<std::size_t>(std::count(text.begin(), upto, '\n')) + 1;
}

}  // namespace

nlohmann::json parse_json(const std::string& text, const std::string& source) {
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    ErrorLocator locator;
    nlohmann::json::sax_parse(text, &locator);
    // nlohmann prefixes its messages with an exception tag the user has no use for.
    const std::string what = e.what();
    const std::size_t tag_end = what.find("] ");
    std::string message = "invalid JSON: " + (tag_end == std::string::npos ? what : what.substr(tag_end + 2));
    if (dynamic_cast<const nlohmann::json::out_of_range*>(&e) != nullptr)
      message += "; expected a number within the range of a double";
    throw InputError(source, line_of(text, locator.position), message);
  }
}

nlohmann::json read_json_file(const std::string& path) { return parse_json(read_input_file(path), path); }

}  // namespace slamkit
