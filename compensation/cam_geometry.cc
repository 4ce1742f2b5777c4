// Validation of follower radii and of the design lobe's shape.
#include "compensation/cam_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "compensation/message_text.h"

namespace gaugeloop {
namespace {

constexpr double kShapeSpacingDeg = 0.05;

std::string part_label(const Part& part) { return "part '" + part.name + "' lobe " + std::to_string(part.lobe); }

}  // namespace

Result<FollowerGeometry> follower_geometry(const Part& part) {
  FollowerGeometry g;
  g.kind = part.follower;
  g.base_circle_radius_mm = part.base_circle_radius_mm;
  if (!std::isfinite(g.base_circle_radius_mm) || g.base_circle_radius_mm <= 0.0) {
    return make_error(ErrorCode::kInvalidInput, part_label(part) + ": base circle radius " +
                                                    format_fixed(part.base_circle_radius_mm, 3) +
                                                    " mm is not a positive number; set base_circle_radius_mm");
  }
  switch (part.follower) {
    case FollowerKind::kFlat:
    case FollowerKind::kKnifeEdge:
      g.roller_radius_mm = 0.0;
      break;
    case FollowerKind::kRoller:
      g.roller_radius_mm = part.follower_radius_mm;
      if (!std::isfinite(g.roller_radius_mm) || g.roller_radius_mm <= 0.0) {
        return make_error(ErrorCode::kInvalidInput, part_label(part) + ": roller follower radius " +
                                                        format_fixed(part.follower_radius_mm, 3) +
                                                        " mm is not a positive number; set follower_radius_mm, or use "
                                                        "follower knife_edge for a radius of 0");
      }
      break;
  }
  return g;
}

std::vector<double> dense_angle_grid_deg(const PeriodicSpline& spline, double max_spacing_deg) {
  const Eigen::VectorXd& knots = spline.knots_deg();
  const Eigen::Index n = knots.size();
  std::vector<double> grid;
  for (Eigen::Index i = 0; i < n; ++i) {
    const double from = knots(i);
    const double to = (i + 1 < n) ? knots(i + 1) : knots(0) + PeriodicSpline::kPeriodDeg;
    const int pieces = std::max(2, static_cast<int>(std::ceil((to - from) / max_spacing_deg)));
    for (int k = 0; k < pieces; ++k) grid.push_back(from + (to - from) * k / pieces);
  }
  return grid;
}

double polar_curvature_per_mm(double r_mm, double r1_mm, double r2_mm) {
  const double q = r_mm * r_mm + r1_mm * r1_mm;
  return (r_mm * r_mm + 2.0 * r1_mm * r1_mm - r_mm * r2_mm) / (q * std::sqrt(q));
}

Status check_lobe_shape(const PeriodicSpline& lift_mm, const FollowerGeometry& g) {
  const std::vector<double> grid = dense_angle_grid_deg(lift_mm, kShapeSpacingDeg);
  const double rb = g.base_circle_radius_mm;
  const double rr = g.roller_radius_mm;

  std::vector<bool> bad(grid.size(), false);
  bool any = false;
  double lowest_lift = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < grid.size(); ++i) {
    const double h = lift_mm.value(grid[i]);
    lowest_lift = std::min(lowest_lift, h);
    if (!(rb + h > 0.0)) bad[i] = any = true;
  }
  if (any) {
    return make_error(ErrorCode::kRefused, "the lift reaches " + format_fixed(lowest_lift, 4) +
                                               " mm, below minus the base circle radius (" + format_fixed(rb, 3) +
                                               " mm), at cam angle " + describe_angle_ranges(grid, bad) +
                                               "; check the lift table and base_circle_radius_mm");
  }

  if (g.kind == FollowerKind::kFlat) {
    // The radius of curvature of a curve with support function p is p + p''.
    double smallest = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < grid.size(); ++i) {
      const double radius = rb + lift_mm.value(grid[i]) + lift_mm.d2(grid[i]);
      if (!(radius > 0.0)) {
        bad[i] = any = true;
        smallest = std::min(smallest, radius);
      }
    }
    if (any) {
      return make_error(ErrorCode::kRefused,
                        "a flat follower needs a convex lobe, but rb + H + H'' <= 0 (radius of "
                        "curvature down to " +
                            format_fixed(smallest, 3) + " mm) at cam angle " + describe_angle_ranges(grid, bad) +
                            "; check the lift table, base_circle_radius_mm and the follower kind");
    }
    return {};
  }

  if (g.kind == FollowerKind::kRoller) {
    // Undercut: where the pitch curve is convex with radius <= rr the cam surface, its
    // inward offset by rr, folds over itself.
    double smallest_pitch_radius = std::numeric_limits<double>::infinity();
    for (size_t i = 0; i < grid.size(); ++i) {
      const double rho = rb + rr + lift_mm.value(grid[i]);
      const double kappa = polar_curvature_per_mm(rho, lift_mm.d1(grid[i]), lift_mm.d2(grid[i]));
      if (kappa > 0.0 && !(1.0 - rr * kappa > 0.0)) {
        bad[i] = any = true;
        smallest_pitch_radius = std::min(smallest_pitch_radius, 1.0 / kappa);
      }
    }
    if (any) {
      return make_error(ErrorCode::kRefused, "the roller (radius " + format_fixed(rr, 3) +
                                                 " mm) undercuts the lobe: the pitch curve's radius of curvature is "
                                                 "down to " +
                                                 format_fixed(smallest_pitch_radius, 3) + " mm at cam angle " +
                                                 describe_angle_ranges(grid, bad) +
                                                 "; check the lift table and follower_radius_mm");
    }
  }
  return {};
}

}  // namespace gaugeloop
