// A smooth periodic wheel path with exact derivatives, for tests with known answers:
// X(C) = a (1 - cos C) + b sin 2C, C in degrees.
#pragma once

#include <cmath>
#include <numbers>

#include "nc_out/sampled_path.h"
#include "tests/support/angles.h"

namespace gaugeloop::testing {

inline SampledPath analytic_path(double a_mm, double b_mm, double step_deg = 0.01) {
  SampledPath p;
  p.c_step_deg = step_deg;
  const int n = static_cast<int>(std::lround(360.0 / step_deg));
  const double k = kRadPerDeg;
  for (int i = 0; i < n; ++i) {
    const double t = i * step_deg * k;
    p.x_mm.push_back(a_mm * (1.0 - std::cos(t)) + b_mm * std::sin(2.0 * t));
    p.dx_dc_mm_per_deg.push_back((a_mm * std::sin(t) + 2.0 * b_mm * std::cos(2.0 * t)) * k);
    p.d2x_dc2_mm_per_deg2.push_back((a_mm * std::cos(t) - 4.0 * b_mm * std::sin(2.0 * t)) * k * k);
  }
  return p;
}

}  // namespace gaugeloop::testing
