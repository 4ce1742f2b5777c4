// Fitting and evaluating the periodic cubic spline.
#include "compensation/periodic_spline.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <Eigen/Core>

#include "compensation/message_text.h"
#include "core/angles.h"

namespace gaugeloop {
namespace {

// Thomas algorithm for a tridiagonal system: sub[i] multiplies x[i-1], sup[i] multiplies
// x[i+1] (sub[0] and sup[n-1] unused). Stable here because every matrix we pass is
// strictly diagonally dominant.
Eigen::VectorXd solve_tridiagonal(const Eigen::VectorXd& sub, const Eigen::VectorXd& diag, const Eigen::VectorXd& sup,
                                  const Eigen::VectorXd& rhs) {
  const Eigen::Index n = diag.size();
  Eigen::VectorXd c_prime(n);
  Eigen::VectorXd x(n);
  c_prime(0) = sup(0) / diag(0);
  x(0) = rhs(0) / diag(0);
  for (Eigen::Index i = 1; i < n; ++i) {
    const double m = diag(i) - sub(i) * c_prime(i - 1);
    c_prime(i) = (i + 1 < n) ? sup(i) / m : 0.0;
    x(i) = (rhs(i) - sub(i) * x(i - 1)) / m;
  }
  for (Eigen::Index i = n - 2; i >= 0; --i) x(i) -= c_prime(i) * x(i + 1);
  return x;
}

}  // namespace

Result<PeriodicSpline> PeriodicSpline::fit(const std::vector<double>& angle_deg, const std::vector<double>& value) {
  if (angle_deg.size() != value.size()) {
    return make_error(ErrorCode::kInvalidInput, "periodic spline: " + std::to_string(angle_deg.size()) +
                                                    " angles but " + std::to_string(value.size()) +
                                                    " values; give one value per angle");
  }
  if (angle_deg.size() < 4) {
    return make_error(ErrorCode::kInvalidInput, "periodic spline: " + std::to_string(angle_deg.size()) +
                                                    " points; a periodic spline needs at least 4 points over the turn");
  }
  for (size_t i = 0; i < angle_deg.size(); ++i) {
    if (!std::isfinite(angle_deg[i]) || !std::isfinite(value[i])) {
      return make_error(ErrorCode::kInvalidInput, "periodic spline: point " + std::to_string(i) +
                                                      " is NaN or infinite; every angle and value must be finite");
    }
    if (angle_deg[i] < 0.0 || angle_deg[i] >= kPeriodDeg) {
      return make_error(ErrorCode::kInvalidInput, "periodic spline: angle " + format_fixed(angle_deg[i], 6) +
                                                      " deg (point " + std::to_string(i) +
                                                      ") is outside [0, 360); give one turn of angles");
    }
    if (i > 0 && !(angle_deg[i] > angle_deg[i - 1])) {
      return make_error(ErrorCode::kInvalidInput, "periodic spline: angle " + format_fixed(angle_deg[i], 6) +
                                                      " deg (point " + std::to_string(i) + ") does not come after " +
                                                      format_fixed(angle_deg[i - 1], 6) +
                                                      " deg; angles must be strictly increasing");
    }
  }
  return PeriodicSpline(angle_deg, value);
}

PeriodicSpline PeriodicSpline::fit(const DegreeTable& value) {
  std::vector<double> x(kDegreesPerRevolution);
  std::vector<double> y(kDegreesPerRevolution);
  for (size_t i = 0; i < x.size(); ++i) {
    x[i] = static_cast<double>(i);
    y[i] = value[i];
  }
  return PeriodicSpline(std::move(x), std::move(y));
}

PeriodicSpline::PeriodicSpline(std::vector<double> knot_deg, std::vector<double> value)
    : knot_deg_(std::move(knot_deg)), a_(std::move(value)) {
  const Eigen::Index n = size();
  // h(i): width of interval i, from knot i to knot i+1 (the last one wraps across 360).
  Eigen::VectorXd h(n);
  for (Eigen::Index i = 0; i + 1 < n; ++i) h(i) = knot_deg_[i + 1] - knot_deg_[i];
  h(n - 1) = knot_deg_[0] + kPeriodDeg - knot_deg_[n - 1];
  auto prev = [n](Eigen::Index i) { return (i + n - 1) % n; };
  auto next = [n](Eigen::Index i) { return (i + 1) % n; };

  // Continuity of s' at every knot, in the knot second derivatives m (per deg^2):
  //   h[i-1] m[i-1] + 2 (h[i-1] + h[i]) m[i] + h[i] m[i+1]
  //     = 6 ((y[i+1] - y[i]) / h[i] - (y[i] - y[i-1]) / h[i-1]),  indices mod n.
  // A cyclic tridiagonal, symmetric and strictly diagonally dominant matrix.
  Eigen::VectorXd sub(n), diag(n), sup(n), rhs(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double hp = h(prev(i));
    sub(i) = hp;
    diag(i) = 2.0 * (hp + h(i));
    sup(i) = h(i);
    rhs(i) = 6.0 * ((a_[next(i)] - a_[i]) / h(i) - (a_[i] - a_[prev(i)]) / hp);
  }
  // Sherman-Morrison: A = B + u v^T where B is tridiagonal, u = (gamma, 0, ..., 0, corner_low),
  // v = (1, 0, ..., 0, corner_high / gamma). gamma = -diag(0) keeps B diagonally dominant.
  const double corner_high = sub(0);     // A(0, n-1)
  const double corner_low = sup(n - 1);  // A(n-1, 0)
  const double gamma = -diag(0);
  Eigen::VectorXd diag_b = diag;
  diag_b(0) -= gamma;
  diag_b(n - 1) -= corner_low * corner_high / gamma;
  Eigen::VectorXd u = Eigen::VectorXd::Zero(n);
  u(0) = gamma;
  u(n - 1) = corner_low;
  const Eigen::VectorXd y = solve_tridiagonal(sub, diag_b, sup, rhs);
  const Eigen::VectorXd z = solve_tridiagonal(sub, diag_b, sup, u);
  const double factor = (y(0) + corner_high * y(n - 1) / gamma) / (1.0 + z(0) + corner_high * z(n - 1) / gamma);
  const Eigen::VectorXd m = y - factor * z;

  bool uniform = true;
  for (Eigen::Index i = 1; i < n && uniform; ++i) uniform = std::abs(h(i) - h(0)) <= 1e-12;
  if (uniform) uniform_step_deg_ = h(0);

  b_.resize(knot_deg_.size());
  c_.resize(knot_deg_.size());
  d_.resize(knot_deg_.size());
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Index j = next(i);
    b_[i] = (a_[j] - a_[i]) / h(i) - h(i) * (2.0 * m(i) + m(j)) / 6.0;
    c_[i] = 0.5 * m(i);
    d_[i] = (m(j) - m(i)) / (6.0 * h(i));
  }
}

