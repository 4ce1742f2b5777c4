// The pin's wheel path, the split of a normal correction onto the axes, and the pin's speed
// program (pin_path.h; derivation in docs/crankpins.md).
#include "compensation/pin_path.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include "compensation/periodic_spline.h"
#include "compensation/pin_kinematics.h"
#include "core/angles.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

// A curve table's rows must land on whole turns: the step divides 360 to within rounding.
Result<std::size_t> rows_per_turn(double c_step_deg) {
  if (std::isfinite(c_step_deg) && c_step_deg > 0.0 && c_step_deg <= 1.0) {
    const double rows = 360.0 / c_step_deg;
    const double whole = std::round(rows);
    if (std::abs(rows - whole) < 1e-9 * whole) return static_cast<std::size_t>(whole);
  }
  return Error{ErrorCode::kInvalidInput, "pin path: c_step_deg = " + format_fixed(c_step_deg, 6) +
                                             " must be in (0, 1] deg and divide 360 (e.g. 0.01, 0.1, 0.5)"};
}

// The grinding normal's machine angle n(C) and its C-derivatives, in radians per degree of C.
// C-X: n = phi = -asin(R sin t / (r + rw)); C-X-Y: n = 0 throughout.
struct NormalMotion {
  double n_rad = 0.0;
  double dn_dc = 0.0;    // rad/deg
  double d2n_dc2 = 0.0;  // rad/deg^2
};

NormalMotion normal_motion(const PinGeometry& pin, double c_deg) {
  NormalMotion m;
  if (pin.mode == PinMode::kCXY) return m;
  const double t = crank_angle_deg(pin, c_deg) * kRadPerDeg;
  const double s = pin.throw_mm * std::sin(t) / (pin.pin_radius_mm + pin.wheel_radius_mm);   // sin(-phi)
  const double ds = pin.throw_mm * std::cos(t) / (pin.pin_radius_mm + pin.wheel_radius_mm);  // per rad of t
  const double cos_phi = std::sqrt(1.0 - s * s);
  const double phi = -std::asin(s);
  // phi' = -s' / cos phi, phi'' = -(s'' cos phi + s' sin phi phi') / cos^2 phi with s'' = -s.
  const double d1 = -ds / cos_phi;
  const double d2 = (s * cos_phi - ds * std::sin(phi) * d1) / (cos_phi * cos_phi);
  m.n_rad = phi;
  m.dn_dc = d1 * kRadPerDeg;
  m.d2n_dc2 = d2 * kRadPerDeg * kRadPerDeg;
  return m;
}

// The split's weight w(n) = cos(a - n) / S(n), S = sum_j cos^2(a_j - n), of the axis at
// `axis_rad`, and its first two derivatives in n (closed form), for the chain rule.
struct SplitWeight {
  double w = 0.0;
  double dw = 0.0;
  double d2w = 0.0;
};

SplitWeight split_weight(double axis_rad, const std::vector<double>& axes_rad, double n_rad) {
  double sum = 0.0;
  double sum1 = 0.0;
  double sum2 = 0.0;
  for (double a : axes_rad) {
    const double c = std::cos(a - n_rad);
    const double s = std::sin(a - n_rad);
    sum += c * c;
    sum1 += 2.0 * c * s;            // dS/dn
    sum2 += 2.0 * (s * s - c * c);  // d2S/dn2
  }
  const double c = std::cos(axis_rad - n_rad);
  const double s = std::sin(axis_rad - n_rad);
  SplitWeight w;
  w.w = c / sum;
  w.dw = s / sum - c * sum1 / (sum * sum);
  w.d2w = -c / sum - 2.0 * s * sum1 / (sum * sum) - c * sum2 / (sum * sum) + 2.0 * c * sum1 * sum1 / (sum * sum * sum);
  return w;
}

std::vector<double> mode_axes_deg(PinMode mode) {
  return mode == PinMode::kCXY ? std::vector<double>{0.0, 90.0} : std::vector<double>{0.0};
}

}  // namespace

