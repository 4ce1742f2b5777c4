// Crankpin kinematics in closed form (docs/crankpins.md).
#include "compensation/pin_kinematics.h"

#include <cmath>
#include <numbers>
#include <string>

#include "core/angles.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

double wrap_deg(double a) {
  double w = std::fmod(a, 360.0);
  if (w < 0.0) w += 360.0;
  if (w >= 360.0) w -= 360.0;
  return w;
}

Status positive(double value, std::string_view key) {
  if (std::isfinite(value) && value > 0.0) return {};
  return Error{ErrorCode::kInvalidInput,
               "pin: " + std::string(key) + " = " + format_fixed(value, 4) + " must be a positive number of mm"};
}

}  // namespace

Status validate(const PinGeometry& pin) {
  if (Status s = positive(pin.throw_mm, "throw_mm"); !s.ok()) return s;
  if (Status s = positive(pin.pin_radius_mm, "pin_radius_mm"); !s.ok()) return s;
  if (Status s = positive(pin.wheel_radius_mm, "wheel_radius_mm"); !s.ok()) return s;
  if (pin.throw_mm >= pin.pin_radius_mm + pin.wheel_radius_mm) {
    return Error{ErrorCode::kInvalidInput, "pin: throw_mm = " + format_fixed(pin.throw_mm, 4) +
                                               " must be less than pin_radius_mm + wheel_radius_mm = " +
                                               format_fixed(pin.pin_radius_mm + pin.wheel_radius_mm, 4) +
                                               ": the wheel could not reach the pin at every crank angle"};
  }
  if (!std::isfinite(pin.pin_angle_deg) || !std::isfinite(pin.gauge_offset_deg)) {
    return Error{ErrorCode::kInvalidInput, "pin: pin_angle_deg and gauge_offset_deg must be finite numbers of degrees"};
  }
  return {};
}

double crank_angle_deg(const PinGeometry& pin, double c_deg) { return c_deg + pin.pin_angle_deg; }

PinPose design_pin_pose(const PinGeometry& pin, double c_deg) {
  const double t_deg = crank_angle_deg(pin, c_deg);
  const double t = t_deg / kDegPerRad;
  const double big_r = pin.throw_mm;
  const double reach = pin.pin_radius_mm + pin.wheel_radius_mm;
  PinPose pose;
  if (pin.mode == PinMode::kCXY) {
    pose.x_mm = big_r * std::cos(t) + big_r;
    pose.y_mm = big_r * std::sin(t);
    pose.normal_deg = 0.0;
    pose.dpsi_dc = -1.0;
  } else {
    const double s = big_r * std::sin(t) / reach;
    const double phi = -std::asin(s);
    const double cos_phi = std::cos(phi);
    pose.x_mm = big_r * std::cos(t) + reach * cos_phi - (reach - big_r);
    pose.y_mm = 0.0;
    pose.normal_deg = phi * kDegPerRad;
    pose.dpsi_dc = -big_r * std::cos(t) / (reach * cos_phi) - 1.0;
  }
  pose.contact_psi_deg = wrap_deg(pose.normal_deg - t_deg);
  return pose;
}

double gauge_psi_deg(const PinGeometry& pin, double c_deg) {
  return wrap_deg(design_pin_pose(pin, c_deg).contact_psi_deg + pin.gauge_offset_deg);
}

double pin_grinding_point_speed_mm_per_min(const PinGeometry& pin, double c_deg, double speed_rpm) {
  const double dpsi = std::abs(design_pin_pose(pin, c_deg).dpsi_dc);
  return pin.pin_radius_mm * dpsi * 2.0 * std::numbers::pi * std::abs(speed_rpm);
}

}  // namespace gaugeloop