void PeriodicSpline::locate(double angle_deg, std::ptrdiff_t& i, double& t) const {
  double a = angle_deg;
  if (!(a >= 0.0 && a < kPeriodDeg)) {
    a = std::fmod(angle_deg, kPeriodDeg);
    if (a < 0.0) a += kPeriodDeg;
    if (a >= kPeriodDeg) a -= kPeriodDeg;  // -1e-17 + 360 rounds to 360
  }
  const Eigen::Index n = size();
  if (a < knot_deg_[0]) {
    // Before the first knot: the wrap interval from the last knot across 360.
    i = n - 1;
    t = a + kPeriodDeg - knot_deg_[n - 1];
    return;
  }
  if (uniform_step_deg_ > 0.0) {
    // k >= 0 here, so truncation is the floor (one instruction; std::floor is a library call
    // without SSE4.1). A NaN angle lands here as i = 0, t = NaN: NaN values, as promised.
    const double k = (a - knot_deg_[0]) / uniform_step_deg_;
    i = (k >= static_cast<double>(n - 1)) ? n - 1 : (k > 0.0 ? static_cast<Eigen::Index>(k) : 0);
    t = a - knot_deg_[i];
    return;
  }
  const double* begin = knot_deg_.data();
  const double* found = std::upper_bound(begin, begin + n, a);
  i = static_cast<Eigen::Index>(found - begin) - 1;
  t = a - knot_deg_[i];
}

double PeriodicSpline::value(double angle_deg) const {
  Eigen::Index i = 0;
  double t = 0.0;
  locate(angle_deg, i, t);
  return a_[i] + t * (b_[i] + t * (c_[i] + t * d_[i]));
}

PeriodicSpline::Piece PeriodicSpline::piece(std::ptrdiff_t i) const {
  const Eigen::Index n = size();
  Piece p;
  p.knot_deg = knot_deg_[i];
  p.width_deg = (i + 1 < n) ? knot_deg_[i + 1] - knot_deg_[i] : knot_deg_[0] + kPeriodDeg - knot_deg_[i];
  p.a = a_[i];
  p.b = b_[i];
  p.c = c_[i];
  p.d = d_[i];
  return p;
}

PeriodicSpline::Point PeriodicSpline::evaluate(double angle_deg) const {
  Eigen::Index i = 0;
  double t = 0.0;
  locate(angle_deg, i, t);
  Point p;
  p.value = a_[i] + t * (b_[i] + t * (c_[i] + t * d_[i]));
  p.d1 = (b_[i] + t * (2.0 * c_[i] + 3.0 * t * d_[i])) * kDegPerRad;
  p.d2 = (2.0 * c_[i] + 6.0 * t * d_[i]) * kDegPerRad * kDegPerRad;
  return p;
}

double PeriodicSpline::d1(double angle_deg) const {
  Eigen::Index i = 0;
  double t = 0.0;
  locate(angle_deg, i, t);
  return (b_[i] + t * (2.0 * c_[i] + 3.0 * t * d_[i])) * kDegPerRad;
}

double PeriodicSpline::d2(double angle_deg) const {
  Eigen::Index i = 0;
  double t = 0.0;
  locate(angle_deg, i, t);
  return (2.0 * c_[i] + 6.0 * t * d_[i]) * kDegPerRad * kDegPerRad;
}

}  // namespace gaugeloop
