// Axis-limit guards on the wheel path and on the table.
#include "nc_out/table_guards.h"
#include "core/number_text.h"

#include <cmath>
#include <cstdio>
#include <string>

namespace gaugeloop {
namespace {

std::string at_c(double c_deg) { return "at C" + format_fixed(c_deg, 3); }

// The axis letter and the prefix of its limits' keys: "X" and "x_", "Y" and "y_".
std::string axis_key(const AxisLimits& l, const char* rest) {
  std::string key(1, static_cast<char>(l.axis == 'Y' ? 'y' : 'x'));
  return key + rest;
}

// What a guard checks, at one C: value and the velocity/acceleration per degree.
struct Row {
  double c_deg;
  double x_mm;
  double dx_dc;
  double d2x_dc2;
};

Status check_row(const char* what, const Row& r, const AxisLimits& l, bool check_acceleration) {
  const double w = 6.0 * std::abs(l.speed_rpm);  // deg/s
  if (!std::isfinite(r.x_mm) || !std::isfinite(r.dx_dc) || !std::isfinite(r.d2x_dc2)) {
    return make_error(ErrorCode::kRefused, std::string(what) + " has NaN or infinity " + at_c(r.c_deg) +
                                               "; the wheel path is broken: check the lift table and the "
                                               "correction; nothing was written");
  }
  if (r.x_mm < l.x_min_mm || r.x_mm > l.x_max_mm) {
    const bool low = r.x_mm < l.x_min_mm;
    return make_error(ErrorCode::kRefused,
                      std::string(what) + " " + l.axis + " " + format_fixed(r.x_mm, 4) + " mm " + at_c(r.c_deg) +
                          " is " +
                          (low ? "below the axis limit " + axis_key(l, "_min_mm ") + format_fixed(l.x_min_mm, 4)
                               : "above the axis limit " + axis_key(l, "_max_mm ") + format_fixed(l.x_max_mm, 4)) +
                          " mm; check the part geometry and the correction, or the configured axis limits; "
                          "nothing was written");
  }
  const double v = r.dx_dc * w;
  if (std::abs(v) > l.x_velocity_max_mm_per_s) {
    // Velocity grows with the speed: this speed would just fit.
    const double fits_rpm = std::abs(l.speed_rpm) * l.x_velocity_max_mm_per_s / std::abs(v);
    return make_error(ErrorCode::kRefused,
                      std::string(what) + " " + l.axis + " velocity " + format_fixed(std::abs(v), 2) + " mm/s " +
                          at_c(r.c_deg) + " exceeds the limit " + format_fixed(l.x_velocity_max_mm_per_s, 2) +
                          " mm/s at " + format_fixed(std::abs(l.speed_rpm), 2) + " rpm; grind at most " +
                          format_fixed(fits_rpm, 2) + " rpm; nothing was written");
  }
  const double a = r.d2x_dc2 * w * w;
  if (check_acceleration && std::abs(a) > l.x_acceleration_max_mm_per_s2) {
    // Acceleration grows with the square of the speed.
    const double fits_rpm = std::abs(l.speed_rpm) * std::sqrt(l.x_acceleration_max_mm_per_s2 / std::abs(a));
    return make_error(ErrorCode::kRefused,
                      std::string(what) + " " + l.axis + " acceleration " + format_fixed(std::abs(a), 1) + " mm/s^2 " +
                          at_c(r.c_deg) + " exceeds the limit " + format_fixed(l.x_acceleration_max_mm_per_s2, 1) +
                          " mm/s^2 at " + format_fixed(std::abs(l.speed_rpm), 2) + " rpm; grind at most " +
                          format_fixed(fits_rpm, 2) + " rpm; nothing was written");
  }
  return {};
}

}  // namespace

Status check_axis_limits(const AxisLimits& l) {
  auto bad = [](const std::string& m) { return make_error(ErrorCode::kInvalidInput, m); };
  if (!std::isfinite(l.x_min_mm) || !std::isfinite(l.x_max_mm) || !(l.x_min_mm < l.x_max_mm)) {
    return bad("axis limits x_min_mm " + format_fixed(l.x_min_mm, 4) + " and x_max_mm " + format_fixed(l.x_max_mm, 4) +
               " must be finite with x_min_mm < x_max_mm");
  }
  if (!(l.x_velocity_max_mm_per_s > 0.0) || !std::isfinite(l.x_velocity_max_mm_per_s)) {
    return bad("x_velocity_max_mm_per_s must be a positive number");
  }
  if (!(l.x_acceleration_max_mm_per_s2 > 0.0) || !std::isfinite(l.x_acceleration_max_mm_per_s2)) {
    return bad("x_acceleration_max_mm_per_s2 must be a positive number");
  }
  if (!std::isfinite(l.speed_rpm) || l.speed_rpm == 0.0) {
    return bad("speed_rpm (the programmed work speed) must be a non-zero number");
  }
  return {};
}

Status check_path_guards(const SampledPath& path, const AxisLimits& limits) {
  if (Status s = check_sampled_path_shape(path); !s) return s;
  if (Status s = check_axis_limits(limits); !s) return s;
  for (std::size_t k = 0; k < path.size(); ++k) {
    const Row r{path.c_deg(k), path.x_mm[k], path.dx_dc_mm_per_deg[k], path.d2x_dc2_mm_per_deg2[k]};
    if (Status s = check_row("wheel path", r, limits, true); !s) return s;
  }
  return {};
}

Status check_table_guards(const CurveTable& table, const SampledPath& path, const AxisLimits& limits) {
  if (Status s = check_sampled_path_shape(path); !s) return s;
  if (Status s = check_axis_limits(limits); !s) return s;
  for (const CurvePoint& p : table.points) {
    if (Status s = check_row("curve table point", {p.c_deg, p.x_mm, 0.0, 0.0}, limits, false); !s) return s;
  }
  if (Status s = validate_curve_points(table.points); !s) return s;
  Result<TableInterpolant> nc = TableInterpolant::of(table.points, table.interpolation);
  if (!nc) return nc.error();
  const bool spline = table.interpolation != Interpolation::kLinear;  // a smooth table: its X' and X'' count
  std::size_t segment = 0;
  for (std::size_t k = 0; k <= path.size(); ++k) {
    const double c = k == path.size() ? 360.0 : path.c_deg(k);
    const TableInterpolant::Value v = nc->at(c, segment);
    if (Status s = check_row("curve table", {c, v.x_mm, v.dx_dc_mm_per_deg, v.d2x_dc2_mm_per_deg2}, limits, spline);
        !s) {
      return s;
    }
  }
  return {};
}

}  // namespace gaugeloop
