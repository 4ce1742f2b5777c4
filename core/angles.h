// Angles: pi and the factors between degrees and radians, one definition for the whole product.
#pragma once

#include <numbers>

namespace gaugeloop {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kRadPerDeg = std::numbers::pi / 180.0;
inline constexpr double kDegPerRad = 180.0 / std::numbers::pi;

}  // namespace gaugeloop
