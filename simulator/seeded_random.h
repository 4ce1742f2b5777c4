// Seeded randomness for the simulators: pure functions of a seed and an index, so a run or a
// ground part is repeatable and independent of the order things are computed in.
#pragma once

#include <cmath>
#include <cstdint>

#include "core/angles.h"

namespace gaugeloop::seeded {

// splitmix64: a well-mixed 64-bit hash.
inline std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A uniform deviate in (0, 1) from a hash: never 0, so its logarithm is finite.
inline double unit_uniform(std::uint64_t h) {
  return (static_cast<double>(h >> 11) + 0.5) * (1.0 / 9007199254740992.0);
}

// A uniform deviate in [lo, hi) from (seed, index).
inline double uniform(std::uint64_t seed, std::uint64_t index, double lo, double hi) {
  return lo + (hi - lo) * unit_uniform(mix(mix(seed) ^ (index * 0x9e3779b97f4a7c15ULL)));
}

// A standard normal deviate (Box-Muller) from (seed, index).
inline double normal(std::uint64_t seed, std::uint64_t index) {
  const double u1 = unit_uniform(mix(seed ^ mix(2 * index)));
  const double u2 = unit_uniform(mix(seed ^ mix(2 * index + 1)));
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
}

}  // namespace gaugeloop::seeded