Result<PinPath> compute_pin_path(const PinGeometry& pin, double c_step_deg) {
  if (Status s = validate(pin); !s.ok()) return s.error();
  Result<std::size_t> rows = rows_per_turn(c_step_deg);
  if (!rows) return rows.error();
  const std::size_t n = *rows;
  PinPath path;
  path.c_step_deg = c_step_deg;
  for (std::vector<double>* v :
       {&path.x_mm, &path.dx_dc_mm_per_deg, &path.d2x_dc2_mm_per_deg2, &path.y_mm, &path.dy_dc_mm_per_deg,
        &path.d2y_dc2_mm_per_deg2, &path.contact_psi_deg, &path.normal_deg}) {
    v->assign(n, 0.0);
  }
  const double big_r = pin.throw_mm;
  const double reach = pin.pin_radius_mm + pin.wheel_radius_mm;
  const double k1 = kRadPerDeg;
  const double k2 = kRadPerDeg * kRadPerDeg;
  for (std::size_t k = 0; k < n; ++k) {
    const double c_deg = path.c_deg(k);
    const PinPose pose = design_pin_pose(pin, c_deg);
    path.x_mm[k] = pose.x_mm;
    path.y_mm[k] = pose.y_mm;
    path.contact_psi_deg[k] = pose.contact_psi_deg;
    path.normal_deg[k] = pose.normal_deg;
    const double t = crank_angle_deg(pin, c_deg) * kRadPerDeg;
    const double sin_t = std::sin(t);
    const double cos_t = std::cos(t);
    if (pin.mode == PinMode::kCXY) {
      path.dx_dc_mm_per_deg[k] = -big_r * sin_t * k1;
      path.d2x_dc2_mm_per_deg2[k] = -big_r * cos_t * k2;
      path.dy_dc_mm_per_deg[k] = big_r * cos_t * k1;
      path.d2y_dc2_mm_per_deg2[k] = -big_r * sin_t * k2;
    } else {
      // X = R cos t + q - (r + rw - R), q = sqrt((r + rw)^2 - R^2 sin^2 t) = (r + rw) cos phi:
      // q' = -R^2 sin t cos t / q, q'' = -R^2 cos 2t / q - R^4 sin^2 t cos^2 t / q^3.
      const double q = std::sqrt(reach * reach - big_r * big_r * sin_t * sin_t);
      const double sc = big_r * big_r * sin_t * cos_t;
      const double dq = -sc / q;
      const double d2q = -big_r * big_r * std::cos(2.0 * t) / q - sc * sc / (q * q * q);
      path.dx_dc_mm_per_deg[k] = (-big_r * sin_t + dq) * k1;
      path.d2x_dc2_mm_per_deg2[k] = (-big_r * cos_t + d2q) * k2;
    }
  }
  return path;
}

Result<std::vector<double>> split_along_direction(double displacement_mm, double direction_deg,
                                                  const std::vector<double>& axis_deg) {
  const double n = direction_deg * kRadPerDeg;
  double sum = 0.0;
  for (double a : axis_deg) sum += std::pow(std::cos(a * kRadPerDeg - n), 2);
  if (!(sum >= 1e-12)) {
    return Error{ErrorCode::kInvalidInput,
                 "normal split: no axis has a component along the direction at " + format_fixed(direction_deg, 4) +
                     " deg; the correction cannot be made by these axes (give an axis not perpendicular to it)"};
  }
  std::vector<double> u(axis_deg.size());
  for (std::size_t k = 0; k < u.size(); ++k) {
    u[k] = displacement_mm * std::cos(axis_deg[k] * kRadPerDeg - n) / sum;
  }
  return u;
}

