// A ballbar test in the ZY plane and what the slides' compensation tables should take out of it
// (docs/gears.md, "The slides"). The test is a circle run both ways, counter-clockwise and
// clockwise, as the ballbar's software lists it: the angle from +Y towards +Z and the bar's
// length less its nominal. Its figures (ISO 230-4's circular deviation, and the band about the
// set-up centre) and a least-squares fit (Eigen) of the slides' geometric errors, which tables
// can take out, beside the servo mismatch and backlash, which they cannot.
#pragma once

#include <string>
#include <vector>

#include "core/result.h"
#include "core/slide_table.h"

namespace gaugeloop {

// One circle: the angle from +Y towards +Z (degrees) and the radial deviation (um) at it.
struct BallbarCircle {
  double radius_mm = 100.0;
  std::vector<double> angle_deg;
  std::vector<double> radial_um;
};

struct BallbarTest {
  double radius_mm = 100.0;
  double feed_mm_per_min = 1000.0;
  BallbarCircle ccw;  // +Y towards +Z
  BallbarCircle cw;
};

struct BallbarFigures {
  // ISO 230-4's circular deviation, both directions together: the band of the radial deviations
  // about the least-squares centre (the set-up's offset taken out).
  double roundness_um = 0.0;
  // The band of the radial deviations as measured, about the set-up centre, both directions,
  // nothing fitted.
  double position_error_um = 0.0;
  double centre_y_um = 0.0;  // the least-squares centre's offset from the set-up centre
  double centre_z_um = 0.0;
  int samples = 0;
};

// kInvalidInput for a circle with fewer than 8 points, lengths that differ, a value not finite.
Result<BallbarFigures> ballbar_figures(const BallbarTest& test);

// What the fit may assume of the slides: the leads of Y's and Z's ball screws (mm; 0: no
// periodic error of that screw is fitted), from the machine's documentation.
struct SlideModel {
  double y_screw_lead_mm = 0.0;
  double z_screw_lead_mm = 0.0;
};

struct SlideIdentification {
  // Geometric, for the tables:
  double scale_mismatch = 0.0;         // Y's scale error less Z's (mm/mm): only the difference is seen
  double squareness = 0.0;             // Y's error per mm of Z (mm/mm)
  double y_straightness_per_mm = 0.0;  // Y's error per mm^2 of Z: Z's guide bowed in Y (1/mm)
  double z_straightness_per_mm = 0.0;  // Z's error per mm^2 of Y: Y's guide bowed in Z (1/mm)
  double y_screw_sin_mm = 0.0;         // Y's periodic error: sin and cos of 2 pi y / lead
  double y_screw_cos_mm = 0.0;
  double z_screw_sin_mm = 0.0;
  double z_screw_cos_mm = 0.0;
  // Dynamic, for the machine data (not a table):
  double servo_mismatch_ms = 0.0;  // Z's lag less Y's: match the axes' servo gain (Kv)
  double y_backlash_um = 0.0;      // the play of Y's drive: the backlash compensation
  double z_backlash_um = 0.0;
  SlideModel model;
  double radius_mm = 0.0;
  double residual_rms_um = 0.0;
  double condition = 0.0;  // of the model's columns, each scaled to unit length
  int samples = 0;
};

// Fits the slides' errors to both circles of `test` by least squares (radial deviation = the
// slides' errors along the radius, less the set-up centre's). kRefused when the data cannot tell
// terms apart (a singular value under 1e-9 of the largest), naming them and what separates them
// (a circle in one direction only cannot tell squareness from servo mismatch, nor a screw's
// error from its backlash); kInvalidInput as ballbar_figures, and for a screw lead negative or
// not finite.
Result<SlideIdentification> identify_slides(const BallbarTest& test, const SlideModel& model);

// The identified geometric errors as the control's tables, over `half_travel_mm` about the
// circle's centre (the axes' zero) every `step_mm`, each 0 at the centre: Y's LEC (the scale
// mismatch and Y's screw), Z's LEC (Z's screw), a CEC of Y over Z (squareness and Z's guide's
// bow) and a CEC of Z over Y (Y's guide's bow). Added to `in_force` when given: what a ballbar
// with tables loaded still sees is what they leave. kInvalidInput for a travel or step not
// positive or more than 10,000 points a table, or tables in force of another layout.
Result<std::vector<SlideCompensationTable>> slide_tables(const SlideIdentification& id, double half_travel_mm,
                                                         double step_mm,
                                                         const std::vector<SlideCompensationTable>& in_force = {});

}  // namespace gaugeloop
