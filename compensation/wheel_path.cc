// Wheel-centre kinematics for flat, roller and knife-edge followers, and the psi and C resampling.
#include "compensation/wheel_path.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <iterator>
#include <limits>
#include <numbers>
#include <string>
#include <vector>

#include "compensation/cam_geometry.h"
#include "compensation/message_text.h"
#include "core/angles.h"

namespace gaugeloop {
namespace {

// A row whose evaluated wheel angle is within this of its target is carried the rest of the
// way by a second-order Taylor step in psi: the error left is X''' dpsi^3 / 6 in X (below
// 1e-20 mm), X''' dpsi^2 / 2 in X' and X''' dpsi in X'' (dpsi < 1.7e-8 rad).
constexpr double kTaylorDeg = 1e-6;
// The psi table rows are bracketed in: cells no wider than this, aligned with the lift's knots.
constexpr double kTableSpacingDeg = 0.5;
// Within a cell (inside one spline piece, where X(psi) is smooth) rows come from a quintic
// through X, X', X'' at the cell's ends, where it matches the kinematics at the cell's middle
// to these (mm, mm/rad, mm/rad^2: below 1e-11 mm, 2e-11 mm/deg, 3e-10 mm/deg^2); elsewhere
// each row is solved for.
constexpr double kQuinticX = 1e-11;
constexpr double kQuinticDx = 1e-9;
constexpr double kQuinticD2x = 1e-6;

// Everything about the wheel at one follower angle beta (cam frame), from one evaluation of
// the lift. Derivatives along psi per radian.
struct WheelState {
  double psi_deg = 0.0;     // polar angle of the wheel centre, unwrapped: beta + small
  double dpsi_dbeta = 0.0;  // dimensionless; > 0 where the wheel can follow the lobe
  double x_mm = 0.0;        // |W| - rw - rb
  double dx = 0.0;          // dX/dpsi, mm/rad
  double d2x = 0.0;         // d2X/dpsi2, mm/rad^2
};

class Kinematics {
 public:
  Kinematics(const PeriodicSpline& lift, const FollowerGeometry& g, double wheel_radius_mm)
      : lift_(lift), g_(g), rw_(wheel_radius_mm) {}

  WheelState at(double beta_deg) const {
    const PeriodicSpline::Point lift = lift_.evaluate(beta_deg);
    const double h = lift.value;
    const double h1 = lift.d1;
    const double h2 = lift.d2;
    const double rb = g_.base_circle_radius_mm;
    WheelState w;
    // The wheel-centre curve W(beta) in polar form r(psi). Its tangent T is the lobe's (the
    // flat follower's face, the roller's pitch curve), so dr/dpsi = r (W.T) / (W x T) needs
    // only H and H'. Its curvature is that of the lobe curve offset outward by the wheel:
    // flat 1 / (rb + H + H'' + rw); roller kappa / (1 + d kappa), kappa the pitch curve's.
    // The polar curvature kappa_W = (r^2 + 2 r'^2 - r r'') / (r^2 + r'^2)^(3/2) then gives r''.
    double r = 0.0;
    double kappa_w = 0.0;
    if (g_.kind == FollowerKind::kFlat) {
      // W = a u + H' t, a = p + rw with p = rb + H the support function; T = t, so W.T = H',
      // W x T = a. psi = beta + atan2(H', a), a > 0; its derivative a (a + H'') / |W|^2.
      const double a = rb + h + rw_;
      const double w2 = a * a + h1 * h1;
      r = std::sqrt(w2);
      w.psi_deg = beta_deg + std::atan(h1 / a) * kDegPerRad;
      w.dpsi_dbeta = a * (a + h2) / w2;
      w.dx = r * h1 / a;
      kappa_w = 1.0 / (a + h2);
    } else {
      // Roller and knife edge: W = R + d n, R the pitch curve point (rho = rb + rr + H), n its
      // outward normal, d = rw - rr; alpha the pressure angle, cos = rho / |R'|. W.T = rho sin,
      // W x T = rho cos + d; dW/dbeta = (1 + d kappa) |R'| T, so dpsi/dbeta =
      // (1 + d kappa)(rho cos + d) |R'| / |W|^2.
      const double rr = g_.roller_radius_mm;
      const double rho = rb + rr + h;
      const double d = rw_ - rr;
      const double length = std::sqrt(rho * rho + h1 * h1);  // |R'|
      const double ca = rho / length;
      const double sa = h1 / length;
      const double w2 = rho * rho + d * d + 2.0 * rho * d * ca;
      r = std::sqrt(w2);
      w.psi_deg = beta_deg - std::atan2(d * sa, rho + d * ca) * kDegPerRad;
      const double kappa = polar_curvature_per_mm(rho, h1, h2);
      w.dpsi_dbeta = (1.0 + d * kappa) * (rho * ca + d) * length / w2;
      w.dx = r * rho * sa / (rho * ca + d);
      kappa_w = kappa / (1.0 + d * kappa);
    }
    const double q = r * r + w.dx * w.dx;
    w.x_mm = r - rw_ - rb;
    w.d2x = (r * r + 2.0 * w.dx * w.dx - kappa_w * q * std::sqrt(q)) / r;
    return w;
  }

