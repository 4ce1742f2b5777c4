// What a wheel leaves of a pin: the support function of the wheel centre's orbit in the pin
// frame, less the wheel radius (pin_envelope.h).
#include "compensation/pin_envelope.h"

#include <cmath>
#include <numbers>
#include <string>

#include "compensation/pin_kinematics.h"
#include "core/angles.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

// The wheel centre at every row of the path, relative to the pin's nominal centre, in the pin
// frame (mm).
struct Orbit {
  std::vector<double> u_mm;  // along the crank radius
  std::vector<double> v_mm;  // across it, counter-clockwise
};

Result<Orbit> orbit_of(const PinGeometry& pin, double c_step_deg, const std::vector<double>& x_mm,
                       const std::vector<double>& y_mm) {
  if (Status s = validate(pin); !s) return s.error();
  const double rows = 360.0 / c_step_deg;
  if (!(std::isfinite(rows) && c_step_deg > 0.0 && std::abs(rows - std::round(rows)) < 1e-9 && rows >= 3.0)) {
    return make_error(ErrorCode::kInvalidInput, "pin envelope: the C step " + format_fixed(c_step_deg, 6) +
                                                    " deg must divide 360 into at least 3 rows");
  }
  const auto n = static_cast<size_t>(std::lround(rows));
  if (x_mm.size() != n || y_mm.size() != n) {
    return make_error(ErrorCode::kInvalidInput, "pin envelope: the path has " + std::to_string(x_mm.size()) +
                                                    " X and " + std::to_string(y_mm.size()) + " Y rows; a step of " +
                                                    format_fixed(c_step_deg, 6) + " deg needs " + std::to_string(n) +
                                                    " of each");
  }
  // X = 0 puts the wheel centre at r + rw - R on the machine's X axis (core/pin.h).
  const double x_zero_mm = pin.pin_radius_mm + pin.wheel_radius_mm - pin.throw_mm;
  Orbit orbit;
  orbit.u_mm.resize(n);
  orbit.v_mm.resize(n);
  for (size_t k = 0; k < n; ++k) {
    if (!std::isfinite(x_mm[k]) || !std::isfinite(y_mm[k])) {
      return make_error(ErrorCode::kInvalidInput, "pin envelope: the path is not a number at C " +
                                                      format_fixed(static_cast<double>(k) * c_step_deg, 3) + " deg");
    }
    const double t = crank_angle_deg(pin, static_cast<double>(k) * c_step_deg) * kRadPerDeg;
    const double ct = std::cos(t);
    const double st = std::sin(t);
    // Wheel centre less pin centre in the machine frame, then turned back by t into the pin frame.
    const double wx = x_mm[k] + x_zero_mm - pin.throw_mm * ct;
    const double wy = y_mm[k] - pin.throw_mm * st;
    orbit.u_mm[k] = ct * wx + st * wy;
    orbit.v_mm[k] = -st * wx + ct * wy;
  }
  return orbit;
}

// The orbit's support function in pin-frame direction psi, less rw and r. The largest row is
// refined by the parabola through it and its neighbours: between rows the projection is smooth
// in C, and the rows' own maximum would sit below the true one by up to about
// (r + rw) (1 - cos(step / 2)), 1.2e-4 mm at 0.1 deg.
double radius_error_at(const PinGeometry& pin, const Orbit& orbit, double psi_deg) {
  const double a = psi_deg * kRadPerDeg;
  const double cu = std::cos(a);
  const double su = std::sin(a);
  const size_t n = orbit.u_mm.size();
  auto projection = [&](size_t k) { return orbit.u_mm[k] * cu + orbit.v_mm[k] * su; };
  size_t best = 0;
  double best_mm = projection(0);
  for (size_t k = 1; k < n; ++k) {
    const double p = projection(k);
    if (p > best_mm) {
      best_mm = p;
      best = k;
    }
  }
  const double before = projection((best + n - 1) % n);
  const double after = projection((best + 1) % n);
  const double curvature = before - 2.0 * best_mm + after;
  double peak_mm = best_mm;
  if (curvature < 0.0) peak_mm -= (after - before) * (after - before) / (8.0 * curvature);
  return peak_mm - pin.wheel_radius_mm - pin.pin_radius_mm;
}

}  // namespace

Result<DegreeTable> ground_pin_radius_error_mm(const PinGeometry& pin, double c_step_deg,
                                               const std::vector<double>& x_mm, const std::vector<double>& y_mm) {
  Result<Orbit> orbit = orbit_of(pin, c_step_deg, x_mm, y_mm);
  if (!orbit) return orbit.error();
  DegreeTable error_mm{};
  for (size_t d = 0; d < error_mm.size(); ++d) error_mm[d] = radius_error_at(pin, *orbit, static_cast<double>(d));
  return error_mm;
}

Result<std::vector<double>> ground_pin_radius_error_at_mm(const PinGeometry& pin, double c_step_deg,
                                                          const std::vector<double>& x_mm,
                                                          const std::vector<double>& y_mm,
                                                          const std::vector<double>& psi_deg) {
  Result<Orbit> orbit = orbit_of(pin, c_step_deg, x_mm, y_mm);
  if (!orbit) return orbit.error();
  std::vector<double> error_mm;
  error_mm.reserve(psi_deg.size());
  for (double psi : psi_deg) {
    if (!std::isfinite(psi)) {
      return make_error(ErrorCode::kInvalidInput, "pin envelope: a pin-frame angle is not a finite number of degrees");
    }
    error_mm.push_back(radius_error_at(pin, *orbit, psi));
  }
  return error_mm;
}

}  // namespace gaugeloop