Result<PinPath> corrected_pin_path(const PinGeometry& pin, const DegreeTable& correction_um, double c_step_deg) {
  Result<PinPath> design = compute_pin_path(pin, c_step_deg);
  if (!design) return design.error();
  for (std::size_t i = 0; i < correction_um.size(); ++i) {
    if (!std::isfinite(correction_um[i])) {
      return Error{ErrorCode::kInvalidInput, "pin correction: the value at pin degree " + std::to_string(i) +
                                                 " is not a finite number of um; measure the pin again"};
    }
  }
  PinPath path = std::move(design).value();
  const PeriodicSpline c_um = PeriodicSpline::fit(correction_um);
  const std::vector<double> axes_deg = mode_axes_deg(pin.mode);
  std::vector<double> axes_rad;
  for (double a : axes_deg) axes_rad.push_back(a * kRadPerDeg);
  std::vector<double>* value[2] = {&path.x_mm, &path.y_mm};
  std::vector<double>* first[2] = {&path.dx_dc_mm_per_deg, &path.dy_dc_mm_per_deg};
  std::vector<double>* second[2] = {&path.d2x_dc2_mm_per_deg2, &path.d2y_dc2_mm_per_deg2};
  for (std::size_t k = 0; k < path.size(); ++k) {
    const NormalMotion nm = normal_motion(pin, path.c_deg(k));
    // The contact point runs at psi' = n' - 1 (deg/deg, n' in deg/deg); psi'' = n''.
    const double dpsi_rad = nm.dn_dc - kRadPerDeg;  // rad of psi per degree of C
    const double d2psi_rad = nm.d2n_dc2;
    const PeriodicSpline::Point c = c_um.evaluate(path.contact_psi_deg[k]);
    // The displacement along the normal, d = -c / 1000 mm, and its C-derivatives.
    const double d0 = -c.value / 1000.0;
    const double d1 = -c.d1 * dpsi_rad / 1000.0;
    const double d2 = -(c.d2 * dpsi_rad * dpsi_rad + c.d1 * d2psi_rad) / 1000.0;
    for (std::size_t a = 0; a < axes_rad.size(); ++a) {
      // u = d w(n): u' = d' w + d w_n n', u'' = d'' w + 2 d' w_n n' + d (w_nn n'^2 + w_n n'').
      const SplitWeight w = split_weight(axes_rad[a], axes_rad, nm.n_rad);
      (*value[a])[k] += d0 * w.w;
      (*first[a])[k] += d1 * w.w + d0 * w.dw * nm.dn_dc;
      (*second[a])[k] += d2 * w.w + 2.0 * d1 * w.dw * nm.dn_dc + d0 * (w.d2w * nm.dn_dc * nm.dn_dc + w.dw * nm.d2n_dc2);
    }
  }
  return path;
}

std::vector<double> pin_grinding_point_speed_mm_per_min(const PinPath& path, const PinGeometry& pin, double speed_rpm) {
  std::vector<double> v(path.size());
  for (std::size_t k = 0; k < v.size(); ++k) {
    v[k] = pin_grinding_point_speed_mm_per_min(pin, path.c_deg(k), speed_rpm);
  }
  return v;
}

Result<WorkSpeedPlan> plan_pin_work_speed(const PinPath& path, const PinGeometry& pin,
                                          const WorkSpeedSettings& settings) {
  if (Status s = validate(pin); !s.ok()) return s.error();
  if (settings.hold != SpeedHold::kLobe) {
    return make_error(ErrorCode::kInvalidInput,
                      "speed program: a pin has no flanks; hold its grinding-point speed all round with "
                      "[speed] lobe_speed_mm_per_min (hold = \"lobe\")");
  }
  const std::size_t n = path.size();
  SpeedPlanRows rows;
  rows.c_step_deg = path.c_step_deg;
  rows.target_mm_per_min.assign(n, settings.lobe_speed_mm_per_min);  // a pin has no base circle: all held
  rows.contact_arc_mm_per_deg.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    // v at 1 rpm is the arc per degree times 360.
    rows.contact_arc_mm_per_deg[k] = pin_grinding_point_speed_mm_per_min(pin, path.c_deg(k), 1.0) / 360.0;
  }
  rows.d_dc_mm_per_deg = {path.dx_dc_mm_per_deg};
  rows.d2_dc2_mm_per_deg2 = {path.d2x_dc2_mm_per_deg2};
  if (pin.mode == PinMode::kCXY) {
    rows.d_dc_mm_per_deg.push_back(path.dy_dc_mm_per_deg);
    rows.d2_dc2_mm_per_deg2.push_back(path.d2y_dc2_mm_per_deg2);
  }
  return plan_work_speed_rows(rows, settings);
}

}  // namespace gaugeloop
