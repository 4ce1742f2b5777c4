// Wheel-centre kinematics for flat, roller and knife-edge followers, and the psi resampling.
#include "compensation/wheel_path.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>

#include "compensation/cam_geometry.h"
#include "compensation/message_text.h"

namespace gaugeloop {
namespace {

constexpr double kDegPerRad = 180.0 / std::numbers::pi;
constexpr double kGridSpacingDeg = 0.05;
constexpr double kPsiToleranceDeg = 1e-10;

// The wheel centre for follower angle beta (cam frame).
struct WheelPoint {
  double psi_deg = 0.0;     // polar angle of the wheel centre, unwrapped: beta + small
  double x_mm = 0.0;        // |W| - rw - rb
  double dpsi_dbeta = 0.0;  // dimensionless; > 0 where the wheel can follow the lobe
  double curvature = 0.0;   // roller: signed curvature of the pitch curve (1/mm)
};

class Kinematics {
 public:
  Kinematics(const PeriodicSpline& lift, const FollowerGeometry& g, double wheel_radius_mm)
      : lift_(lift), g_(g), rw_(wheel_radius_mm) {}

  WheelPoint at(double beta_deg) const {
    const double h = lift_.value(beta_deg);
    const double h1 = lift_.d1(beta_deg);
    const double h2 = lift_.d2(beta_deg);
    const double rb = g_.base_circle_radius_mm;
    WheelPoint w;
    if (g_.kind == FollowerKind::kFlat) {
      // Wheel centre = (p + rw) along the follower direction + H' along the tangent.
      const double a = rb + h + rw_;
      const double w2 = a * a + h1 * h1;
      w.psi_deg = beta_deg + std::atan2(h1, a) * kDegPerRad;
      w.x_mm = std::sqrt(w2) - rw_ - rb;
      // d/dbeta of beta + atan2(H', p + rw) = (p + rw)(p + rw + H'') / |W|^2.
      w.dpsi_dbeta = a * (a + h2) / w2;
      return w;
    }
    // Roller and knife edge: wheel centre W = R + d n, R the pitch curve point, n its outward
    // normal, d = rw - rr. dW/dbeta = (1 + d kappa) |R'| T, and W x T = rho cos(alpha) + d,
    // so dpsi/dbeta = (1 + d kappa)(rho cos(alpha) + d) |R'| / |W|^2.
    const double rr = g_.roller_radius_mm;
    const double rho = rb + rr + h;
    const double d = rw_ - rr;
    const double alpha = std::atan(h1 / rho);
    const double ca = std::cos(alpha);
    const double w2 = rho * rho + d * d + 2.0 * rho * d * ca;
    w.psi_deg = beta_deg - std::atan2(d * std::sin(alpha), rho + d * ca) * kDegPerRad;
    w.x_mm = std::sqrt(w2) - rw_ - rb;
    w.curvature = polar_curvature_per_mm(rho, h1, h2);
    w.dpsi_dbeta = (1.0 + d * w.curvature) * (rho * ca + d) * std::sqrt(rho * rho + h1 * h1) / w2;
    return w;
  }

