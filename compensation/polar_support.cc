// Dense-sample-then-refine maximisation for the support function of a polar curve.
#include "compensation/polar_support.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "compensation/cam_geometry.h"

namespace gaugeloop {
namespace {

constexpr double kRadPerDeg = std::numbers::pi / 180.0;

// Local sample maxima within this much of the best sample are refined: sampling at 0.05 deg
// (8.7e-4 rad) under-reads a smooth maximum by about r * dphi^2 / 2, 3.8e-4 mm for r = 1 m,
// so every candidate for the global maximum is kept.
constexpr double kCandidateMarginMm = 1e-3;

}  // namespace

PolarSupport::PolarSupport(PeriodicSpline radius_mm, double radius_offset_mm, double max_spacing_deg)
    : radius_mm_(std::move(radius_mm)), offset_mm_(radius_offset_mm) {
  phi_deg_ = dense_angle_grid_deg(radius_mm_, max_spacing_deg);
  x_mm_.resize(phi_deg_.size());
  y_mm_.resize(phi_deg_.size());
  for (size_t i = 0; i < phi_deg_.size(); ++i) {
    const double r = radius(phi_deg_[i]);
    x_mm_[i] = r * std::cos(phi_deg_[i] * kRadPerDeg);
    y_mm_[i] = r * std::sin(phi_deg_[i] * kRadPerDeg);
  }
}

PolarSupport::Point PolarSupport::at(double theta_deg) const {
  const double c = std::cos(theta_deg * kRadPerDeg);
  const double s = std::sin(theta_deg * kRadPerDeg);
  const size_t n = phi_deg_.size();
  std::vector<double> f(n);
  double best = -std::numeric_limits<double>::infinity();
  for (size_t i = 0; i < n; ++i) {
    f[i] = x_mm_[i] * c + y_mm_[i] * s;
    best = std::max(best, f[i]);
  }
  auto objective = [&](double phi) { return radius(phi) * std::cos((phi - theta_deg) * kRadPerDeg); };
  constexpr double kInvPhi = 0.6180339887498949;  // 1 / golden ratio
  Point result{best, 0.0};
  bool have = false;
  for (size_t i = 0; i < n; ++i) {
    const size_t ip = (i + n - 1) % n;
    const size_t in = (i + 1) % n;
    if (f[i] < best - kCandidateMarginMm || f[i] < f[ip] || f[i] < f[in]) continue;
    // Bracket [phi(i-1), phi(i+1)], unwrapped around phi(i).
    double lo = (i == 0) ? phi_deg_[ip] - PeriodicSpline::kPeriodDeg : phi_deg_[ip];
    double hi = (i + 1 == n) ? phi_deg_[in] + PeriodicSpline::kPeriodDeg : phi_deg_[in];
    double x1 = hi - kInvPhi * (hi - lo);
    double x2 = lo + kInvPhi * (hi - lo);
    double f1 = objective(x1);
    double f2 = objective(x2);
    for (int iter = 0; iter < 200 && hi - lo > 1e-10; ++iter) {
      if (f1 < f2) {
        lo = x1;
        x1 = x2;
        f1 = f2;
        x2 = lo + kInvPhi * (hi - lo);
        f2 = objective(x2);
      } else {
        hi = x2;
        x2 = x1;
        f2 = f1;
        x1 = hi - kInvPhi * (hi - lo);
        f1 = objective(x1);
      }
    }
    const double phi = 0.5 * (lo + hi);
    const double value = std::max({objective(phi), f1, f2, f[i]});
    if (!have || value > result.support_mm) {
      have = true;
      result.support_mm = value;
      double w = std::fmod(phi, PeriodicSpline::kPeriodDeg);
      if (w < 0.0) w += PeriodicSpline::kPeriodDeg;
      result.phi_deg = w;
    }
  }
  return result;
}

}  // namespace gaugeloop
