// The wheel path that grinds a pin, on the fine C grid a curve table needs, and the one rule
// that turns a correction along the grinding normal into moves of the machine's axes.
// Frames: core/pin.h. Derivation and figure: docs/crankpins.md.
#pragma once

#include <vector>

#include "compensation/work_speed.h"
#include "core/pin.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// The wheel's path over one turn: row k at C = k * c_step_deg, k = 0 .. 360/c_step_deg - 1.
// X and Y in mm with their C-derivatives per degree, exact (closed form, not finite
// differences) for the design; Y and its derivatives are all 0 in C-X. contact_psi_deg and
// normal_deg are the design's at each row (design_pin_pose): a correction moves the wheel by
// micrometres, which moves the grinding point by a negligible angle.
struct PinPath {
  double c_step_deg = 0.01;
  std::vector<double> x_mm;
  std::vector<double> dx_dc_mm_per_deg;
  std::vector<double> d2x_dc2_mm_per_deg2;
  std::vector<double> y_mm;
  std::vector<double> dy_dc_mm_per_deg;
  std::vector<double> d2y_dc2_mm_per_deg2;
  std::vector<double> contact_psi_deg;  // pin-frame angle ground at the row, [0, 360)
  std::vector<double> normal_deg;       // machine-frame angle of the grinding normal

  std::size_t size() const { return x_mm.size(); }
  double c_deg(std::size_t k) const { return static_cast<double>(k) * c_step_deg; }
};

// The design path. Errors: as validate(PinGeometry); kInvalidInput for a step not in (0, 1]
// or not dividing 360.
Result<PinPath> compute_pin_path(const PinGeometry& pin, double c_step_deg);

// The general rule, after the gear grinder's virtual axis: a displacement `displacement_mm`
// of the wheel along the unit direction at `direction_deg` (machine frame), made by the axes
// whose unit directions are at `axis_deg` (X at 0, Y at 90), as the smallest move of those
// axes whose projection on the direction is the displacement:
//   u_k = d cos(a_k - n) / sum_j cos^2(a_j - n).
// X and Y together (C-X-Y): u_X = d cos n, u_Y = d sin n, the direction cosines. X alone
// (C-X): u_X = d / cos n. kInvalidInput when no axis has a component along the direction
// (the sum is below 1e-12).
Result<std::vector<double>> split_along_direction(double displacement_mm, double direction_deg,
                                                  const std::vector<double>& axis_deg);

// The path that grinds the pin to the target radius r - c(psi) / 1000 in every pin-frame
// direction psi, c = correction_um (pin frame, index = whole pin degree; positive takes more
// off): at each row the design wheel moves by -c(contact_psi) / 1000 along the grinding
// normal, split onto the mode's axes (X alone, or X and Y) by split_along_direction. c is
// interpolated with a periodic spline. C-X-Y moves along the line of centres (the normal is
// horizontal, so the move is all X), exactly; C-X moves X by d / cos n, which also carries
// the wheel d tan n across that line and changes the distance of the centres by
// d^2 tan^2 n / (2 (r + rw)) more: second order, 1.2e-8 mm at 20 um on the sample pin
// (R 45, r 25, rw 300), and the grinding point moves by a negligible angle. Derivatives of
// the moved path are the design's plus those of the move (spline derivatives through the
// chain rule).
// A zero correction gives the design path bit for bit. Errors: as compute_pin_path;
// kInvalidInput for a non-finite correction.
Result<PinPath> corrected_pin_path(const PinGeometry& pin, const DegreeTable& correction_um, double c_step_deg);

// The grinding-point speed at every row with C at the constant `speed_rpm`, mm/min
// (pin_grinding_point_speed_mm_per_min).
std::vector<double> pin_grinding_point_speed_mm_per_min(const PinPath& path, const PinGeometry& pin, double speed_rpm);

// The work speed program that keeps the grinding-point speed constant over the whole pin (in
// C-X it varies by (r + rw + R) / (r + rw - R) at one C speed): the target is
// settings.lobe_speed_mm_per_min everywhere (lobe_threshold_mm is not used: a pin has no base
// circle), C never faster than base_speed_rpm, within the C acceleration and the slide
// limits as plan_work_speed keeps them (the same planner: ceiling, then forward and backward
// passes). The plan's constant_* figures are at base_speed_rpm. Errors: as plan_work_speed.
Result<WorkSpeedPlan> plan_pin_work_speed(const PinPath& path, const PinGeometry& pin,
                                          const WorkSpeedSettings& settings);

}  // namespace gaugeloop
