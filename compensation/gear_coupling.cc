// Coupling factors of the generating gearbox and the equivalent compensation through SIM1.
#include "compensation/gear_coupling.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/angles.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

Error bad(const std::string& key, double value, const std::string& allowed) {
  const int decimals = std::isfinite(value) && value == std::round(value) ? 0 : 4;
  return make_error(ErrorCode::kInvalidInput, key + " = " + format_fixed(value, decimals) + ": " + allowed);
}

bool in(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

}  // namespace

double worm_lead_angle_deg(const WormWheel& worm, double normal_module_mm) {
  return std::asin(worm.starts * normal_module_mm / worm.pitch_diameter_mm) / kRadPerDeg;
}

Status validate(const GearPart& part) {
  const GearGeometry& g = part.gear;
  const WormWheel& w = part.worm;
  const GearStroke& s = part.stroke;
  if (!in(g.normal_module_mm, 0.1, 50.0)) return bad("[gear] normal_module_mm", g.normal_module_mm, "0.1 to 50 mm");
  if (g.teeth < 5 || g.teeth > 1000) return bad("[gear] teeth", g.teeth, "a whole number from 5 to 1000");
  if (!in(g.pressure_angle_deg, 5.0, 45.0)) {
    return bad("[gear] pressure_angle_deg", g.pressure_angle_deg, "5 to 45 deg (20 for most gears)");
  }
  if (!in(g.helix_angle_deg, 0.0, 60.0)) {
    return bad("[gear] helix_angle_deg", g.helix_angle_deg, "0 (spur) to 60 deg; the hand is given by `hand`");
  }
  if (!in(g.face_width_mm, 0.1, 2000.0)) return bad("[gear] face_width_mm", g.face_width_mm, "0.1 to 2000 mm");
  if (w.starts < 1 || w.starts > 10) return bad("[gear.worm] starts", w.starts, "a whole number from 1 to 10");
  if (!in(w.pitch_diameter_mm, 10.0, 2000.0)) {
    return bad("[gear.worm] pitch_diameter_mm", w.pitch_diameter_mm, "10 to 2000 mm");
  }
  const double sin_lead = w.starts * g.normal_module_mm / w.pitch_diameter_mm;
  if (!(sin_lead <= std::sin(45.0 * kRadPerDeg))) {
    return bad("[gear.worm] pitch_diameter_mm", w.pitch_diameter_mm,
               "too small for " + std::to_string(w.starts) + (w.starts == 1 ? " start" : " starts") + " of module " +
                   format_fixed(g.normal_module_mm, 3) + " mm: the thread would lead more than 45 deg");
  }
  const double lead = worm_lead_angle_deg(w, g.normal_module_mm);
  if (w.lead_angle_deg != 0.0 && !(std::abs(w.lead_angle_deg - lead) <= 0.01)) {
    return bad(
        "[gear.worm] lead_angle_deg", w.lead_angle_deg,
        "disagrees with the " + format_fixed(lead, 4) + " deg that " + std::to_string(w.starts) +
            (w.starts == 1 ? " start" : " starts") + " of module " + format_fixed(g.normal_module_mm, 3) +
            " mm on a pitch diameter of " + format_fixed(w.pitch_diameter_mm, 3) +
            " mm make (sin = starts x module / pitch diameter); correct one of them or leave the lead angle out");
  }
  if (!std::isfinite(s.z_start_mm) || !std::isfinite(s.z_end_mm) || !(s.z_end_mm > s.z_start_mm)) {
    return bad("[gear.stroke] z_end_mm", s.z_end_mm,
               "must lie above z_start_mm = " + format_fixed(s.z_start_mm, 3) + " mm (the stroke runs up Z)");
  }
  if (!(s.spline_step_mm > 0.0) || !std::isfinite(s.spline_step_mm) || s.spline_step_mm > s.z_end_mm - s.z_start_mm ||
      (s.z_end_mm - s.z_start_mm) / s.spline_step_mm > 100000.0) {
    return bad("[gear.stroke] spline_step_mm", s.spline_step_mm,
               "must be positive, at most the stroke's length (" + format_fixed(s.z_end_mm - s.z_start_mm, 3) +
                   " mm) and give at most 100,000 points");
  }
  return {};
}

