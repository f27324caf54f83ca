#pragma once
// The one way slamkit reads and writes a settings file (the simulator's config, the datasets'
// config/*.json): a table of keys over a settings struct. Each key names one field and its kind:
//   RealOption     a number, optionally held in degrees in the JSON and in radians in the struct,
//                  with the range it must lie in
//   IntegerOption  an integer within bounds (int and uint64 fields)
//   FlagOption     true or false
//   SectionOption  a nested JSON object with a table of its own, over the same struct
// Missing keys keep their defaults. An unknown key, a value of the wrong kind or out of range is an
// InputError naming the file and the key, so every settings file is checked the same way; a file
// that is not JSON, or holds a number beyond the range of a double, is one naming the file and line.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"
#include "slamkit/core/names.hpp"

namespace slamkit {

/// The range a real setting must lie in: the test of the struct's value (so radians for angles)
/// and how to state it to the user, in the JSON's units.
struct RealRange {
  bool (*ok)(double);
  const char* expected;
};

namespace option_ranges {
// Each fails NaN, as NaN fails every comparison; only kNonNegativeOrInfinite admits infinity.
inline constexpr RealRange kPositive{[](double v) { return v > 0.0 && std::isfinite(v); }, "> 0"};
inline constexpr RealRange kNonNegative{[](double v) { return v >= 0.0 && std::isfinite(v); }, ">= 0"};
inline constexpr RealRange kFinite{[](double v) { return std::isfinite(v); }, "a finite number"};
/// For limits whose default, infinity, means none (a JSON file cannot hold infinity).
inline constexpr RealRange kNonNegativeOrInfinite{[](double v) { return v >= 0.0; }, ">= 0"};
// Degrees-to-radians rounding may put 360 deg an ulp above 2 pi.
inline constexpr RealRange kFieldOfView{[](double v) { return v > 0.0 && v <= 2.0 * kPi * (1.0 + 1e-12); },
                                        "> 0 and <= 360"};
}  // namespace option_ranges

enum class Unit {
  kAsIs,
  kDegrees,  // the JSON holds degrees, the struct radians
};

template <typename Options>
struct OptionKey;

template <typename Options>
struct RealOption {
  double& (*field)(Options&);
  RealRange range;
  Unit unit = Unit::kAsIs;
};

template <typename Options, typename Int>
struct IntegerOption {
  Int& (*field)(Options&);
  Int min = 0;
  Int max = std::numeric_limits<Int>::max();
};

template <typename Options>
struct FlagOption {
  bool& (*field)(Options&);
};

/// A nested object; its keys reach their fields from the same settings struct.
template <typename Options>
struct SectionOption {
  const OptionKey<Options>* keys;
  std::size_t count;
  std::span<const OptionKey<Options>> table() const { return {keys, count}; }
};

/// SectionOption over a key table defined as an array.
template <typename Options, std::size_t N>
constexpr SectionOption<Options> section(const OptionKey<Options> (&keys)[N]) {
  return {keys, N};
}

template <typename Options>
struct OptionKey {
  const char* key;
  std::variant<RealOption<Options>, IntegerOption<Options, int>, IntegerOption<Options, std::uint64_t>,
               FlagOption<Options>, SectionOption<Options>>
      kind;
};

/// Parses JSON text; `source` names it in errors. Malformed JSON, or a number beyond the range of a
/// double, is an InputError naming `source` and the line.
nlohmann::json parse_json(const std::string& text, const std::string& source);
/// parse_json of a file's contents; a file that cannot be read is an InputError naming it.
nlohmann::json read_json_file(const std::string& path);

namespace option_detail {

template <typename... F>
struct Overloaded : F... {
  using F::operator()...;
};
template <typename... F>
Overloaded(F...) -> Overloaded<F...>;

template <typename Int>
std::string integer_range(Int min, Int max) {
  return fmt::format("an integer from {} to {}", min, max);
}

/// The JSON integer as Int if it lies in [min, max]. JSON text parses a non-negative integer as
/// unsigned; a json built in code may hold it signed.
template <typename Int>
bool integer_in(const nlohmann::json& value, Int min, Int max, Int& out) {
  const auto within = [&](auto v) {
    if (std::cmp_less(v, min) || std::cmp_greater(v, max)) return false;
    out = static_cast<Int>(v);
    return true;
  };
  if (value.is_number_unsigned()) return within(value.template get<std::uint64_t>());
  if (value.is_number_integer()) return within(value.template get<std::int64_t>());
  return false;
}

template <typename Options>
std::vector<std::string> key_names(std::span<const OptionKey<Options>> keys) {
  std::vector<std::string> names;
  for (const auto& k : keys) names.emplace_back(k.key);
  return names;
}

/// `what` names the object in errors: "the simulator config", "'car'".
template <typename Options>
void read_keys(const nlohmann::json& json, const std::string& source, const std::string& what,
               std::span<const OptionKey<Options>> keys, Options& options) {
  if (!json.is_object())
    throw InputError(source, 0, fmt::format("expected {} as a JSON object, found {}", what, json.type_name()));
  // Named variables, not a structured binding: clang 14 cannot capture a binding in the lambdas below.
  for (const auto& item : json.items()) {
    const std::string& key = item.key();
    const nlohmann::json& value = item.value();
    const auto k = std::find_if(keys.begin(), keys.end(), [&](const OptionKey<Options>& o) { return key == o.key; });
    if (k == keys.end()) {
      const std::vector<std::string> names = key_names(keys);
      throw InputError(source, 0,
                       fmt::format("unknown key '{}' in {}{}; expected one of: {}", key, what, did_you_mean(key, names),
                                   fmt::join(names, ", ")));
    }
    const auto fail = [&](const std::string& expected) {
      throw InputError(source, 0, fmt::format("'{}' must be {}, found {}", key, expected, value.dump()));
    };
    std::visit(Overloaded{
                   [&](const RealOption<Options>& o) {
                     if (!value.is_number()) fail("a number");
                     const double v = value.template get<double>();
                     o.field(options) = o.unit == Unit::kDegrees ? deg2rad(v) : v;
                   },
                   [&]<typename Int>(const IntegerOption<Options, Int>& o) {
                     if (!integer_in(value, o.min, o.max, o.field(options))) fail(integer_range(o.min, o.max));
                   },
                   [&](const FlagOption<Options>& o) {
                     if (!value.is_boolean()) fail("true or false");
                     o.field(options) = value.template get<bool>();
                   },
                   [&](const SectionOption<Options>& o) {
                     read_keys(value, source, fmt::format("'{}'", key), o.table(), options);
                   },
               },
               k->kind);
  }
}

}  // namespace option_detail

/// Throws an InputError naming `source` and the first key whose value is out of its range. Takes a
/// copy because the key table reaches the fields through mutable references.
template <typename Options>
void validate_options(Options options, const std::string& source, std::span<const OptionKey<Options>> keys) {
  using option_detail::Overloaded;
  for (const auto& k : keys) {
    std::visit(Overloaded{
                   [&](const RealOption<Options>& o) {
                     const double v = o.field(options);
                     if (!o.range.ok(v))
                       throw InputError(source, 0,
                                        fmt::format("'{}' must be {}, found {}", k.key, o.range.expected,
                                                    o.unit == Unit::kDegrees ? rad2deg(v) : v));
                   },
                   [&]<typename Int>(const IntegerOption<Options, Int>& o) {
                     const Int v = o.field(options);
                     if (std::cmp_less(v, o.min) || std::cmp_greater(v, o.max))
                       throw InputError(source, 0,
                                        fmt::format("'{}' must be {}, found {}", k.key,
                                                    option_detail::integer_range(o.min, o.max), v));
                   },
                   [](const FlagOption<Options>&) {},
                   [&](const SectionOption<Options>& o) { validate_options(options, source, o.table()); },
               },
               k.kind);
  }
}

/// Reads `json` over `defaults`, then validates the result. `what` names the settings in errors,
/// e.g. "the simulator config".
template <typename Options>
Options options_from_json(const nlohmann::json& json, const std::string& source, const std::string& what,
                          Options defaults, std::span<const OptionKey<Options>> keys) {
  option_detail::read_keys(json, source, what, keys, defaults);
  validate_options(defaults, source, keys);
  return defaults;
}

/// The settings as JSON with the keys options_from_json reads.
template <typename Options>
nlohmann::json options_to_json(Options options, std::span<const OptionKey<Options>> keys) {
  using option_detail::Overloaded;
  nlohmann::json j = nlohmann::json::object();
  for (const auto& k : keys) {
    std::visit(Overloaded{
                   [&](const RealOption<Options>& o) {
                     const double v = o.field(options);
                     // Rounded to 12 significant digits so that whole degrees print as such after
                     // the trip through radians, and read back as the same radians.
                     j[k.key] = o.unit == Unit::kDegrees
                                    ? std::strtod(fmt::format("{:.12g}", rad2deg(v)).c_str(), nullptr)
                                    : v;
                   },
                   [&]<typename Int>(const IntegerOption<Options, Int>& o) { j[k.key] = o.field(options); },
                   [&](const FlagOption<Options>& o) { j[k.key] = o.field(options); },
                   [&](const SectionOption<Options>& o) { j[k.key] = options_to_json(options, o.table()); },
               },
               k.kind);
  }
  return j;
}

}  // namespace slamkit