  // The dense checks of a roller lobe, without roots or divisions. The pitch curve's
  // curvature is kappa = num / q^(3/2), num = rho^2 + 2 rho'^2 - rho rho'', q = rho^2 + rho'^2.
  //  - undercut: convex with radius <= rr, kappa >= 1 / rr: num > 0 and (rr num)^2 >= q^3;
  //  - the wheel moves on (dpsi/dbeta > 0): rho cos(alpha) + d > 0 always (it is rb + rw or
  //    more), so it is 1 + d kappa > 0: d num >= 0, or (d num)^2 < q^3.
  struct RollerCheck {
    bool undercut = false;
    bool moves = true;
  };
  RollerCheck roller_check(const PeriodicSpline::Point& lift) const {
    const double rr = g_.roller_radius_mm;
    const double rho = g_.base_circle_radius_mm + rr + lift.value;
    const double q = rho * rho + lift.d1 * lift.d1;
    const double num = rho * rho + 2.0 * lift.d1 * lift.d1 - rho * lift.d2;
    const double q3 = q * q * q;
    const double dn = (rw_ - rr) * num;
    RollerCheck c;
    c.undercut = num > 0.0 && (rr * num) * (rr * num) >= q3;
    c.moves = dn >= 0.0 || dn * dn < q3;
    return c;
  }

  // Whether roller_check passes, and rb + H > 0, everywhere on a spline piece, from bounds of
  // H, H' and H'' over it (false: it may not; sample it). With rho >= rho_lo > 0,
  // q^(3/2) >= rho_lo^3, so no undercut if rr num < rho_lo^3 throughout, and the wheel moves on
  // if |d| num < rho_lo^3 where d num < 0; num = rho^2 + 2 H'^2 - rho H'' is bounded from the
  // ranges of rho and H'' (bilinear: at their corners). A margin of 1e-9 keeps rounding on
  // the safe side.
  bool roller_piece_is_clear(const PeriodicSpline::Piece& p) const {
    constexpr double k1 = kDegPerRad;
    constexpr double k2 = kDegPerRad * kDegPerRad;
    const double w = p.width_deg;
    const double rr = g_.roller_radius_mm;
    const double rb = g_.base_circle_radius_mm;
    const double spread_h = (std::abs(p.b) + (std::abs(p.c) + std::abs(p.d) * w) * w) * w;
    if (!(rb + p.a - spread_h > 0.0)) return false;
    const double rho_lo = rb + rr + p.a - spread_h;
    const double rho_hi = rb + rr + p.a + spread_h;
    const double h1_max = (std::abs(p.b) + (2.0 * std::abs(p.c) + 3.0 * std::abs(p.d) * w) * w) * k1;
    const double h2_a = 2.0 * p.c * k2;
    const double h2_b = (2.0 * p.c + 6.0 * p.d * w) * k2;
    const double corners[] = {-rho_lo * h2_a, -rho_lo * h2_b, -rho_hi * h2_a, -rho_hi * h2_b};
    const double cross_lo = *std::min_element(std::begin(corners), std::end(corners));
    const double cross_hi = *std::max_element(std::begin(corners), std::end(corners));
    const double num_lo = rho_lo * rho_lo + cross_lo;
    const double num_hi = rho_hi * rho_hi + 2.0 * h1_max * h1_max + cross_hi;
    const double limit = rho_lo * rho_lo * rho_lo * (1.0 - 1e-9);
    if (!(rr * num_hi < limit)) return false;
    const double d = rw_ - rr;
    const double against = d >= 0.0 ? -num_lo : num_hi;  // num of the sign that stalls
    return std::abs(d) * against < limit;
  }