GearCoupling gear_coupling(const GearPart& part) {
  const GearGeometry& g = part.gear;
  const WormWheel& w = part.worm;
  const double beta = g.helix_angle_deg * kRadPerDeg;
  const double gamma = worm_lead_angle_deg(w, g.normal_module_mm) * kRadPerDeg;
  const double hg = g.helix_angle_deg == 0.0 ? 0.0 : hand_sign(g.hand);
  const double hw = hand_sign(w.hand);
  const double z2_mn = g.teeth * g.normal_module_mm;
  GearCoupling k;
  k.s_bc = -hw * w.starts / static_cast<double>(g.teeth);
  k.s_zc_deg_per_mm = -hg * 360.0 * std::sin(beta) / (kPi * z2_mn);
  k.s_yc_deg_per_mm = 360.0 * std::cos(gamma) / (kPi * z2_mn);
  k.s_sim_c = 1.0;
  k.lead_angle_deg = gamma / kRadPerDeg;
  k.setting_angle_deg = (hw * gamma - hg * beta) / kRadPerDeg;
  k.worm_lead_mm = w.starts * kPi * g.normal_module_mm / std::cos(gamma);
  k.gear_pitch_diameter_mm = z2_mn / std::cos(beta);
  k.transverse_pitch_mm = kPi * g.normal_module_mm / std::cos(beta);
  return k;
}

double equivalent_sim_deg(const GearCoupling& k, const AxisErrors& e) {
  return k.s_yc_deg_per_mm * e.y_mm + k.s_zc_deg_per_mm * e.z_mm + k.s_bc * e.b_deg - e.c_deg;
}

Result<std::vector<StrokeSimPoint>> stroke_sim_points(const GearPart& part, const GearCoupling& k,
                                                      const StrokeAxisErrors& e) {
  const std::size_t n = e.z_mm.size();
  auto refuse = [&](const std::string& why) { return make_error(ErrorCode::kInvalidInput, e.source + ": " + why); };
  if (n < 2) return refuse("needs at least two rows of axis errors along Z");
  for (const std::vector<double>* column : {&e.y_error_um, &e.z_error_um, &e.b_error_deg, &e.c_error_deg}) {
    if (column->size() != n) return refuse("every row needs all four axis errors");
  }
  for (std::size_t i = 0; i < n; ++i) {
    for (double v : {e.z_mm[i], e.y_error_um[i], e.z_error_um[i], e.b_error_deg[i], e.c_error_deg[i]}) {
      if (!std::isfinite(v)) return refuse("row " + std::to_string(i + 1) + " is not all finite numbers");
    }
    if (i > 0 && !(e.z_mm[i] > e.z_mm[i - 1])) {
      return refuse("row " + std::to_string(i + 1) + ": Z " + format_fixed(e.z_mm[i], 3) +
                    " mm does not increase; give the rows from the bottom of the stroke up");
    }
  }
  const GearStroke& s = part.stroke;
  constexpr double kSlack = 1e-9;
  if (e.z_mm.front() > s.z_start_mm + kSlack || e.z_mm.back() < s.z_end_mm - kSlack) {
    return refuse("the errors are known from Z " + format_fixed(e.z_mm.front(), 3) + " to " +
                  format_fixed(e.z_mm.back(), 3) + " mm, the stroke runs from " + format_fixed(s.z_start_mm, 3) +
                  " to " + format_fixed(s.z_end_mm, 3) + " mm; measure (or model) the whole stroke");
  }
  std::vector<StrokeSimPoint> out;
  std::size_t row = 0;
  for (const double z : stroke_spline_points_mm(s)) {
    while (row + 2 < n && e.z_mm[row + 1] < z) ++row;
    const double t = std::clamp((z - e.z_mm[row]) / (e.z_mm[row + 1] - e.z_mm[row]), 0.0, 1.0);
    auto lerp = [&](const std::vector<double>& v) { return v[row] + t * (v[row + 1] - v[row]); };
    StrokeSimPoint p;
    p.z_mm = z;
    p.errors =
        AxisErrors{lerp(e.y_error_um) / 1000.0, lerp(e.z_error_um) / 1000.0, lerp(e.b_error_deg), lerp(e.c_error_deg)};
    p.sim_deg = equivalent_sim_deg(k, p.errors);
    out.push_back(p);
  }
  return out;
}

std::vector<double> stroke_spline_points_mm(const GearStroke& s) {
  const double length = s.z_end_mm - s.z_start_mm;
  const auto steps = static_cast<std::size_t>(std::ceil(length / s.spline_step_mm - 1e-9));
  std::vector<double> z;
  z.reserve(steps + 1);
  for (std::size_t j = 0; j <= steps; ++j) {
    z.push_back(j == steps ? s.z_end_mm : s.z_start_mm + static_cast<double>(j) * s.spline_step_mm);
  }
  return z;
}

}  // namespace gaugeloop
