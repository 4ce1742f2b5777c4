// Grinding-point speed and the work speed program.
#include "compensation/work_speed.h"
#include "core/angles.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <sstream>
#include <string>

namespace gaugeloop {
namespace {

Status in_range(double value, double lo, double hi, const char* key, const char* unit) {
  if (std::isfinite(value) && value > lo && value <= hi) return {};
  std::ostringstream msg;
  msg << "speed program: " << key << " = " << value << " is outside (" << lo << ", " << hi << "]" << unit
      << "; set it in that range";
  return make_error(ErrorCode::kInvalidInput, msg.str());
}

// Whether the path has one row per step of a grid that divides 360, with its derivatives.
Status check_path(const MachinePath& path, double& step_deg) {
  const size_t n = path.c_deg.size();
  if (n < 4 || path.x_mm.size() != n || path.dx_dc_mm_per_deg.size() != n || path.d2x_dc2_mm_per_deg2.size() != n) {
    return make_error(ErrorCode::kInvalidInput,
                      "speed program: the wheel path needs X, dX/dC and d2X/dC2 at every row (at least 4 rows); "
                      "compute it with compute_machine_path");
  }
  step_deg = 360.0 / static_cast<double>(n);
  if (std::abs(path.c_deg[1] - path.c_deg[0] - step_deg) > 1e-9) {
    return make_error(ErrorCode::kInvalidInput, "speed program: the wheel path's rows are not one uniform turn of C");
  }
  return {};
}

}  // namespace

double contact_arc_mm_per_deg(double x_mm, double dx_mm_per_deg, double d2x_mm_per_deg2, double base_radius_mm,
                              double wheel_radius_mm) {
  const double r = base_radius_mm + wheel_radius_mm + x_mm;
  const double r1 = dx_mm_per_deg * kDegPerRad;
  const double r2 = d2x_mm_per_deg2 * kDegPerRad * kDegPerRad;
  const double q = r * r + r1 * r1;
  const double per_rad = std::sqrt(q) - wheel_radius_mm * (r * r + 2.0 * r1 * r1 - r * r2) / q;
  return per_rad / kDegPerRad;
}

std::vector<double> grinding_point_speed_mm_per_min(const MachinePath& path, const Part& part, double speed_rpm) {
  std::vector<double> v(path.x_mm.size());
  for (size_t k = 0; k < v.size(); ++k) {
    v[k] = grinding_point_speed_mm_per_min(
        contact_arc_mm_per_deg(path.x_mm[k], path.dx_dc_mm_per_deg[k], path.d2x_dc2_mm_per_deg2[k],
                               part.base_circle_radius_mm, part.wheel_radius_mm),
        speed_rpm);
  }
  return v;
}

Result<std::vector<double>> grinding_point_speed_mm_per_min(const MachinePath& path, const Part& part,
                                                            const WorkSpeedProgram& program) {
  double step_deg = 0.0;
  if (Status s = check_path(path, step_deg); !s) return s.error();
  if (program.speed_rpm.size() != path.x_mm.size() || std::abs(program.c_step_deg - step_deg) > 1e-9) {
    return make_error(ErrorCode::kInvalidInput,
                      "speed program: " + std::to_string(program.speed_rpm.size()) + " speeds at " +
                          std::to_string(program.c_step_deg) + " deg do not match the wheel path's " +
                          std::to_string(path.x_mm.size()) + " rows; plan the program on the same C grid");
  }
  std::vector<double> v = grinding_point_speed_mm_per_min(path, part, 1.0);
  for (size_t k = 0; k < v.size(); ++k) v[k] *= std::abs(program.speed_rpm[k]);
  return v;
}

Status validate(const WorkSpeedSettings& s) {
  for (const Status& st :
       {in_range(s.base_speed_rpm, 0.0, 1000.0, "[speed] base_speed_rpm", " rpm"),
        in_range(s.lobe_speed_mm_per_min, 0.0, 1e5, "[speed] lobe_speed_mm_per_min", " mm/min"),
        in_range(s.lobe_threshold_mm, 0.0, 10.0, "[speed] lobe_threshold_mm", " mm"),
        in_range(s.grinding_point_speed_mm_per_min, 0.0, 1e5, "[speed] grinding_point_speed_mm_per_min", " mm/min"),
        in_range(s.flank_speed_mm_per_min, 0.0, 1e5, "[speed] flank_speed_mm_per_min", " mm/min"),
        in_range(s.c_acceleration_max_deg_per_s2, 0.0, 1e7, "[speed] c_acceleration_max_deg_per_s2", " deg/s^2"),
        in_range(s.x_velocity_max_mm_per_s, 0.0, 1e6, "[nc] x_velocity_max_mm_per_s", " mm/s"),
        in_range(s.x_acceleration_max_mm_per_s2, 0.0, 1e8, "[nc] x_acceleration_max_mm_per_s2", " mm/s^2")}) {
    if (!st) return st;
  }
  return {};
}

std::string_view speed_hold_name(SpeedHold hold) {
  switch (hold) {
    case SpeedHold::kLobe:
      return "lobe";
    case SpeedHold::kFlanks:
      return "flanks";
  }
  return "?";
}

double cycle_time_s(const WorkSpeedProgram& program) {
  const size_t n = program.speed_rpm.size();
  double t = 0.0;
  for (size_t k = 0; k < n; ++k) {
    const double w0 = 6.0 * std::abs(program.speed_rpm[k]);
    const double w1 = 6.0 * std::abs(program.speed_rpm[(k + 1) % n]);
    t += program.c_step_deg * 0.5 * (1.0 / w0 + 1.0 / w1);
  }
  return t;
}

Result<WorkSpeedPlan> plan_work_speed_rows(const SpeedPlanRows& rows, const WorkSpeedSettings& s) {
  if (Status st = validate(s); !st) return st.error();
  const size_t n = rows.contact_arc_mm_per_deg.size();
  bool sizes_agree =
      rows.target_mm_per_min.size() == n && rows.d_dc_mm_per_deg.size() == rows.d2_dc2_mm_per_deg2.size();
  for (size_t a = 0; sizes_agree && a < rows.d_dc_mm_per_deg.size(); ++a) {
    sizes_agree = rows.d_dc_mm_per_deg[a].size() == n && rows.d2_dc2_mm_per_deg2[a].size() == n;
  }
  if (n < 4 || !sizes_agree) {
    return make_error(ErrorCode::kInvalidInput,
                      "speed program: the path needs the contact arc and every axis's first and second "
                      "C-derivatives at every row (at least 4 rows); compute the path with its derivatives");
  }
  const double h = rows.c_step_deg;
  if (!(h > 0.0) || std::abs(h * static_cast<double>(n) - 360.0) > 1e-6) {
    return make_error(ErrorCode::kInvalidInput, "speed program: " + std::to_string(n) + " rows at " +
                                                    std::to_string(h) + " deg are not one uniform turn of C");
  }
  const double a_half = 0.5 * s.x_acceleration_max_mm_per_s2;
  const double w_base = 6.0 * s.base_speed_rpm;

  // 1. The ceiling on omega^2, (deg/s)^2.
  std::vector<double> w2(n);
  for (size_t k = 0; k < n; ++k) {
    double cap = w_base * w_base;
    const double arc = rows.contact_arc_mm_per_deg[k];
    const double v_target_mm_per_s = rows.target_mm_per_min[k] / 60.0;
    if (v_target_mm_per_s > 0.0 && arc > 0.0) cap = std::min(cap, std::pow(v_target_mm_per_s / arc, 2));
    for (size_t a = 0; a < rows.d_dc_mm_per_deg.size(); ++a) {
      const double v1 = std::abs(rows.d_dc_mm_per_deg[a][k]);
      if (v1 > 0.0) cap = std::min(cap, std::pow(s.x_velocity_max_mm_per_s / v1, 2));
      const double a2 = std::abs(rows.d2_dc2_mm_per_deg2[a][k]);
      if (a2 > 0.0) cap = std::min(cap, a_half / a2);
    }
    w2[k] = cap;
  }
  // 2. The allowed change of omega^2 from row k to k+1: 2 alpha h, alpha the smaller of the C
  // limit and what the slides' other half allows at either end.
  std::vector<double> step(n);
  auto alpha_at = [&](size_t k) {
    double alpha = s.c_acceleration_max_deg_per_s2;
    for (const std::vector<double>& d1 : rows.d_dc_mm_per_deg) {
      const double v1 = std::abs(d1[k]);
      if (v1 > 0.0) alpha = std::min(alpha, a_half / v1);
    }
    return alpha;
  };
  for (size_t k = 0; k < n; ++k) step[k] = 2.0 * h * std::min(alpha_at(k), alpha_at((k + 1) % n));
  for (int lap = 0; lap < 2; ++lap) {
    for (size_t k = 0; k < n; ++k) {
      const size_t next = (k + 1) % n;
      w2[next] = std::min(w2[next], w2[k] + step[k]);
    }
  }
  for (int lap = 0; lap < 2; ++lap) {
    for (size_t i = n; i-- > 0;) {
      const size_t next = (i + 1) % n;
      w2[i] = std::min(w2[i], w2[next] + step[i]);
    }
  }

  WorkSpeedPlan plan;
  plan.program.c_step_deg = h;
  plan.program.speed_rpm.resize(n);
  plan.grinding_point_speed_mm_per_min.resize(n);
  plan.constant_grinding_point_speed_mm_per_min.resize(n);
  for (size_t k = 0; k < n; ++k) {
    plan.program.speed_rpm[k] = std::sqrt(w2[k]) / 6.0;
    const double v_per_rpm = grinding_point_speed_mm_per_min(rows.contact_arc_mm_per_deg[k], 1.0);
    plan.grinding_point_speed_mm_per_min[k] = v_per_rpm * std::abs(plan.program.speed_rpm[k]);
    plan.constant_grinding_point_speed_mm_per_min[k] =
        grinding_point_speed_mm_per_min(rows.contact_arc_mm_per_deg[k], s.base_speed_rpm);
  }
  plan.cycle_time_s = cycle_time_s(plan.program);
  plan.constant_cycle_time_s = 60.0 / s.base_speed_rpm;
  for (size_t k = 0; k < n; ++k) {
    const double half_dw2_dc = (w2[(k + 1) % n] - w2[(k + n - 1) % n]) / (4.0 * h);  // omega d(omega)/dC
    plan.largest_c_acceleration_deg_per_s2 = std::max(plan.largest_c_acceleration_deg_per_s2, std::abs(half_dw2_dc));
    for (size_t a = 0; a < rows.d_dc_mm_per_deg.size(); ++a) {
      const double d1 = rows.d_dc_mm_per_deg[a][k];
      const double d2 = rows.d2_dc2_mm_per_deg2[a][k];
      plan.largest_x_velocity_mm_per_s = std::max(plan.largest_x_velocity_mm_per_s, std::abs(d1) * std::sqrt(w2[k]));
      plan.largest_x_acceleration_mm_per_s2 =
          std::max(plan.largest_x_acceleration_mm_per_s2, std::abs(d2 * w2[k] + d1 * half_dw2_dc));
    }
  }
  return plan;
}

Result<WorkSpeedPlan> plan_work_speed(const MachinePath& path, const Part& part, const WorkSpeedSettings& s) {
  // The settings first (the row planner checks them again): a bad key is named before a bad path.
  if (Status st = validate(s); !st) return st.error();
  double h = 0.0;
  if (Status st = check_path(path, h); !st) return st.error();
  const size_t n = path.x_mm.size();
  SpeedPlanRows rows;
  rows.c_step_deg = h;
  rows.contact_arc_mm_per_deg.resize(n);
  rows.target_mm_per_min.resize(n);
  const double x_max = *std::max_element(path.x_mm.begin(), path.x_mm.end());
  for (size_t k = 0; k < n; ++k) {
    rows.contact_arc_mm_per_deg[k] =
        contact_arc_mm_per_deg(path.x_mm[k], path.dx_dc_mm_per_deg[k], path.d2x_dc2_mm_per_deg2[k],
                               part.base_circle_radius_mm, part.wheel_radius_mm);
    switch (s.hold) {
      case SpeedHold::kLobe:
        rows.target_mm_per_min[k] = path.x_mm[k] > s.lobe_threshold_mm ? s.lobe_speed_mm_per_min : 0.0;
        break;
      case SpeedHold::kFlanks:
        rows.target_mm_per_min[k] =
            is_flank_row(path.x_mm[k], x_max) ? s.flank_speed_mm_per_min : s.grinding_point_speed_mm_per_min;
        break;
    }
  }
  rows.d_dc_mm_per_deg = {path.dx_dc_mm_per_deg};
  rows.d2_dc2_mm_per_deg2 = {path.d2x_dc2_mm_per_deg2};
  return plan_work_speed_rows(rows, s);
}

}  // namespace gaugeloop
