// The follower geometry of a part, validated, and the checks that a design lobe can exist.
#pragma once

#include <vector>

#include "compensation/periodic_spline.h"
#include "core/part.h"
#include "core/result.h"

namespace gaugeloop {

// Radii of a part as the kinematics use them, in mm.
struct FollowerGeometry {
  FollowerKind kind = FollowerKind::kFlat;
  double base_circle_radius_mm = 0.0;  // rb > 0
  // rr: the roller radius for kRoller (> 0); 0 for a knife edge; unused (0) for flat.
  double roller_radius_mm = 0.0;
};

// Validates the radii of `part` that do not depend on the wheel: rb finite and > 0; for a
// roller follower rr finite and > 0. kInvalidInput naming the part and the field.
Result<FollowerGeometry> follower_geometry(const Part& part);

// Sampling grid over one turn, cam frame, in degrees: starts at the spline's first knot,
// strictly increasing, below first knot + 360; every knot interval is split into equal
// pieces no wider than `max_spacing_deg` (at least 2 pieces).
std::vector<double> dense_angle_grid_deg(const PeriodicSpline& spline, double max_spacing_deg);

// Signed curvature (1/mm, positive where convex) of the curve r(beta) in polar form, with
// r' and r'' per radian. For a roller follower r = rb + rr + H is the pitch curve.
double polar_curvature_per_mm(double r_mm, double r1_mm, double r2_mm);

// Whether the lobe described by `lift_mm` (cam frame, 0 on the base circle, follower of
// `geometry`) can exist, checked on a dense grid:
//  - everywhere rb + H > 0 (the lift never reaches into the cam axis);
//  - flat follower: the lobe is convex, rb + H + H'' > 0 (H'' per rad^2);
//  - roller follower: no undercut, the roller radius is smaller than the radius of curvature
//    of the pitch curve wherever that is convex.
// kRefused naming the cam angle range(s) and what to check.
Status check_lobe_shape(const PeriodicSpline& lift_mm, const FollowerGeometry& geometry);

// check_lobe_shape's conditions for a flat follower, exactly rather than sampled: on each
// spline piece rb + H and rb + H + H'' are cubics, whose minimum over the piece is at an end
// or where their derivative (a quadratic) vanishes. Returns the smallest radius of curvature
// rb + H + H'' over the turn (mm) and where (cam degrees), and the smallest rb + H.
struct FlatLobeMinima {
  double radius_of_curvature_mm = 0.0;
  double radius_at_deg = 0.0;
  double support_mm = 0.0;  // rb + H
};
FlatLobeMinima flat_lobe_minima(const PeriodicSpline& lift_mm, double rb_mm);

// The grid check_lobe_shape samples (dense_angle_grid_deg at this spacing), so a caller that
// needs the lift there anyway evaluates it once and passes it to the overload below.
inline constexpr double kShapeCheckSpacingDeg = 0.05;

// check_lobe_shape on lift values already evaluated: lift_at_grid[i] = lift.evaluate(grid[i]),
// grid = dense_angle_grid_deg(lift, kShapeCheckSpacingDeg).
Status check_lobe_shape(const std::vector<double>& grid, const std::vector<PeriodicSpline::Point>& lift_at_grid,
                        const FollowerGeometry& geometry);

}  // namespace gaugeloop
