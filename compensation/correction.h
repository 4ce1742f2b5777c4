// Turning measured lift errors into the correction for the next part, and its wheel path.
#pragma once

#include "compensation/wheel_path.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// Keeps harmonics 0..max_harmonic of a periodic table (Fourier truncation with Eigen's FFT),
// in the table's own units. max_harmonic < 0 gives all zeros; >= 180 returns the input.
DegreeTable smooth_harmonics(const DegreeTable& values, int max_harmonic);

struct CompensationSettings {
  double gain = 1.0;                 // g in (0, 1]: fraction of the smoothed error fed back
  int max_harmonic = 30;             // harmonics kept when smoothing the error, 0..180
  double max_correction_um = 100.0;  // guard on the correction in force after this step
};

// Correction convention: a correction c(theta) in um, cam frame, per whole cam degree, in
// flat-probe reading terms. The next part is ground to the target whose flat-probe reading
// is design - c (correct the target, BRIEF section 5), so a lobe that measured e um high
// asks for c to grow by g * e.
//
// Returns correction_in_force_um + gain * smooth_harmonics(analysis.error_um, max_harmonic)
// (iterative learning control: each run builds on the correction in force).
// Errors: kRefused when gain is outside (0, 1] or when any |correction| exceeds
// max_correction_um (naming the degree and the value: approve it by hand or find the cause);
// kInvalidInput for non-finite inputs, max_harmonic outside [0, 180] or a limit <= 0.
Result<DegreeTable> next_correction(const LobeAnalysis& analysis, const DegreeTable& correction_in_force_um,
                                    const CompensationSettings& s);

// The wheel path that grinds the design lobe with `correction_um` applied (convention above).
// The correction table is interpolated with a PeriodicSpline; at each knot of `design`:
//  - flat follower: target lift = design lift - c(beta) / 1000 (the lift is the reading);
//  - roller and knife edge: the reading at probe angle theta moves the cam surface point
//    whose normal is theta; the follower at beta = theta + alpha (alpha the pressure angle)
//    sees that move divided by cos(alpha). So target lift = design lift
//    - c(beta - alpha(beta)) / cos(alpha(beta)) / 1000 wherever the cam surface is on its
//    convex hull (first order in c). A concave flank is invisible to a flat probe; there the
//    lift correction is interpolated periodically between the neighbouring hull points.
// Then a periodic spline through the target lifts, and compute_wheel_path. A zero correction
// gives exactly compute_wheel_path of the design.
// Errors: as PeriodicSpline::fit (design table), compute_wheel_path; kInvalidInput for a
// non-finite correction.
Result<WheelPath> corrected_wheel_path(const LiftTable& design, const DegreeTable& correction_um, const Part& part,
                                       double step_deg);

}  // namespace gaugeloop
