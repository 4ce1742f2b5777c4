// Coupling factors of the generating gearbox and the equivalent compensation through SIM1.
#include "compensation/gear_coupling.h"

#include <cmath>
#include <string>

#include "core/number_text.h"

namespace gaugeloop {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRad = kPi / 180.0;

Error bad(const std::string& key, double value, const std::string& allowed) {
  const int decimals = std::isfinite(value) && value == std::round(value) ? 0 : 4;
  return make_error(ErrorCode::kInvalidInput, key + " = " + format_fixed(value, decimals) + ": " + allowed);
}

bool in(double v, double lo, double hi) { return std::isfinite(v) && v >= lo && v <= hi; }

}  // namespace

double worm_lead_angle_deg(const WormWheel& worm, double normal_module_mm) {
  return std::asin(worm.starts * normal_module_mm / worm.pitch_diameter_mm) / kRad;
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
  if (!(sin_lead <= std::sin(45.0 * kRad))) {
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
  const double beta = g.helix_angle_deg * kRad;
  const double gamma = worm_lead_angle_deg(w, g.normal_module_mm) * kRad;
  const double hg = g.helix_angle_deg == 0.0 ? 0.0 : hand_sign(g.hand);
  const double hw = hand_sign(w.hand);
  const double z2_mn = g.teeth * g.normal_module_mm;
  GearCoupling k;
  k.s_bc = -hw * w.starts / static_cast<double>(g.teeth);
  k.s_zc_deg_per_mm = -hg * 360.0 * std::sin(beta) / (kPi * z2_mn);
  k.s_yc_deg_per_mm = 360.0 * std::cos(gamma) / (kPi * z2_mn);
  k.s_sim_c = 1.0;
  k.lead_angle_deg = gamma / kRad;
  k.setting_angle_deg = (hw * gamma - hg * beta) / kRad;
  k.worm_lead_mm = w.starts * kPi * g.normal_module_mm / std::cos(gamma);
  k.gear_pitch_diameter_mm = z2_mn / std::cos(beta);
  k.transverse_pitch_mm = kPi * g.normal_module_mm / std::cos(beta);
  return k;
}

double equivalent_sim_deg(const GearCoupling& k, const AxisErrors& e) {
  return k.s_yc_deg_per_mm * e.y_mm + k.s_zc_deg_per_mm * e.z_mm + k.s_bc * e.b_deg - e.c_deg;
}

}  // namespace gaugeloop