 private:
  const PeriodicSpline& lift_;
  FollowerGeometry g_;
  double rw_;
};

// One row of a path: X and its derivatives per degree of psi.
struct PathRow {
  double x_mm = 0.0;
  double dx_per_deg = 0.0;
  double d2x_per_deg2 = 0.0;
};

// The refusal for a wheel too large for a concave flank: psi(beta) stops increasing where
// `stalls` is set on `grid`. `curvature`: the pitch curve's there (roller), or empty.
Error stall_error(const Part& part, double rw, const FollowerGeometry& g, const std::vector<double>& grid,
                  const std::vector<bool>& stalls, const std::vector<double>& curvature) {
  // The largest wheel that fits: the smallest radius of curvature of any concave part of the
  // cam surface. For a roller the cam surface is the pitch curve offset inward by rr, so a
  // concave pitch radius 1/|kappa| becomes 1/|kappa| + rr on the surface.
  double largest_fit = std::numeric_limits<double>::infinity();
  for (double kappa : curvature) {
    if (kappa < 0.0) largest_fit = std::min(largest_fit, 1.0 / -kappa + g.roller_radius_mm);
  }
  std::string message = "wheel radius " + format_fixed(rw, 3) + " mm cannot grind the lobe of part '" + part.name +
                        "': the wheel angle psi stops increasing at cam angle " + describe_angle_ranges(grid, stalls) +
                        ", a concave flank tighter than the wheel";
  if (std::isfinite(largest_fit)) {
    message += "; the largest wheel that fits has a radius below " + format_fixed(largest_fit, 2) +
               " mm (the smallest concave radius of curvature of the cam surface)";
  }
  message += "; use a smaller wheel or check the lift table";
  return make_error(ErrorCode::kRefused, message);
}

// The kinematics of one lobe, checked, with psi(beta) tabulated over one turn for bracketing.
// Invariant: psi_ is strictly increasing, dpsi_ > 0, and psi_[n] = psi_[0] + 360 (beta_ likewise).
class PathSampler {
 public:
  static Result<PathSampler> make(const PeriodicSpline& lift_mm, const Part& part);

