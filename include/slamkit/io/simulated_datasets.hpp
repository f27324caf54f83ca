#pragma once
// Simulated datasets named by a spec, simulated in memory when they are opened: the same spec gives
// the same data bit for bit (the simulator draws in a fixed order, without fused multiply-adds), so
// a run of one can be repeated and evaluated from its run.json without a log on disk, and a campaign
// of thousands of seeds writes no simulator logs.
//   scenario:NAME[:SEED]             a named scenario (sim/simulator.hpp's scenario()), noise seed SEED
//   family:NAME:WORLD_SEED[:SEED]    the world WORLD_SEED of a world family, noise seed SEED
//   building:NAME[:SEED]             a simulated building (sim/building.hpp), noise seed SEED
// A missing SEED is the scenario's own (1 for families and buildings). The dataset settings, where
// given, are a partial simulator config laid over the scenario's (the keys of `slamkit simulate
// --config`, e.g. {"clutter_rate_per_scan": 2, "loops": 1}); the seed is the spec's alone.
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "slamkit/core/dataset.hpp"

namespace slamkit {

/// The kinds above, by name.
bool is_simulated_kind(const std::string& kind);

/// Checks the part after "KIND:" without simulating: a known name (with "did you mean"), whole
/// numbers for the seeds. Throws std::invalid_argument.
void check_simulated_spec(const std::string& kind, const std::string& rest);

/// Simulates the dataset `kind`:`rest` names; `settings` (nullptr for none) overrides the simulator
/// config, `source` naming them in errors. Throws InputError on a bad spec or setting.
Dataset simulate_dataset(const std::string& kind, const std::string& rest, const nlohmann::json* settings,
                         const std::string& source);

}  // namespace slamkit
