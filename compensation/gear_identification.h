// The axes' errors of a generating grinder identified from what a shop measures: the lead of a
// ground gear (through the gearbox, the flank sees only dSIM, one sum of the four axes' errors)
// and, optionally, a ballbar circle in the ZY plane (Y and Z themselves). A per-axis error model
// is fitted by least squares (Eigen); terms the data cannot tell apart are named and the fit is
// refused, before anything is written (docs/gears.md, "Identifying the axes").
#pragma once

#include <string>
#include <vector>

#include "compensation/ballbar.h"
#include "compensation/gear_coupling.h"
#include "compensation/gear_lead.h"
#include "core/result.h"

namespace gaugeloop {

// One term of an axis' error along the stroke, a function of Z (mm): z, z^2, or a sine and
// cosine pair of a pitch. Constants are not terms: the lead does not see a constant mesh error
// (it is tooth thickness) and a ballbar's centring takes out a constant offset.
enum class ErrorTermKind { kLinear, kBow, kPeriodic };
struct ErrorTerm {
  char axis = 'Y';  // 'Y', 'Z' (mm), 'B', 'C' (degrees)
  ErrorTermKind kind = ErrorTermKind::kLinear;
  double pitch_mm = 0.0;     // kPeriodic only
  std::string name() const;  // "Y linear", "Z bow", "C periodic 24 mm"
};

// Parses "y:bow,y:linear,z:periodic@13.6,c:periodic@24" (axis y, z, b or c; kind linear, bow or
// periodic@<pitch mm>). kInvalidInput naming the item.
Result<std::vector<ErrorTerm>> parse_error_terms(std::string_view text);

struct IdentifiedTerm {
  ErrorTerm term;
  double value = 0.0;      // linear: per mm; bow: per mm^2; periodic: amplitude (mm or deg)
  double phase_rad = 0.0;  // periodic: the error is value sin(2 pi z / pitch + phase)
  double sin_coefficient = 0.0;
  double cos_coefficient = 0.0;
};

struct AxisIdentification {
  std::vector<IdentifiedTerm> terms;
  double lead_residual_rms_um = 0.0;
  double ballbar_residual_rms_um = 0.0;  // 0 without a ballbar
  int lead_samples = 0;
  int ballbar_samples = 0;
  double condition = 0.0;  // of the model's columns, each scaled to unit length
  // The axes' errors at z (mm for Y and Z, degrees for B and C) as the model has them.
  AxisErrors at(double z_mm) const;
};

// Fits `terms` to the lead traces (ground with SIM1 at `sim_in_force`, linear between its spline
// points: the mesh error is SIM1 less dSIM) and, if given, the ballbar circle (radial error =
// e_Y cos(angle) + e_Z sin(angle) at z = r sin(angle), plus the ballbar's centring and Y's scale
// against Z's, which are fitted and not reported). Each trace has its own offset (the checker's
// alignment). kRefused when the data cannot tell terms apart (a singular value under 1e-9 of the
// largest, columns scaled to unit length): the message names each group of terms that act alike
// and what would separate them. kInvalidInput for no term, no trace, a term repeated, a ballbar
// of fewer than 8 points or mismatched lengths, a periodic pitch not positive.
Result<AxisIdentification> identify_axis_errors(const GearCoupling& coupling, double base_radius_mm,
                                                const std::vector<ErrorTerm>& terms,
                                                const std::vector<LeadTrace>& traces,
                                                const std::vector<StrokeSimPoint>& sim_in_force,
                                                const BallbarCircle* ballbar);

}  // namespace gaugeloop
