// Grinding-wheel infeed against wheel angle for a lobe: the cam-grinding kinematics.
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
// C = rotation_sense * psi + c_offset_deg (compute_machine_path samples on a C grid).
// The derivatives are taken along psi, per degree, exact for the lift spline (not finite
// differences): X' needs the lift and its slope, X'' its curvature too, so X'' is continuous
// wherever the lift spline's H'' is (everywhere, for a C2 spline). compute_wheel_path fills
// all four vectors; a path built by hand (e.g. read back from a table) may leave the two
// derivative vectors empty, and ground_lobe_reading ignores them.
struct WheelPath {
  std::vector<double> psi_deg;
  std::vector<double> x_mm;
  std::vector<double> dx_dpsi_mm_per_deg;     // dX/dpsi
  std::vector<double> d2x_dpsi2_mm_per_deg2;  // d2X/dpsi2
};

// Computes the wheel path for the design lift `lift_mm` (cam frame, mm, 0 on the base circle,
// follower of `part`) with wheel radius part.wheel_radius_mm, at `step_deg` spacing in psi.
// X(beta) and psi(beta) follow the cam-grinding kinematics (flat: support function p = rb + H; roller
// and knife edge: pitch curve rho = rb + rr + H). Resampling onto the uniform psi grid:
// psi(beta), X, X' and X'' are tabulated in cells of at most 0.5 deg of beta that never
// straddle a knot of the lift spline (so everything is smooth inside a cell). Where a cell's
// quintic through X, X', X'' at its ends matches the kinematics at the cell's middle (X to
// 1e-11 mm, X' 2e-11 mm/deg, X'' 3e-10 mm/deg^2), its rows come from it; elsewhere each row
// inverts psi(beta) (cubic Hermite start, safeguarded Newton to 1e-6 deg, then a second-order
// Taylor step in psi). Either way X is exact to ~1e-11 mm, far below the spline's own
// interpolation error; tests/compensation/wheel_path_test.cc holds the eccentric disc to the
// exact formula (X 1e-9 mm, X' 1e-9 mm/deg, X'' 1e-8 mm/deg^2).
// Errors:
//  - kInvalidInput: step not in (0, 90] or 360/step not an integer; radii not positive.
//  - kRefused: the lobe cannot exist (see check_lobe_shape: non-convex flat lobe, undercut
//    roller, lift below -rb), or psi(beta) stops increasing because the wheel is too large
//    for a concave flank; the message names the cam angle range and the largest wheel radius
//    that fits (the smallest radius of curvature of the concave part of the cam surface).
Result<WheelPath> compute_wheel_path(const PeriodicSpline& lift_mm, const Part& part, double step_deg);

// The same wheel path in the machine frame, on the uniform C grid a curve table needs.
// c_deg[k] = k * c_step_deg for k = 0 .. 360/c_step_deg - 1; row k is the wheel at
// psi = rotation_sense * (C - c_offset_deg), computed there directly (no re-interpolation),
// so any c_offset_deg, whole step or not, and either sense give exact rows.
// dX/dC = rotation_sense * dX/dpsi; d2X/dC2 = d2X/dpsi2.
struct MachinePath {
  std::vector<double> c_deg;
  std::vector<double> x_mm;
  std::vector<double> dx_dc_mm_per_deg;
  std::vector<double> d2x_dc2_mm_per_deg2;
};

// Errors: as compute_wheel_path; kInvalidInput also for rotation_sense not +-1 or a
// non-finite c_offset_deg.
Result<MachinePath> compute_machine_path(const PeriodicSpline& lift_mm, const Part& part, double c_step_deg);

// Wheel-slide motion in time with the work spindle at a constant `speed_rpm`, C increasing
// for a positive speed (decreasing for a negative one): C turns 6 * speed_rpm degrees a
// second, so dX/dt = dX/dC * 6 n (mm/s) and d2X/dt2 = d2X/dC2 * (6 n)^2 (mm/s^2). From the
// cam frame, dX/dC = rotation_sense * dX/dpsi.
inline double spindle_deg_per_s(double speed_rpm) { return 6.0 * speed_rpm; }
inline double slide_velocity_mm_per_s(double dx_dc_mm_per_deg, double speed_rpm) {
  return dx_dc_mm_per_deg * spindle_deg_per_s(speed_rpm);
}
inline double slide_acceleration_mm_per_s2(double d2x_dc2_mm_per_deg2, double speed_rpm) {
  const double w = spindle_deg_per_s(speed_rpm);
  return d2x_dc2_mm_per_deg2 * w * w;
}

}  // namespace gaugeloop
