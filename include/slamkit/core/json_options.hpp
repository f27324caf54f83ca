#pragma once
// Settings structs read from and written to JSON through a table of keys: each key names one
// numeric field, whether the JSON holds it in degrees (the struct in radians), and the range it must
// lie in. Unknown keys, non-numbers and out-of-range values are InputErrors naming the key, so every
// shipped configuration file is checked the same way.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <nlohmann/json.hpp>
#include <span>
#include <string>

#include "slamkit/core/angles.hpp"
#include "slamkit/core/error.hpp"

namespace slamkit {

template <typename Options>
struct OptionKey {
  const char* key;
  double& (*field)(Options&);
  bool degrees;          // the JSON holds degrees, the struct radians
  bool (*ok)(double);    // tests the struct's value
  const char* expected;  // the same range for the user, in the JSON's units
};

namespace option_checks {
inline bool positive(double v) { return v > 0.0; }
inline bool non_negative(double v) { return v >= 0.0; }
inline bool any(double) { return true; }
// Degrees-to-radians rounding may put 360 deg an ulp above 2 pi.
inline bool field_of_view(double v) { return v > 0.0 && v <= 2.0 * kPi * (1.0 + 1e-12); }
}  // namespace option_checks

/// Throws an InputError naming `source` and the first key whose value is out of its range.
template <typename Options>
void validate_options(Options options, const std::string& source, std::span<const OptionKey<Options>> keys) {
  for (const auto& k : keys) {
    const double v = k.field(options);
    if (!std::isfinite(v) || !k.ok(v))
      throw InputError(source, 0,
                       fmt::format("'{}' must be {}, found {}", k.key, k.expected, k.degrees ? rad2deg(v) : v));
  }
}

/// Reads `json` over `defaults`: keys absent keep their default. `what` names the settings in errors.
template <typename Options>
Options options_from_json(const nlohmann::json& json, const std::string& source, const std::string& what,
                          Options defaults, std::span<const OptionKey<Options>> keys) {
  if (!json.is_object())
    throw InputError(source, 0, fmt::format("expected the {} as a JSON object, found {}", what, json.type_name()));
  for (const auto& [key, value] : json.items()) {
    const auto k = std::find_if(keys.begin(), keys.end(), [&](const OptionKey<Options>& o) { return key == o.key; });
    if (k == keys.end()) {
      std::string known;
      for (const auto& o : keys) known += fmt::format("{}{}", known.empty() ? "" : ", ", o.key);
      throw InputError(source, 0, fmt::format("unknown key '{}' in the {}; expected one of: {}", key, what, known));
    }
    if (!value.is_number())
      throw InputError(source, 0, fmt::format("'{}' must be a number, found {}", key, value.dump()));
    const double v = value.template get<double>();
    k->field(defaults) = k->degrees ? deg2rad(v) : v;
  }
  validate_options(defaults, source, keys);
  return defaults;
}

template <typename Options>
nlohmann::json options_to_json(Options options, std::span<const OptionKey<Options>> keys) {
  nlohmann::json j = nlohmann::json::object();
  for (const auto& k : keys) {
    const double v = k.field(options);
    // Rounded to 12 significant digits so that whole degrees print as such after the trip through
    // radians, and read back as the same radians.
    j[k.key] = k.degrees ? std::strtod(fmt::format("{:.12g}", rad2deg(v)).c_str(), nullptr) : v;
  }
  return j;
}

}  // namespace slamkit
