// Support function of a polar curve: convex hull of a dense sampling, refined on the curve.
#include "compensation/polar_support.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <utility>

#include "compensation/cam_geometry.h"
#include "core/angles.h"

namespace gaugeloop {
namespace {

constexpr double kContactToleranceDeg = 1e-10;
// Newton steps the fast path of refine takes before handing over to the safeguarded search.
constexpr int kFastNewtonSteps = 6;

// z component of (b - a) x (c - b): > 0 for a left (counter-clockwise) turn at b.
double turn(double ax, double ay, double bx, double by, double cx, double cy) {
  return (bx - ax) * (cy - by) - (by - ay) * (cx - bx);
}

// An angle in degrees wrapped into [0, 360).
double wrap_turn(double deg) {
  double w = std::fmod(deg, PeriodicSpline::kPeriodDeg);
  if (w < 0.0) w += PeriodicSpline::kPeriodDeg;
  if (w >= PeriodicSpline::kPeriodDeg) w -= PeriodicSpline::kPeriodDeg;  // -1e-17 + 360 rounds to 360
  return w;
}

}  // namespace

PolarSupport::PolarSupport(PeriodicSpline radius_mm, double radius_offset_mm, double max_spacing_deg)
    : radius_mm_(std::move(radius_mm)), offset_mm_(radius_offset_mm) {
  phi_deg_ = dense_angle_grid_deg(radius_mm_, max_spacing_deg);
  const size_t n = phi_deg_.size();
  x_mm_.resize(n);
  y_mm_.resize(n);
  size_t farthest = 0;
  double farthest_r = -1.0;
  for (size_t i = 0; i < n; ++i) {
    const double r = radius(phi_deg_[i]);
    x_mm_[i] = r * std::cos(phi_deg_[i] * kRadPerDeg);
    y_mm_[i] = r * std::sin(phi_deg_[i] * kRadPerDeg);
    if (r > farthest_r) {
      farthest_r = r;
      farthest = i;
    }
  }
  // Graham scan in the grid's angular order about the axis, which lies inside the curve (it
  // is star-shaped about it), starting from the point farthest from the axis (on the hull).
  for (size_t k = 0; k <= n; ++k) {
    const size_t i = (farthest + k) % n;
    while (hull_.size() >= 2) {
      const size_t a = hull_[hull_.size() - 2];
      const size_t b = hull_.back();
      if (turn(x_mm_[a], y_mm_[a], x_mm_[b], y_mm_[b], x_mm_[i], y_mm_[i]) > 0.0) break;
      hull_.pop_back();
    }
    hull_.push_back(i);
  }
  hull_.pop_back();  // the start again
  const size_t m = hull_.size();
  normal_deg_.resize(m);
  for (size_t e = 0; e < m; ++e) {
    const size_t a = hull_[e];
    const size_t b = hull_[(e + 1) % m];
    // Counter-clockwise edge direction (dx, dy): outward normal (dy, -dx).
    double nu = std::atan2(-(x_mm_[b] - x_mm_[a]), y_mm_[b] - y_mm_[a]) * kDegPerRad;
    if (e > 0) {
      while (nu < normal_deg_[e - 1]) nu += 360.0;
    }
    normal_deg_[e] = nu;
  }
}

PolarSupport::Point PolarSupport::refine(double theta_deg, double lo_deg, double hi_deg, double start_deg) const {
  // f(phi) = r cos(d), d = phi - theta; per radian: f' = r' cos d - r sin d,
  // f'' = r'' cos d - 2 r' sin d - r cos d. Maximum where f' falls through 0.
  // Fast path: plain Newton from `start_deg`, which the caller puts within ~1e-3 deg of the
  // contact, so two or three steps converge. A maximum it converges to strictly inside the
  // bracket is the one maximum the bracket holds (see the class comment), the same point the
  // safeguarded search below finds, without its two evaluations at the bracket's ends. If it
  // leaves the bracket, meets f'' >= 0 or has not converged in a few steps, the safeguarded
  // search decides.
  {
    double phi = start_deg;
    for (int iter = 0; iter < kFastNewtonSteps && phi > lo_deg && phi < hi_deg; ++iter) {
      const double d = (phi - theta_deg) * kRadPerDeg;
      const PeriodicSpline::Point rp = radius_mm_.evaluate(phi);
      const double r = offset_mm_ + rp.value;
      const double cd = std::cos(d);
      const double sd = std::sin(d);
      const double f1 = rp.d1 * cd - r * sd;
      const double f2 = rp.d2 * cd - 2.0 * rp.d1 * sd - r * cd;
      if (!(f2 < 0.0)) break;
      const double newton = phi - f1 / f2 * kDegPerRad;
      if (std::abs(newton - phi) < kContactToleranceDeg) {
        if (!(newton > lo_deg && newton < hi_deg)) break;
        // The point at phi carried to the root: f'(phi) ~ 0 there, so the support moves by
        // O(f'' step^2), below 1e-20 mm; the tangential part to first order.
        const double step = (newton - phi) * kRadPerDeg;
        Point p;
        p.support_mm = r * cd + f1 * step;
        p.tangential_mm = r * sd + (rp.d1 * sd + r * cd) * step;
        p.phi_deg = wrap_turn(newton);
        return p;
      }
      phi = newton;
    }
  }
  auto value = [&](double phi) { return radius(phi) * std::cos((phi - theta_deg) * kRadPerDeg); };
  auto slope = [&](double phi) {
    const double d = (phi - theta_deg) * kRadPerDeg;
    const PeriodicSpline::Point r = radius_mm_.evaluate(phi);
    return r.d1 * std::cos(d) - (offset_mm_ + r.value) * std::sin(d);
  };
  double best_phi = lo_deg;
  const double f_lo = slope(lo_deg);
  const double f_hi = slope(hi_deg);
  if (f_lo > 0.0 && f_hi < 0.0) {
    double lo = lo_deg;
    double hi = hi_deg;
    double phi = 0.5 * (lo + hi);
    for (int iter = 0; iter < 100; ++iter) {
      const double d = (phi - theta_deg) * kRadPerDeg;
      const PeriodicSpline::Point rp = radius_mm_.evaluate(phi);
      const double r = offset_mm_ + rp.value;
      const double cd = std::cos(d);
      const double sd = std::sin(d);
      const double f1 = rp.d1 * cd - r * sd;
      const double f2 = rp.d2 * cd - 2.0 * rp.d1 * sd - r * cd;
      if (f1 > 0.0) {
        lo = phi;
      } else {
        hi = phi;
      }
      // Converged: a Newton step below the tolerance is taken even if rounding puts it on
      // the bracket's edge (bisecting from there would wander off for a dozen steps).
      const double newton = (f2 < 0.0) ? phi - f1 / f2 * kDegPerRad : phi;
      if (f2 < 0.0 && std::abs(newton - phi) < kContactToleranceDeg) {
        phi = newton;
        break;
      }
      phi = (newton > lo && newton < hi) ? newton : 0.5 * (lo + hi);
      if (hi - lo < kContactToleranceDeg) break;
    }
    best_phi = phi;
  } else if (!(f_lo > 0.0) && !(f_hi < 0.0)) {
    // f falls then rises: the larger end.
    best_phi = value(lo_deg) >= value(hi_deg) ? lo_deg : hi_deg;
  } else {
    best_phi = (f_lo > 0.0) ? hi_deg : lo_deg;  // monotone: the end it rises to
  }
  return contact_point(theta_deg, best_phi);
}

PolarSupport::Point PolarSupport::contact_point(double theta_deg, double phi_deg) const {
  Point p;
  const double r = radius(phi_deg);
  const double d = (phi_deg - theta_deg) * kRadPerDeg;
  p.support_mm = r * std::cos(d);
  p.tangential_mm = r * std::sin(d);
  p.phi_deg = wrap_turn(phi_deg);
  return p;
}

PolarSupport::Point PolarSupport::at(double theta_deg) const {
  const size_t n = phi_deg_.size();
  const size_t m = hull_.size();
  // theta into [normal[0], normal[0] + 360): the vertex hull_[j] carries the normals between
  // edge j - 1's and edge j's, so the first edge whose normal is >= theta names it.
  double t = std::fmod(theta_deg - normal_deg_[0], 360.0);
  if (t < 0.0) t += 360.0;
  t += normal_deg_[0];
  const size_t j =
      static_cast<size_t>(std::lower_bound(normal_deg_.begin(), normal_deg_.end(), t) - normal_deg_.begin());
  const size_t vertex = j % m;
  Point best;
  bool have = false;
  for (size_t k : {vertex, (vertex + m - 1) % m, (vertex + 1) % m}) {
    const size_t g = hull_[k];
    // A neighbour next to the vertex on the grid brackets nothing the vertex's bracket does
    // not (the maximum lies within one grid step of the best sample); one across a bridge
    // is the other end of a near-tie and is refined.
    if (k != vertex && (g == (hull_[vertex] + 1) % n || hull_[vertex] == (g + 1) % n)) continue;
    // Bracket [phi(g - 1), phi(g + 1)], unwrapped around phi(g).
    const double lo = (g == 0) ? phi_deg_[n - 1] - PeriodicSpline::kPeriodDeg : phi_deg_[g - 1];
    const double hi = (g + 1 == n) ? phi_deg_[0] + PeriodicSpline::kPeriodDeg : phi_deg_[g + 1];
    double start = phi_deg_[g];
    if (k == vertex) {
      // The vertex carries the normals from edge j - 1's to edge j's. An edge between
      // neighbouring samples has, to second order, the normal of the curve at its middle, so
      // the contact runs from the middle of one edge to the middle of the other as theta
      // crosses the vertex's normals; across a bridge it stays at the vertex.
      const double normal_before = (j == 0) ? normal_deg_[m - 1] - 360.0 : normal_deg_[j - 1];
      const double normal_after = (j == m) ? normal_deg_[0] + 360.0 : normal_deg_[j];
      const size_t before = hull_[(vertex + m - 1) % m];
      const size_t after = hull_[(vertex + 1) % m];
      const double from = (g == (before + 1) % n) ? 0.5 * (lo + phi_deg_[g]) : phi_deg_[g];
      const double to = (after == (g + 1) % n) ? 0.5 * (phi_deg_[g] + hi) : phi_deg_[g];
      const double span = normal_after - normal_before;
      const double u = span > 0.0 ? std::clamp((t - normal_before) / span, 0.0, 1.0) : 0.5;
      start = from + u * (to - from);
    }
    const Point p = refine(theta_deg, lo, hi, start);
    if (!have || p.support_mm > best.support_mm) {
      best = p;
      have = true;
    }
  }
  return best;
}

}  // namespace gaugeloop
