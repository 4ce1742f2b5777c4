// The grinding-point speed along the lobe and a work speed program that holds it on the lobe.
//
// Grinding the flanks at the speed of the base circle makes the speed at which the wheel's
// contact point runs along the cam surface, and with it the equivalent chip thickness
// h_eq = a_e v_w / v_s, vary several times over a turn. A program that slows C where the
// wheel is on the lobe keeps v_w (and h_eq at a fixed depth of cut and wheel speed) at a
// target there, which is what gives the flanks their finish (docs/variable_speed.md).
#pragma once

#include <string_view>
#include <vector>

#include "compensation/wheel_path.h"
#include "core/part.h"
#include "core/result.h"
#include "core/work_speed.h"

namespace gaugeloop {

// How far the contact point runs along the cam surface (arc length, cam frame) per degree of
// wheel angle, mm/deg. Any follower: the ground surface is the envelope of the wheel, so only
// the wheel-centre curve and the wheel radius matter.
//
// Derivation. The wheel centre, cam frame, in polar form: r(psi) = rb + rw + X(psi), r' and
// r'' per radian. Its arc length runs at |W'| = sqrt(r^2 + r'^2) per radian and its curvature
// is k_W = (r^2 + 2 r'^2 - r r'') / (r^2 + r'^2)^(3/2). The cam surface is the inner offset of
// that curve by the wheel radius rw, P = W - rw n, so dP/ds_W = (1 - rw k_W) T and
//   ds/dpsi = sqrt(r^2 + r'^2) - rw (r^2 + 2 r'^2 - r r'') / (r^2 + r'^2)   [mm/rad]
// which is rb on the base circle (r = rb + rw, r' = r'' = 0). The grinding-point speed at a
// C speed of n rpm is v_w = ds/dpsi * 2 pi n (mm/min); |dpsi/dC| = 1, so the C derivatives
// of a machine path serve as well (the sign of X' does not enter).
// Arguments: X (mm), dX/dpsi (mm/deg), d2X/dpsi2 (mm/deg^2), rb and rw (mm).
double contact_arc_mm_per_deg(double x_mm, double dx_mm_per_deg, double d2x_mm_per_deg2, double base_radius_mm,
                              double wheel_radius_mm);

// v_w in mm/min from ds/dpsi (mm/deg) at n rpm: C turns 360 |n| degrees a minute.
inline double grinding_point_speed_mm_per_min(double contact_arc_mm_per_deg, double speed_rpm) {
  return contact_arc_mm_per_deg * 360.0 * (speed_rpm < 0.0 ? -speed_rpm : speed_rpm);
}

// The grinding-point speed at every row of `path` with C at the constant `speed_rpm`, mm/min.
std::vector<double> grinding_point_speed_mm_per_min(const MachinePath& path, const Part& part, double speed_rpm);

// The same under a speed program on the path's own grid (program.c_step_deg equal to the
// path's step, one entry per row). Errors: kInvalidInput when the grids differ.
Result<std::vector<double>> grinding_point_speed_mm_per_min(const MachinePath& path, const Part& part,
                                                            const WorkSpeedProgram& program);

// Where the speed program holds the grinding-point speed at a target.
enum class SpeedHold {
  // The whole lobe (X above lobe_threshold_mm: flanks and nose) at lobe_speed_mm_per_min; the
  // base circle at base_speed_rpm.
  kLobe,
  // As the variable-speed camshaft paper ground: the whole turn at grinding_point_speed_mm_per_min
  // (base circle and nose too), the flanks (rise and return: X between 5 % and 95 % of its
  // largest value, is_flank_row) at flank_speed_mm_per_min. A flank speed equal to the other is
  // the paper's baseline, one grinding-point speed all round.
  kFlanks,
};
std::string_view speed_hold_name(SpeedHold hold);  // "lobe", "flanks"

// The rise and return of a lobe: X between 5 % and 95 % of its largest value over the turn,
// neither base circle nor nose. The flank figure of the surface model reads the same rows.
inline bool is_flank_row(double x_mm, double x_max_mm) { return x_mm > 0.05 * x_max_mm && x_mm < 0.95 * x_max_mm; }

// What the speed program is asked to do. Messages name the keys as the files have them: the
// part file's `[speed]` for the lobe's settings, the service's `[nc]` for the slide's limits
// (docs/variable_speed.md).
struct WorkSpeedSettings {
  SpeedHold hold = SpeedHold::kLobe;
  // C speed on the base circle, and the most C ever turns: the program only slows down.
  double base_speed_rpm = 60.0;
  // kLobe: the grinding-point speed held where the wheel is on the lobe (X above
  // lobe_threshold_mm), flanks and nose; the variable-speed camshaft paper's slow-down took
  // the flanks to 2000 mm/min.
  double lobe_speed_mm_per_min = 2000.0;
  double lobe_threshold_mm = 0.01;
  // kFlanks: the grinding-point speed held on the base circle and the nose, and on the flanks.
  double grinding_point_speed_mm_per_min = 8000.0;
  double flank_speed_mm_per_min = 2000.0;
  // The work spindle's acceleration limit (either sense).
  double c_acceleration_max_deg_per_s2 = 1000.0;
  // The wheel slide's limits, as for the table guards.
  double x_velocity_max_mm_per_s = 300.0;
  double x_acceleration_max_mm_per_s2 = 20000.0;
};

// Checks the settings: kInvalidInput naming the key, its value and the range allowed.
Status validate(const WorkSpeedSettings& settings);

struct WorkSpeedPlan {
  WorkSpeedProgram program;                                      // on the path's C grid
  std::vector<double> grinding_point_speed_mm_per_min;           // per row, under the program
  std::vector<double> constant_grinding_point_speed_mm_per_min;  // per row, at base_speed_rpm throughout
  double cycle_time_s = 0.0;                                     // one turn under the program
  double constant_cycle_time_s = 0.0;                            // one turn at base_speed_rpm
  // Over the turn, under the program, from the discrete program (central differences); for
  // more than one following axis, the largest over the axes:
  double largest_c_acceleration_deg_per_s2 = 0.0;
  double largest_x_velocity_mm_per_s = 0.0;
  double largest_x_acceleration_mm_per_s2 = 0.0;
};

// The speed program for `path` (machine frame, with its derivatives, as compute_machine_path
// gives it; uniform grid over one turn). In omega = dC/dt (deg/s), per row:
//  1. a ceiling: 6 base_speed_rpm; where the speed is held (SpeedHold) also target / (ds/dC),
//     the target grinding-point speed there; the slide's velocity |X'| omega <= v_max; and half the slide's
//     acceleration from the path's curvature, |X''| omega^2 <= a_max / 2.
//  2. the highest profile under that ceiling whose changes keep the acceleration of C,
//     omega d(omega)/dC = d(omega^2)/dC / 2, within the C limit and within the other half of the
//     slide's: |X'| omega d(omega)/dC <= a_max / 2. A forward and a backward pass over
//     omega^2, twice round the periodic turn, so the program slows down before the lobe
//     rather than entering it too fast.
// So the slide's acceleration at variable speed, d2X/dt2 = X'' omega^2 + X' omega d(omega)/dC,
// stays within a_max. The lobe is never ground faster than the target; the base circle keeps
// base_speed_rpm (a base speed above the constant speed a shop grinds at wins back cycle time:
// X barely moves there).
// Errors: as validate; kInvalidInput for a path without derivatives or not on a uniform grid
// that divides 360.
Result<WorkSpeedPlan> plan_work_speed(const MachinePath& path, const Part& part, const WorkSpeedSettings& settings);

// The planner under plan_work_speed and plan_pin_work_speed (compensation/pin_path.h): what
// it needs of a path, row by row on a uniform C grid over one turn.
struct SpeedPlanRows {
  double c_step_deg = 0.0;
  // How far the grinding point runs over the work's surface per degree of C, mm/deg.
  std::vector<double> contact_arc_mm_per_deg;
  // The grinding-point speed held at each row, mm/min; 0 where none is (a lobe's base circle
  // under SpeedHold::kLobe).
  std::vector<double> target_mm_per_min;
  // The following axes' derivatives, per axis and row (X; X and Y for a C-X-Y pin). Each
  // axis is kept within the slide's limits of the settings: the slides share them.
  std::vector<std::vector<double>> d_dc_mm_per_deg;
  std::vector<std::vector<double>> d2_dc2_mm_per_deg2;
};

// The ceiling per row (6 base_speed_rpm; target / arc where a target is held; each axis's
// velocity and half its acceleration), then the forward and backward passes on omega^2 as
// plan_work_speed describes; the plan's largest_x_* figures are the largest over the axes.
// Errors: as validate; kInvalidInput for rows of differing sizes, fewer than 4, or a step
// that does not make one turn.
Result<WorkSpeedPlan> plan_work_speed_rows(const SpeedPlanRows& rows, const WorkSpeedSettings& settings);

// One turn's time under `program`, s: the trapezoid rule over dt = dC / omega.
double cycle_time_s(const WorkSpeedProgram& program);

}  // namespace gaugeloop
