// Grinding-wheel infeed against wheel angle for a lobe: the kinematics of BRIEF section 3.
#pragma once

#include <vector>

#include "compensation/periodic_spline.h"
#include "core/part.h"
#include "core/result.h"

namespace gaugeloop {

// Wheel infeed on a uniform grid of wheel angles.
// Frame: cam frame. psi_deg[k] = k * step for k = 0 .. 360/step - 1, the polar angle of the
// wheel centre about the cam axis (0 at the nose, counter-clockwise). x_mm[k] = |W| - rw - rb,
// the wheel-slide infeed in mm, 0 on the base circle. The machine angle of row k is
// C = rotation_sense * psi + c_offset_deg (conversion is the NC writer's job).
struct WheelPath {
  std::vector<double> psi_deg;
  std::vector<double> x_mm;
};

// Computes the wheel path for the design lift `lift_mm` (cam frame, mm, 0 on the base circle,
// follower of `part`) with wheel radius part.wheel_radius_mm, at `step_deg` spacing in psi.
// X(beta) and psi(beta) follow BRIEF section 3 (flat: support function p = rb + H; roller
// and knife edge: pitch curve rho = rb + rr + H); X is resampled onto the uniform psi grid by
// inverting psi(beta) (bracketing plus safeguarded Newton, |psi error| < 1e-10 deg).
// Errors:
//  - kInvalidInput: step not in (0, 90] or 360/step not an integer; radii not positive.
//  - kRefused: the lobe cannot exist (see check_lobe_shape: non-convex flat lobe, undercut
//    roller, lift below -rb), or psi(beta) stops increasing because the wheel is too large
//    for a concave flank; the message names the cam angle range and the largest wheel radius
//    that fits (the smallest radius of curvature of the concave part of the cam surface).
Result<WheelPath> compute_wheel_path(const PeriodicSpline& lift_mm, const Part& part, double step_deg);

}  // namespace gaugeloop
