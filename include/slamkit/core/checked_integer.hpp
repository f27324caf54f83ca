#pragma once
// Conversion of a computed double to an integer type. A static_cast is undefined behaviour when the
// value is NaN, infinite or beyond the type's range, and such values do arrive from hostile input
// (a speed of 1e-300 makes a step count of 1e300). Every place where a double becomes a count, an
// index, a time step or a cell key converts through here, so the failure is an error that names the
// quantity.
#include <fmt/format.h>

#include <cmath>
#include <concepts>
#include <limits>
#include <stdexcept>
#include <string_view>

namespace slamkit {

/// `value` truncated toward zero, as static_cast would; std::out_of_range naming `what` when it is
/// not a finite number that fits in Int.
template <std::integral Int>
Int checked_integer(double value, std::string_view what) {
  // min and max + 1 are 0 or powers of two, so exact in a double (max itself need not be).
  constexpr double kMin = static_cast<double>(std::numeric_limits<Int>::min());
  constexpr double kMaxPlusOne = static_cast<double>(std::numeric_limits<Int>::max() / 2 + 1) * 2.0;
  const double whole = std::trunc(value);  // NaN stays NaN and fails both tests
  if (!(whole >= kMin && whole < kMaxPlusOne))
    throw std::out_of_range(fmt::format("{} is {}, outside the range [{}, {}] that can be represented", what, value,
                                        std::numeric_limits<Int>::min(), std::numeric_limits<Int>::max()));
  return static_cast<Int>(value);
}

}  // namespace slamkit
