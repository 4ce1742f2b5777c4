// A gear's flank lines across the face width (lead, or helix, traces) as a gear checker
// measures them; what ISO 1328-1 makes of one (total, form and slope helix deviation, the
// flank tolerance class); and the gearbox's mesh error along the stroke identified from them by
// least squares (docs/gears.md, "The loop").
//
// Frame: Z of the stroke (core/gear.h), the face from -b/2 to +b/2 around Z = 0. A deviation is
// in um along the base circle's tangent in the transverse plane, positive where the flank has
// more metal than the design helix. The left flank is the one facing +C: turning the gear by
// +dC (radians) against the worm leaves the left flank r_b dC thicker and the right one r_b dC
// thinner.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/gear.h"
#include "core/result.h"

namespace gaugeloop {

// The gear's base radius: d2 / 2 cos(alpha_t), tan(alpha_t) = tan(alpha_n) / cos(beta).
double base_radius_mm(const GearGeometry& gear);

// What ISO 1328-1 makes of a flank line over its evaluation range: a lead's (F_beta, f_f_beta,
// f_H_beta; the range the face less, at each end, the smaller of 5 % of the face width and one
// module; positions Z) or a profile's (F_alpha, f_f_alpha, f_H_alpha; roll lengths).
struct FlankLineFigures {
  double total_um = 0.0;  // the band between two design lines (of the design slope) enclosing the trace
  double form_um = 0.0;   // the band between two mean lines (the least-squares line)
  double slope_um = 0.0;  // the mean line's rise over the range, signed
  double from_mm = 0.0;
  double to_mm = 0.0;
  int points = 0;
};
using LeadFigures = FlankLineFigures;
using ProfileFigures = FlankLineFigures;
// kInvalidInput when fewer than 3 points of the trace fall in the evaluation range or the trace
// is not increasing in Z.
Result<LeadFigures> lead_figures(const LeadTrace& trace, const GearGeometry& gear);

// The profile a checker traces at the face's middle: roll lengths from the root form circle (the
// pitch radius less one module, not below the base circle) to the tip circle (the pitch radius
// plus one module: a standard addendum), and ISO 1328-1's evaluation range, the first 92 % of
// that from the root.
struct ProfileRange {
  double start_roll_mm = 0.0;
  double tip_roll_mm = 0.0;
  double evaluation_end_roll_mm = 0.0;
};
ProfileRange profile_range(const GearGeometry& gear);

// ISO 1328-1's profile deviations over the evaluation range, the design line an involute.
// kInvalidInput for fewer than 3 points in the range, a trace not increasing.
Result<ProfileFigures> profile_figures(const ProfileTrace& trace, const GearGeometry& gear);

// The flank tolerance class of ISO 1328-1 for a total helix deviation: the smallest class A (1
// to 11) whose tolerance F_betaT = (0.1 sqrt(d) + 0.63 sqrt(b) + 4.2) sqrt(2)^(A - 5) um holds
// it (d the pitch diameter, b the face width, mm; the standard's rounding of tolerances is not
// applied); 12 when none does.
int helix_tolerance_class(double total_um, double pitch_diameter_mm, double face_width_mm);
double helix_tolerance_um(int tolerance_class, double pitch_diameter_mm, double face_width_mm);

// The same for a total profile deviation: F_alphaT = (3.2 sqrt(m_n) + 0.22 sqrt(d) + 0.7)
// sqrt(2)^(A - 5) um (m_n the normal module, d the pitch diameter, mm).
int profile_tolerance_class(double total_um, double normal_module_mm, double pitch_diameter_mm);
double profile_tolerance_um(int tolerance_class, double normal_module_mm, double pitch_diameter_mm);

// The gearbox's mesh error at the stroke's spline points, identified from lead traces.
struct MeshIdentification {
  std::vector<double> z_mm;      // the spline points
  std::vector<double> mesh_deg;  // C ahead of where the worm needs it, degrees: SIM1 less what
                                 // puts the gear in mesh; its mean over the observed points is 0
  std::vector<bool> observed;    // false: no trace reaches the point's span; held at the nearest
                                 // observed point's value
  double residual_rms_um = 0.0;  // the traces about the fit: what the spline points cannot follow,
                                 // and the checker's noise
  int traces = 0;
  int samples = 0;
  int unknowns = 0;  // observed spline points and one offset per trace
  int rank = 0;      // of the least-squares problem; unknowns - 1 when only the mean is unseen
};

// Fits, by least squares (Eigen), a mesh error linear between the spline points (as the control
// moves SIM1 between the stroke's blocks) to the traces: a deviation of flank f at z is
// flank_sign(f) r_b mesh(z) (radians) plus the trace's own offset, which the checker sets when
// it aligns on the tooth. So the lead sees the mesh error less its mean (a constant rotation is
// tooth thickness, not lead), and it sees only the mesh: Y, Z, B and C act on it through one sum,
// dSIM, and are not separable from the lead alone (docs/gears.md). kInvalidInput for no trace,
// fewer than 2 spline points, a trace with no point on the stroke, or one not increasing in Z.
Result<MeshIdentification> identify_mesh_error(const std::vector<LeadTrace>& traces,
                                               const std::vector<double>& spline_z_mm, double base_radius_mm);

}  // namespace gaugeloop
