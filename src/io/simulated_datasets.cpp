#include "slamkit/io/simulated_datasets.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <charconv>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <stdexcept>
#include <string_view>
#include <vector>

#include "slamkit/core/error.hpp"
#include "slamkit/core/names.hpp"
#include "slamkit/io/sim_log.hpp"
#include "slamkit/sim/building.hpp"
#include "slamkit/sim/simulator.hpp"

namespace slamkit {
namespace {

constexpr std::string_view kScenario = "scenario";
constexpr std::string_view kFamily = "family";
constexpr std::string_view kBuilding = "building";

std::vector<std::string> split(const std::string& text) {
  std::vector<std::string> parts;
  std::size_t begin = 0;
  for (std::size_t colon = text.find(':'); colon != std::string::npos; colon = text.find(':', begin)) {
    parts.push_back(text.substr(begin, colon - begin));
    begin = colon + 1;
  }
  parts.push_back(text.substr(begin));
  return parts;
}

std::uint64_t parse_seed(const std::string& text, std::string_view what) {
  std::uint64_t value = 0;
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (text.empty() || error != std::errc() || end != text.data() + text.size())
    throw std::invalid_argument(fmt::format("expected {} as a whole number >= 0, found '{}'", what, text));
  return value;
}

/// A simulated spec taken apart: the name, and the seeds that are given.
struct SimulatedSpec {
  std::string name;
  std::optional<std::uint64_t> world_seed, seed;
};

SimulatedSpec parse(const std::string& kind, const std::string& rest) {
  const std::vector<std::string> parts = split(rest);
  const bool family = kind == kFamily;
  const std::string form = family ? "family:NAME:WORLD_SEED[:SEED]" : fmt::format("{}:NAME[:SEED]", kind);
  if (parts.size() < (family ? 2u : 1u) || parts.size() > (family ? 3u : 2u) || parts[0].empty())
    throw std::invalid_argument(fmt::format("'{}:{}' is not a simulated dataset; expected {}", kind, rest, form));
  const std::vector<std::string> names = kind == kScenario ? scenario_names()
                                         : family          ? world_family_names()
                                                           : floor_plan_names();
  if (std::find(names.begin(), names.end(), parts[0]) == names.end())
    throw std::invalid_argument(unknown_name_message(kind, parts[0], names));
  SimulatedSpec spec{parts[0], {}, {}};
  if (family) spec.world_seed = parse_seed(parts[1], "the world seed");
  if (parts.size() == (family ? 3u : 2u)) spec.seed = parse_seed(parts.back(), "the noise seed");
  return spec;
}

/// `base` with `settings` laid over it: what simulate --config reads, with the base's values for
/// the keys the settings leave out. The seed is the spec's, so a second one is refused.
nlohmann::json overlaid(nlohmann::json base, const nlohmann::json* settings, const std::string& source) {
  if (settings == nullptr) return base;
  if (!settings->is_object())
    throw InputError(source, 0, fmt::format("expected an object of simulator settings, found {}", settings->dump()));
  if (settings->contains("seed"))
    throw InputError(source, 0, "'seed': a simulated dataset's noise seed is its spec's last number, not a setting");
  base.merge_patch(*settings);
  return base;
}

}  // namespace

bool is_simulated_kind(const std::string& kind) { return kind == kScenario || kind == kFamily || kind == kBuilding; }

void check_simulated_spec(const std::string& kind, const std::string& rest) { parse(kind, rest); }

Dataset simulate_dataset(const std::string& kind, const std::string& rest, const nlohmann::json* settings,
                         const std::string& source) {
  SimulatedSpec spec;
  try {
    spec = parse(kind, rest);
  } catch (const std::invalid_argument& e) {
    throw InputError(fmt::format("{}:{}", kind, rest), 0, e.what());
  }
  if (kind == kBuilding) {
    BuildingSimConfig config =
        building_sim_config_from_json(overlaid(to_json(BuildingSimConfig{}), settings, source), source);
    config.seed = spec.seed.value_or(1);
    return simulate_building(floor_plan(spec.name), config);
  }
  const Scenario base = kind == kScenario ? scenario(spec.name) : world_family(spec.name).member(*spec.world_seed);
  SimulatorConfig config = simulator_config_from_json(overlaid(to_json(base.config), settings, source), source);
  config.seed = spec.seed.value_or(kind == kScenario ? base.config.seed : 1);
  return as_logged(simulate(base.world, config));
}

}  // namespace slamkit
