// The electronic gearbox of a worm-wheel generating grinder, in closed form: the coupling
// factors that make the work spindle C follow the worm's rotation B, the stroke Z and the shift
// Y, and the equivalent compensation that moves C through a virtual leading axis SIM1 coupled
// 1:1 to C, since C cannot be commanded while it follows. Frames and senses: core/gear.h; the
// derivation (generating condition on the pitch plane): docs/gears.md.
#pragma once

#include <string>
#include <vector>

#include "core/gear.h"
#include "core/result.h"

namespace gaugeloop {

// Checks a gear part: module, teeth (5..1000), pressure angle (5..45 deg), helix angle
// (0..60 deg), face width, worm starts (1..10) and pitch diameter positive and finite, the worm
// not steeper than 45 deg, a given lead angle within 0.01 deg of the one its starts, module and
// pitch diameter make, the stroke from its start to its end (at least one spline step, at most
// 100,000 points). kInvalidInput naming the key as the part file spells it ([gear] helix_angle_deg,
// [gear.worm] lead_angle_deg, [gear.stroke] spline_step_mm, ...), its value and what is allowed.
Status validate(const GearPart& part);

// The lead angle a worm of these starts and pitch diameter has for a normal module:
// asin(starts * module / pitch diameter), degrees.
double worm_lead_angle_deg(const WormWheel& worm, double normal_module_mm);

// What the gearbox couples, and the geometry it comes from. C follows
//   C = S_BC B + S_ZC Z + S_YC Y + SIM1
// (degrees; Z and Y in mm), with
//   S_BC = -h_w z0 / z2                     (deg of C per deg of B)
//   S_ZC = -h_g 360 sin(beta) / (pi z2 m_n)   = -h_g 360 tan(beta) / (pi d2)   (deg per mm)
//   S_YC = 360 cos(gamma) / (pi z2 m_n)                                      (deg per mm)
//   S_SIM1,C = 1
// h_g, h_w the hands (+1 right, -1 left), beta the gear's helix angle, gamma the worm's lead
// angle, z0 the starts, z2 the teeth, d2 = z2 m_n / cos(beta) the gear's pitch diameter.
struct GearCoupling {
  double s_bc = 0.0;               // deg of C per deg of B
  double s_zc_deg_per_mm = 0.0;    // deg of C per mm of Z
  double s_yc_deg_per_mm = 0.0;    // deg of C per mm of Y
  double s_sim_c = 1.0;            // deg of C per deg of SIM1
  double setting_angle_deg = 0.0;  // the worm's axis from the gear's transverse direction towards +Z:
                                   // h_w gamma - h_g beta
  double lead_angle_deg = 0.0;     // gamma
  double worm_lead_mm = 0.0;       // one turn of the worm moves its thread z0 pi m_n / cos(gamma) along its axis
  double gear_pitch_diameter_mm = 0.0;
  double transverse_pitch_mm = 0.0;  // pi m_n / cos(beta), one tooth along the pitch circle
};

// Call validate first.
GearCoupling gear_coupling(const GearPart& part);

// Axis errors at one point of the stroke: where the axis is less where it was commanded
// (Y, Z in mm; B, C in degrees).
struct AxisErrors {
  double y_mm = 0.0;
  double z_mm = 0.0;
  double b_deg = 0.0;
  double c_deg = 0.0;
};

// The SIM1 move (degrees of C) that puts the gear back in mesh with the worm where they stand:
// the gearbox makes C follow the commanded Y, Z, B, so C lacks S_YC e_Y + S_ZC e_Z + S_BC e_B
// and carries e_C too much; SIM1 moves C by the difference:
//   dSIM = S_YC e_Y + S_ZC e_Z + S_BC e_B - e_C.
// (The generating paper writes the same sum of compensation amounts, dY S_YC + dZ S_ZC +
// dB S_BC + dC; with its amounts as corrections of C it is this.)
double equivalent_sim_deg(const GearCoupling& k, const AxisErrors& e);

// The axes' errors along the stroke, one row per Z (increasing), as measured or from an
// identified error model (docs/gears.md): Y and Z in um, B and C in degrees, each where the
// axis is less where it was commanded with the worm at that Z.
struct StrokeAxisErrors {
  std::vector<double> z_mm;
  std::vector<double> y_error_um, z_error_um, b_error_deg, c_error_deg;
  std::string source;  // for messages: the file
};

// One spline point of the stroke: Z and where SIM1 stands there (degrees of C).
struct StrokeSimPoint {
  double z_mm = 0.0;
  double sim_deg = 0.0;
  AxisErrors errors;  // the axes' errors at that Z (Y, Z in mm), linear between the rows
};

// The Z of the stroke's spline points: z_start_mm, then every spline_step_mm, the last at
// z_end_mm (a shorter last step where the stroke is not a whole number of steps).
std::vector<double> stroke_spline_points_mm(const GearStroke& stroke);

// The spline points of the part's stroke (z_start_mm, then every spline_step_mm, the last at
// z_end_mm) with the SIM1 position that compensates the errors there (equivalent_sim_deg).
// The errors are linear in Z between rows; kInvalidInput naming the source when the rows are
// not increasing in Z, are not all finite, or do not cover the stroke (no extrapolation: an
// error model is only known where it was measured).
Result<std::vector<StrokeSimPoint>> stroke_sim_points(const GearPart& part, const GearCoupling& k,
                                                      const StrokeAxisErrors& errors);

}  // namespace gaugeloop