  // X and its derivatives per degree at wheel angle psi (any value, wrapped to one turn).
  // `hint`: the cell of the previous call; rows asked for in order find theirs in a step.
  PathRow at_psi(double psi_deg, size_t& hint) const {
    // The same wheel angle, shifted by whole turns into [psi[0], psi[0] + 360).
    const size_t n = beta_.size() - 1;
    double target = psi_deg - PeriodicSpline::kPeriodDeg * std::floor((psi_deg - psi_[0]) / PeriodicSpline::kPeriodDeg);
    if (target >= psi_[n]) target -= PeriodicSpline::kPeriodDeg;
    size_t lo = std::min(hint, n - 1);
    for (int walk = 0; walk < 8 && target < psi_[lo] && lo > 0; ++walk) --lo;
    for (int walk = 0; walk < 8 && target >= psi_[lo + 1] && lo + 1 < n; ++walk) ++lo;
    if (!(psi_[lo] <= target && target < psi_[lo + 1])) {
      const size_t j = static_cast<size_t>(std::upper_bound(psi_.begin(), psi_.end(), target) - psi_.begin());
      lo = (j == 0) ? 0 : std::min(j - 1, n - 1);
    }
    hint = lo;
    if (quintic_ok_[lo]) {
      // The cell's verified quintic in s = (psi - psi_lo) / span (span in rad).
      const double* c = &quintic_[6 * lo];
      const double sp = (target - psi_[lo]) / (psi_[lo + 1] - psi_[lo]);
      const double width = (psi_[lo + 1] - psi_[lo]) * kRadPerDeg;
      PathRow row;
      row.x_mm = c[0] + sp * (c[1] + sp * (c[2] + sp * (c[3] + sp * (c[4] + sp * c[5]))));
      const double d1 = c[1] + sp * (2 * c[2] + sp * (3 * c[3] + sp * (4 * c[4] + sp * 5 * c[5])));
      const double d2 = 2 * c[2] + sp * (6 * c[3] + sp * (12 * c[4] + sp * 20 * c[5]));
      row.dx_per_deg = d1 / width * kRadPerDeg;
      row.d2x_per_deg2 = d2 / (width * width) * kRadPerDeg * kRadPerDeg;
      return row;
    }
    // Start from the cubic Hermite inverse of psi(beta) on the cell (values and slopes at
    // both ends). The cell lies within one piece of the lift spline, where psi(beta) is
    // smooth, so the start is within ~h^4 psi'''' / 384 (1e-11 deg for 0.25 deg cells) and
    // the Taylor step below usually finishes the row from the first evaluation.
    const double span = psi_[lo + 1] - psi_[lo];
    const double u = (target - psi_[lo]) / span;
    const double u2 = u * u;
    const double u3 = u2 * u;
    double beta = (2 * u3 - 3 * u2 + 1) * beta_[lo] + (u3 - 2 * u2 + u) * span / dpsi_[lo] +
                  (-2 * u3 + 3 * u2) * beta_[lo + 1] + (u3 - u2) * span / dpsi_[lo + 1];
    double lo_beta = beta_[lo];
    double hi_beta = beta_[lo + 1];
    // (A target on a cell's end, as on the base circle where psi = beta, starts there.)
    if (!(beta >= lo_beta && beta <= hi_beta)) beta = 0.5 * (lo_beta + hi_beta);
    WheelState w = kin_.at(beta);
    for (int iter = 0; iter < 200 && std::abs(w.psi_deg - target) >= kTaylorDeg; ++iter) {
      // Safeguarded Newton on psi(beta) = target within the cell.
      const double f = w.psi_deg - target;
      if (f < 0.0) {
        lo_beta = beta;
      } else {
        hi_beta = beta;
      }
      const double newton = beta - f / w.dpsi_dbeta;
      beta = (newton >= lo_beta && newton <= hi_beta) ? newton : 0.5 * (lo_beta + hi_beta);
      w = kin_.at(beta);
      if (hi_beta - lo_beta < 1e-13) break;
    }
    const double step = (target - w.psi_deg) * kRadPerDeg;
    PathRow row;
    row.x_mm = w.x_mm + step * (w.dx + 0.5 * step * w.d2x);
    row.dx_per_deg = (w.dx + step * w.d2x) * kRadPerDeg;
    row.d2x_per_deg2 = w.d2x * kRadPerDeg * kRadPerDeg;
    return row;
  }

 private:
  PathSampler(const PeriodicSpline& lift_mm, const FollowerGeometry& g, double rw) : kin_(lift_mm, g, rw) {}

  // Fits the quintic of each cell from its ends and keeps it where it matches an exact
  // evaluation at the cell's middle.
  void fit_cells(const std::vector<WheelState>& ends);