 private:
  const PeriodicSpline& lift_;
  FollowerGeometry g_;
  double rw_;
};

// Solves psi(beta) = target for beta in [lo, hi], given psi(lo) <= target <= psi(hi) and psi
// increasing there. Newton from the bracket, falling back to bisection when a step leaves it.
double invert_psi(const Kinematics& k, double target_deg, double lo, double hi) {
  double beta = 0.5 * (lo + hi);
  for (int iter = 0; iter < 200; ++iter) {
    const WheelPoint w = k.at(beta);
    const double f = w.psi_deg - target_deg;
    if (std::abs(f) < kPsiToleranceDeg) return beta;
    if (f < 0.0) {
      lo = beta;
    } else {
      hi = beta;
    }
    double next = beta - f / w.dpsi_dbeta;
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (hi - lo < 1e-13) return next;
    beta = next;
  }
  return beta;
}

}  // namespace

Result<WheelPath> compute_wheel_path(const PeriodicSpline& lift_mm, const Part& part, double step_deg) {
  if (!std::isfinite(step_deg) || step_deg <= 0.0 || step_deg > 90.0) {
    return make_error(ErrorCode::kInvalidInput,
                      "wheel path: step " + format_fixed(step_deg, 6) +
                          " deg is out of range; give a step in (0, 90] deg that divides 360");
  }
  const double steps_exact = PeriodicSpline::kPeriodDeg / step_deg;
  const double steps_rounded = std::round(steps_exact);
  if (std::abs(steps_exact - steps_rounded) > 1e-9 * steps_rounded || steps_rounded > 3.6e6) {
    return make_error(ErrorCode::kInvalidInput, "wheel path: step " + format_fixed(step_deg, 6) +
                                                    " deg does not divide 360 into a whole number of steps (at most "
                                                    "3600000); use e.g. 1, 0.5, 0.25 or 0.1 deg");
  }
  const int steps = static_cast<int>(steps_rounded);

  Result<FollowerGeometry> geometry = follower_geometry(part);
  if (!geometry.ok()) return geometry.error();
  const FollowerGeometry& g = geometry.value();
  const double rw = part.wheel_radius_mm;
  if (!std::isfinite(rw) || rw <= 0.0) {
    return make_error(ErrorCode::kInvalidInput, "part '" + part.name + "': wheel radius " + format_fixed(rw, 3) +
                                                    " mm is not a positive number; set wheel_radius_mm");
  }
  if (Status shape = check_lobe_shape(lift_mm, g); !shape.ok()) return shape.error();

  const Kinematics kin(lift_mm, g, rw);
  const std::vector<double> grid = dense_angle_grid_deg(lift_mm, kGridSpacingDeg);
  const size_t n = grid.size();
  // Samples 0..n-1 over one turn, plus sample n = sample 0 one turn later (psi + 360).
  std::vector<double> beta(n + 1);
  std::vector<double> psi(n + 1);
  std::vector<bool> stalls(n, false);
  bool any_stall = false;
  for (size_t i = 0; i < n; ++i) {
    const WheelPoint w = kin.at(grid[i]);
    beta[i] = grid[i];
    psi[i] = w.psi_deg;
    if (!(w.dpsi_dbeta > 0.0)) stalls[i] = any_stall = true;
  }
  beta[n] = beta[0] + PeriodicSpline::kPeriodDeg;
  psi[n] = psi[0] + PeriodicSpline::kPeriodDeg;
  for (size_t i = 0; i < n; ++i) {
    if (!(psi[i + 1] > psi[i])) stalls[i] = stalls[(i + 1) % n] = any_stall = true;
  }
  if (any_stall) {
    // The largest wheel that fits: the smallest radius of curvature of any concave part of the
    // cam surface. For a roller the cam surface is the pitch curve offset inward by rr, so a
    // concave pitch radius 1/|kappa| becomes 1/|kappa| + rr on the surface.
    double largest_fit = std::numeric_limits<double>::infinity();
    if (g.kind != FollowerKind::kFlat) {
      for (size_t i = 0; i < n; ++i) {
        const double kappa = kin.at(grid[i]).curvature;
        if (kappa < 0.0) largest_fit = std::min(largest_fit, 1.0 / -kappa + g.roller_radius_mm);
      }
    }
    std::string message = "wheel radius " + format_fixed(rw, 3) + " mm cannot grind the lobe of part '" + part.name +
                          "': the wheel angle psi stops increasing at cam angle " +
                          describe_angle_ranges(grid, stalls) + ", a concave flank tighter than the wheel";
    if (std::isfinite(largest_fit)) {
      message += "; the largest wheel that fits has a radius below " + format_fixed(largest_fit, 2) +
                 " mm (the smallest concave radius of curvature of the cam surface)";
    }
    message += "; use a smaller wheel or check the lift table";
    return make_error(ErrorCode::kRefused, message);
  }

  WheelPath path;
  path.psi_deg.resize(static_cast<size_t>(steps));
  path.x_mm.resize(static_cast<size_t>(steps));
  for (int k = 0; k < steps; ++k) {
    const double psi_k = PeriodicSpline::kPeriodDeg * k / steps;
    // The same wheel angle, shifted by whole turns into [psi[0], psi[0] + 360).
    double target = psi_k - PeriodicSpline::kPeriodDeg * std::floor((psi_k - psi[0]) / PeriodicSpline::kPeriodDeg);
    if (target >= psi[n]) target -= PeriodicSpline::kPeriodDeg;
    const size_t j = static_cast<size_t>(std::upper_bound(psi.begin(), psi.end(), target) - psi.begin());
    const size_t lo = (j == 0) ? 0 : std::min(j - 1, n - 1);
    const double b = invert_psi(kin, target, beta[lo], beta[lo + 1]);
    path.psi_deg[static_cast<size_t>(k)] = psi_k;
    path.x_mm[static_cast<size_t>(k)] = kin.at(b).x_mm;
  }
  return path;
}

}  // namespace gaugeloop
