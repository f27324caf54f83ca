#pragma once
// The simulator's one source of uniform numbers. Private to the sim module.
#include <cstdint>
#include <random>

namespace slamkit::sim_detail {

/// Uniform on [0, 1) from the top 53 bits: unlike std::uniform_real_distribution its output is fixed
/// by the standard engine alone, so a seed gives the same world and log with every standard library.
inline double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

}  // namespace slamkit::sim_detail