  Kinematics kin_;
  std::vector<double> beta_;
  std::vector<double> psi_;
  std::vector<double> dpsi_;  // dpsi/dbeta at each table row
  // Per cell i (rows i to i + 1): X(psi) as c0 + c1 s + ... + c5 s^5, s in [0, 1] across the
  // cell, matching X, X' and X'' at both ends (quintic Hermite), at quintic_[6 i ...]; used
  // for the cell's rows only where quintic_ok_[i].
  std::vector<double> quintic_;
  std::vector<bool> quintic_ok_;
};

void PathSampler::fit_cells(const std::vector<WheelState>& ends) {
  const size_t cells = beta_.size() - 1;
  quintic_.assign(6 * cells, 0.0);
  quintic_ok_.assign(cells, false);
  for (size_t i = 0; i < cells; ++i) {
    const WheelState& a = ends[i];
    const WheelState& b = ends[i + 1];
    const double width = (psi_[i + 1] - psi_[i]) * kRadPerDeg;
    // Ends in s: value, slope (X' width), curvature (X'' width^2).
    const double x0 = a.x_mm;
    const double d0 = a.dx * width;
    const double e0 = a.d2x * width * width;
    const double big_a = b.x_mm - (x0 + d0 + 0.5 * e0);
    const double big_b = b.dx * width - (d0 + e0);
    const double big_c = b.d2x * width * width - e0;
    double* c = &quintic_[6 * i];
    c[0] = x0;
    c[1] = d0;
    c[2] = 0.5 * e0;
    c[3] = 10.0 * big_a - 4.0 * big_b + 0.5 * big_c;
    c[4] = -15.0 * big_a + 7.0 * big_b - big_c;
    c[5] = 6.0 * big_a - 3.0 * big_b + 0.5 * big_c;
    // The interpolation error vanishes to third order at both ends and peaks near the
    // middle: check there against the kinematics themselves.
    const WheelState m = kin_.at(0.5 * (beta_[i] + beta_[i + 1]));
    const double sp = (m.psi_deg - psi_[i]) / (psi_[i + 1] - psi_[i]);
    const double x = c[0] + sp * (c[1] + sp * (c[2] + sp * (c[3] + sp * (c[4] + sp * c[5]))));
    const double d1 = (c[1] + sp * (2 * c[2] + sp * (3 * c[3] + sp * (4 * c[4] + sp * 5 * c[5])))) / width;
    const double d2 = (2 * c[2] + sp * (6 * c[3] + sp * (12 * c[4] + sp * 20 * c[5]))) / (width * width);
    quintic_ok_[i] =
        std::abs(x - m.x_mm) < kQuinticX && std::abs(d1 - m.dx) < kQuinticDx && std::abs(d2 - m.d2x) < kQuinticD2x;
  }
}

Result<PathSampler> PathSampler::make(const PeriodicSpline& lift_mm, const Part& part) {
  Result<FollowerGeometry> geometry = follower_geometry(part);
  if (!geometry.ok()) return geometry.error();
  const FollowerGeometry& g = geometry.value();
  const double rw = part.wheel_radius_mm;
  if (!std::isfinite(rw) || rw <= 0.0) {
    return make_error(ErrorCode::kInvalidInput, "part '" + part.name + "': wheel radius " + format_fixed(rw, 3) +
                                                    " mm is not a positive number; set wheel_radius_mm");
  }
  PathSampler sampler(lift_mm, g, rw);
  const Kinematics& kin = sampler.kin_;

  if (g.kind == FollowerKind::kFlat) {
    // Exact on every spline piece. A convex lobe also keeps psi(beta) increasing:
    // dpsi/dbeta has the sign of rb + H + H'' + rw.
    const FlatLobeMinima m = flat_lobe_minima(lift_mm, g.base_circle_radius_mm);
    if (!(m.support_mm > 0.0 && m.radius_of_curvature_mm > 0.0)) {
      // The sampled check says where; if the fault is narrower than its grid, name the
      // exact place.
      if (Status sampled = check_lobe_shape(lift_mm, g); !sampled.ok()) return sampled.error();
      return make_error(ErrorCode::kRefused,
                        "a flat follower needs a convex lobe, but rb + H + H'' reaches " +
                            format_fixed(m.radius_of_curvature_mm, 4) + " mm at cam angle " +
                            format_fixed(m.radius_at_deg, 2) +
                            " deg; check the lift table, base_circle_radius_mm and the follower kind");
    }
  } else {
    // Sampled, in one pass: the roller's conditions involve the pitch curve's curvature, not a
    // polynomial. The lobe shape first (check_lobe_shape's conditions, which it words), then
    // the wheel.
    // The pass runs piece by piece over the points of dense_angle_grid_deg(lift_mm,
    // kShapeCheckSpacingDeg), evaluating each piece's cubic as PeriodicSpline::evaluate does
    // but without locating the piece 7200 times, and skips a piece whose bounds
    // (roller_piece_is_clear) show no sample of it can fault; only a lobe it faults is
    // sampled again through the grid, for the messages.
    const double rb = g.base_circle_radius_mm;
    bool bad_shape = false;
    bool any_stall = false;
    for (std::ptrdiff_t i = 0; i < lift_mm.size(); ++i) {
      const PeriodicSpline::Piece piece = lift_mm.piece(i);
      if (kin.roller_piece_is_clear(piece)) continue;
      const int pieces = std::max(2, static_cast<int>(std::ceil(piece.width_deg / kShapeCheckSpacingDeg)));
      for (int k = 0; k < pieces; ++k) {
        const double t = (piece.knot_deg + piece.width_deg * k / pieces) - piece.knot_deg;
        PeriodicSpline::Point lift;
        lift.value = piece.a + t * (piece.b + t * (piece.c + t * piece.d));
        lift.d1 = (piece.b + t * (2.0 * piece.c + 3.0 * t * piece.d)) * kDegPerRad;
        lift.d2 = (2.0 * piece.c + 6.0 * t * piece.d) * kDegPerRad * kDegPerRad;
        const Kinematics::RollerCheck c = kin.roller_check(lift);
        if (!(rb + lift.value > 0.0) || c.undercut) bad_shape = true;
        if (!c.moves) any_stall = true;
      }
    }
    const std::vector<double> grid =
        (bad_shape || any_stall) ? dense_angle_grid_deg(lift_mm, kShapeCheckSpacingDeg) : std::vector<double>{};
    std::vector<PeriodicSpline::Point> lift(grid.size());
    for (size_t i = 0; i < grid.size(); ++i) lift[i] = lift_mm.evaluate(grid[i]);
    if (bad_shape) {
      if (Status shape = check_lobe_shape(grid, lift, g); !shape.ok()) return shape.error();
    }
    if (any_stall) {
      std::vector<bool> stalls(grid.size(), false);
      std::vector<double> curvature(grid.size());
      for (size_t i = 0; i < grid.size(); ++i) {
        stalls[i] = !kin.roller_check(lift[i]).moves;
        curvature[i] = polar_curvature_per_mm(g.base_circle_radius_mm + g.roller_radius_mm + lift[i].value, lift[i].d1,
                                              lift[i].d2);
      }
      return stall_error(part, rw, g, grid, stalls, curvature);
    }
  }

  const std::vector<double> grid = dense_angle_grid_deg(lift_mm, kTableSpacingDeg);
  const size_t n = grid.size();
  // Rows 0..n-1 over one turn, plus row n = row 0 one turn later (psi + 360).
  std::vector<double>& beta = sampler.beta_;
  std::vector<double>& psi = sampler.psi_;
  std::vector<double>& dpsi = sampler.dpsi_;
  beta.resize(n + 1);
  psi.resize(n + 1);
  dpsi.resize(n + 1);
  std::vector<bool> stalls(n, false);
  std::vector<WheelState> ends(n + 1);
  bool any_stall = false;
  for (size_t i = 0; i < n; ++i) {
    ends[i] = kin.at(grid[i]);
    beta[i] = grid[i];
    psi[i] = ends[i].psi_deg;
    dpsi[i] = ends[i].dpsi_dbeta;
    if (!(ends[i].dpsi_dbeta > 0.0)) stalls[i] = any_stall = true;
  }
  beta[n] = beta[0] + PeriodicSpline::kPeriodDeg;
  psi[n] = psi[0] + PeriodicSpline::kPeriodDeg;
  dpsi[n] = dpsi[0];
  ends[n] = ends[0];
  for (size_t i = 0; i < n; ++i) {
    if (!(psi[i + 1] > psi[i])) stalls[i] = stalls[(i + 1) % n] = any_stall = true;
  }
  if (any_stall) return stall_error(part, rw, g, grid, stalls, {});
  sampler.fit_cells(ends);
  return sampler;
}

// The number of rows for a step, or an error naming `what` (psi or C).
Result<int> steps_per_turn(double step_deg, const char* what) {
  if (!std::isfinite(step_deg) || step_deg <= 0.0 || step_deg > 90.0) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string("wheel path: ") + what + " step " + format_fixed(step_deg, 6) +
                          " deg is out of range; give a step in (0, 90] deg that divides 360");
  }
  const double steps_exact = PeriodicSpline::kPeriodDeg / step_deg;
  const double steps_rounded = std::round(steps_exact);
  if (std::abs(steps_exact - steps_rounded) > 1e-9 * steps_rounded || steps_rounded > 3.6e6) {
    return make_error(ErrorCode::kInvalidInput, std::string("wheel path: ") + what + " step " +
                                                    format_fixed(step_deg, 6) +
                                                    " deg does not divide 360 into a whole number of steps (at most "
                                                    "3600000); use e.g. 1, 0.5, 0.25 or 0.1 deg");
  }
  return static_cast<int>(steps_rounded);
}

}  // namespace

