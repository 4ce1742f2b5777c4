// Validation of follower radii and of the design lobe's shape.
#include "compensation/cam_geometry.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <numbers>
#include <string>

#include "compensation/message_text.h"

namespace gaugeloop {
namespace {

std::string part_label(const Part& part) { return "part '" + part.name + "' lobe " + std::to_string(part.lobe); }

// The smallest value of p0 + p1 t + p2 t^2 + p3 t^3 for t in [0, w], and where.
void cubic_minimum(double p0, double p1, double p2, double p3, double w, double& value, double& at) {
  auto f = [&](double t) { return p0 + t * (p1 + t * (p2 + t * p3)); };
  value = f(0.0);
  at = 0.0;
  auto consider = [&](double t) {
    if (t > 0.0 && t <= w) {
      const double v = f(t);
      if (v < value) {
        value = v;
        at = t;
      }
    }
  };
  consider(w);
  // f'(t) = p1 + 2 p2 t + 3 p3 t^2.
  const double qa = 3.0 * p3;
  const double qb = 2.0 * p2;
  if (std::abs(qa) < 1e-300) {
    if (qb != 0.0) consider(-p1 / qb);
    return;
  }
  const double disc = qb * qb - 4.0 * qa * p1;
  if (disc < 0.0) return;
  const double root = std::sqrt(disc);
  consider((-qb + root) / (2.0 * qa));
  consider((-qb - root) / (2.0 * qa));
}

}  // namespace

FlatLobeMinima flat_lobe_minima(const PeriodicSpline& lift_mm, double rb_mm) {
  // H'' per rad^2 from the piece's per-degree coefficients: (2c + 6dt) (180/pi)^2.
  constexpr double k = (180.0 / std::numbers::pi) * (180.0 / std::numbers::pi);
  FlatLobeMinima m;
  m.radius_of_curvature_mm = std::numeric_limits<double>::infinity();
  m.support_mm = std::numeric_limits<double>::infinity();
  for (std::ptrdiff_t i = 0; i < lift_mm.size(); ++i) {
    const PeriodicSpline::Piece p = lift_mm.piece(i);
    double value = 0.0;
    double at = 0.0;
    cubic_minimum(rb_mm + p.a + 2.0 * p.c * k, p.b + 6.0 * p.d * k, p.c, p.d, p.width_deg, value, at);
    if (value < m.radius_of_curvature_mm) {
      m.radius_of_curvature_mm = value;
      m.radius_at_deg = std::fmod(p.knot_deg + at, PeriodicSpline::kPeriodDeg);
    }
    cubic_minimum(rb_mm + p.a, p.b, p.c, p.d, p.width_deg, value, at);
    m.support_mm = std::min(m.support_mm, value);
  }
  return m;
}

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
  const std::vector<double>& knots = spline.knots_deg();
  const size_t n = knots.size();
  std::vector<double> grid;
  for (size_t i = 0; i < n; ++i) {
    const double from = knots[i];
    const double to = (i + 1 < n) ? knots[i + 1] : knots[0] + PeriodicSpline::kPeriodDeg;
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
  if (g.kind == FollowerKind::kFlat) {
    // Exact and cheap; the samples below only say where, when the lobe is refused.
    const FlatLobeMinima m = flat_lobe_minima(lift_mm, g.base_circle_radius_mm);
    if (m.support_mm > 0.0 && m.radius_of_curvature_mm > 0.0) return {};
  }
  const std::vector<double> grid = dense_angle_grid_deg(lift_mm, kShapeCheckSpacingDeg);
  std::vector<PeriodicSpline::Point> lift(grid.size());
  for (size_t i = 0; i < grid.size(); ++i) lift[i] = lift_mm.evaluate(grid[i]);
  return check_lobe_shape(grid, lift, g);
}

Status check_lobe_shape(const std::vector<double>& grid, const std::vector<PeriodicSpline::Point>& lift,
                        const FollowerGeometry& g) {
  const double rb = g.base_circle_radius_mm;
  const double rr = g.roller_radius_mm;

  std::vector<bool> bad(grid.size(), false);
  bool any = false;
  double lowest_lift = std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < grid.size(); ++i) {
    const double h = lift[i].value;
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
      const double radius = rb + lift[i].value + lift[i].d2;
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
      const double rho = rb + rr + lift[i].value;
      const double kappa = polar_curvature_per_mm(rho, lift[i].d1, lift[i].d2);
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
