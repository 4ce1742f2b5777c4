// Angles in the tests: pi and degrees to radians, one definition for every test file.
#pragma once

#include <numbers>

namespace gaugeloop::testing {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;

}  // namespace gaugeloop::testing