Result<WheelPath> compute_wheel_path(const PeriodicSpline& lift_mm, const Part& part, double step_deg) {
  Result<int> steps = steps_per_turn(step_deg, "psi");
  if (!steps.ok()) return steps.error();
  Result<PathSampler> sampler = PathSampler::make(lift_mm, part);
  if (!sampler.ok()) return sampler.error();

  const size_t rows = static_cast<size_t>(*steps);
  WheelPath path;
  path.psi_deg.resize(rows);
  path.x_mm.resize(rows);
  path.dx_dpsi_mm_per_deg.resize(rows);
  path.d2x_dpsi2_mm_per_deg2.resize(rows);
  size_t hint = 0;
  for (size_t k = 0; k < rows; ++k) {
    const double psi = PeriodicSpline::kPeriodDeg * static_cast<double>(k) / static_cast<double>(rows);
    const PathRow row = sampler->at_psi(psi, hint);
    path.psi_deg[k] = psi;
    path.x_mm[k] = row.x_mm;
    path.dx_dpsi_mm_per_deg[k] = row.dx_per_deg;
    path.d2x_dpsi2_mm_per_deg2[k] = row.d2x_per_deg2;
  }
  return path;
}

Result<MachinePath> compute_machine_path(const PeriodicSpline& lift_mm, const Part& part, double c_step_deg) {
  Result<int> steps = steps_per_turn(c_step_deg, "C");
  if (!steps.ok()) return steps.error();
  if (part.rotation_sense != 1 && part.rotation_sense != -1) {
    return make_error(ErrorCode::kInvalidInput, "part '" + part.name + "': rotation_sense is " +
                                                    std::to_string(part.rotation_sense) + "; it must be +1 or -1");
  }
  if (!std::isfinite(part.c_offset_deg)) {
    return make_error(ErrorCode::kInvalidInput, "part '" + part.name + "': c_offset_deg must be a finite angle");
  }
  Result<PathSampler> sampler = PathSampler::make(lift_mm, part);
  if (!sampler.ok()) return sampler.error();

  const size_t rows = static_cast<size_t>(*steps);
  const double s = part.rotation_sense;
  MachinePath path;
  path.c_deg.resize(rows);
  path.x_mm.resize(rows);
  path.dx_dc_mm_per_deg.resize(rows);
  path.d2x_dc2_mm_per_deg2.resize(rows);
  size_t hint = 0;
  for (size_t k = 0; k < rows; ++k) {
    const double c = PeriodicSpline::kPeriodDeg * static_cast<double>(k) / static_cast<double>(rows);
    const PathRow row = sampler->at_psi(s * (c - part.c_offset_deg), hint);
    path.c_deg[k] = c;
    path.x_mm[k] = row.x_mm;
    path.dx_dc_mm_per_deg[k] = s * row.dx_per_deg;
    path.d2x_dc2_mm_per_deg2[k] = row.d2x_per_deg2;
  }
  return path;
}

}  // namespace gaugeloop
