#include "slamkit/assoc/association_config.hpp"

#include <fmt/format.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "slamkit/core/json_options.hpp"
#include "slamkit/core/names.hpp"

namespace slamkit {

namespace {

// The numeric settings; the method and gate_known (an enum and an optional) are handled beside it.
// The table checks kinds only: validate() states the ranges, in one place.
constexpr OptionKey<AssociationConfig> kNumericKeys[] = {
    {"accept_probability", RealOption<AssociationConfig>{[](AssociationConfig& c) -> double& { return c.accept_probability; }, option_ranges::kFinite}},
    {"new_landmark_probability", RealOption<AssociationConfig>{[](AssociationConfig& c) -> double& { return c.new_landmark_probability; }, option_ranges::kFinite}},
    {"min_pairing_probability", RealOption<AssociationConfig>{[](AssociationConfig& c) -> double& { return c.min_pairing_probability; }, option_ranges::kFinite}},
    {"clutter_per_scan", RealOption<AssociationConfig>{[](AssociationConfig& c) -> double& { return c.clutter_per_scan; }, option_ranges::kFinite}},
    {"confirm_after", IntegerOption<AssociationConfig, int>{[](AssociationConfig& c) -> int& { return c.confirm_after; }, 1}},
    {"provisional_max_misses", IntegerOption<AssociationConfig, int>{[](AssociationConfig& c) -> int& { return c.provisional_max_misses; }, 1}},
    {"confirmed_max_misses", IntegerOption<AssociationConfig, int>{[](AssociationConfig& c) -> int& { return c.confirmed_max_misses; }, 0}},
    {"view_margin_m", RealOption<AssociationConfig>{[](AssociationConfig& c) -> double& { return c.view_margin_m; }, option_ranges::kNonNegative}},
    {"view_margin_rad", RealOption<AssociationConfig>{[](AssociationConfig& c) -> double& { return c.view_margin_rad; }, option_ranges::kNonNegative}},
    {"jcbb_max_nodes", IntegerOption<AssociationConfig, std::uint64_t>{[](AssociationConfig& c) -> std::uint64_t& { return c.jcbb_max_nodes; }, 1}},
    {"relocalise_min_pairs", IntegerOption<AssociationConfig, std::uint64_t>{[](AssociationConfig& c) -> std::uint64_t& { return c.relocalise_min_pairs; }, 0}},
    {"relocalise_window_s", RealOption<AssociationConfig>{[](AssociationConfig& c) -> double& { return c.relocalise_window_s; }, option_ranges::kFinite}},
};

}  // namespace

AssociationMethod parse_association_method(const std::string& name) {
  if (name == "known") return AssociationMethod::kKnown;
  if (name == "nn") return AssociationMethod::kNearestNeighbour;
  if (name == "jcbb") return AssociationMethod::kJcbb;
  throw std::invalid_argument(unknown_name_message("association", name, {"known", "nn", "jcbb"}));
}

std::string to_string(AssociationMethod method) {
  switch (method) {
    case AssociationMethod::kKnown: return "known";
    case AssociationMethod::kNearestNeighbour: return "nn";
    case AssociationMethod::kJcbb: return "jcbb";
  }
  return "known";
}

void validate(const AssociationConfig& c) {
  auto fail = [](const char* setting, const std::string& range, const auto& found) {
    throw std::invalid_argument(fmt::format("association setting {} must be {}, found {}", setting, range, found));
  };
  if (!(c.accept_probability > 0.0 && c.accept_probability < 1.0))
    fail("accept_probability", "in (0, 1)", c.accept_probability);
  if (!(c.new_landmark_probability >= c.accept_probability && c.new_landmark_probability < 1.0))
    fail("new_landmark_probability", fmt::format("in [accept_probability, 1) = [{}, 1)", c.accept_probability),
         c.new_landmark_probability);
  if (!(c.min_pairing_probability >= 0.0 && c.min_pairing_probability < 1.0))
    fail("min_pairing_probability", "in [0, 1)", c.min_pairing_probability);
  if (!(std::isfinite(c.clutter_per_scan) && c.clutter_per_scan >= 0.0))
    fail("clutter_per_scan", "finite and >= 0", c.clutter_per_scan);
  if (c.confirm_after < 1) fail("confirm_after", ">= 1", c.confirm_after);
  if (c.provisional_max_misses < 1) fail("provisional_max_misses", ">= 1", c.provisional_max_misses);
  if (c.confirmed_max_misses < 0) fail("confirmed_max_misses", ">= 0 (0: never remove)", c.confirmed_max_misses);
  if (!(std::isfinite(c.view_margin_m) && c.view_margin_m >= 0.0))
    fail("view_margin_m", "finite and >= 0", c.view_margin_m);
  if (!(std::isfinite(c.view_margin_rad) && c.view_margin_rad >= 0.0))
    fail("view_margin_rad", "finite and >= 0", c.view_margin_rad);
  if (c.jcbb_max_nodes < 1) fail("jcbb_max_nodes", ">= 1", c.jcbb_max_nodes);
  if (c.relocalise_min_pairs == 1) fail("relocalise_min_pairs", "0 (off) or >= 2", c.relocalise_min_pairs);
  if (!(std::isfinite(c.relocalise_window_s) && c.relocalise_window_s > 0.0))
    fail("relocalise_window_s", "finite and > 0", c.relocalise_window_s);
}

nlohmann::json to_json(const AssociationConfig& config) {
  nlohmann::json j = options_to_json(config, std::span<const OptionKey<AssociationConfig>>(kNumericKeys));
  j["method"] = to_string(config.method);
  j["gate_known"] = config.gate_known ? nlohmann::json(*config.gate_known) : nlohmann::json("filter default");
  return j;
}

AssociationConfig association_config_from_json(const nlohmann::json& json, const std::string& source) {
  AssociationConfig config;
  read_association_settings(json, source, config);
  try {
    validate(config);
  } catch (const std::invalid_argument& e) {
    throw InputError(source, 0, e.what());
  }
  return config;
}

void read_association_settings(const nlohmann::json& json, const std::string& source, AssociationConfig& config) {
  if (!json.is_object()) throw InputError(source, 0, "expected the association settings as a JSON object");
  nlohmann::json numeric = json;
  if (json.contains("method")) {
    const nlohmann::json& method = json.at("method");
    if (!method.is_string()) throw InputError(source, 0, "association 'method' must be a name, found " + method.dump());
    try {
      config.method = parse_association_method(method.get<std::string>());
    } catch (const std::invalid_argument& e) {
      throw InputError(source, 0, e.what());
    }
    numeric.erase("method");
  }
  if (json.contains("gate_known")) {
    const nlohmann::json& gate = json.at("gate_known");
    if (gate.is_boolean())
      config.gate_known = gate.get<bool>();
    else if (gate != "filter default")
      throw InputError(source, 0, "association 'gate_known' must be true, false or \"filter default\", found " + gate.dump());
    numeric.erase("gate_known");
  }
  option_detail::read_keys(numeric, source, "the association settings",
                           std::span<const OptionKey<AssociationConfig>>(kNumericKeys), config);
}

}  // namespace slamkit
