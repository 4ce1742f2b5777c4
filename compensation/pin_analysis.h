// Reading a pin from its gauge: samples per machine degree mapped to pin-frame degrees
// through the kinematics, the revolutions averaged, the least-squares circle and the figures
// a crankpin inspection gives; the pin's tolerances; and the correction for the next pin.
// Frames: core/pin.h; docs/crankpins.md.
#pragma once

#include <vector>

#include "compensation/correction.h"
#include "core/pin.h"
#include "core/result.h"
#include "core/run.h"
#include "core/tolerance.h"

namespace gaugeloop {

struct PinAnalysis {
  // Per pin-frame degree (index = psi in whole degrees), in the shape runs are stored in:
  //  - design_lift_mm: all 0 (the design is round: the gauge should read 0 everywhere);
  //  - mean_lift_mm: the mean reading, the pin's radius error in that direction, mm;
  //  - spread_um: per-degree standard deviation across revolutions;
  //  - error_um: mean_lift_mm in um; residual_error_um: error_um less the least-squares
  //    circle (what roundness is of), with its max, RMS and peak to valley;
  //  - harmonic_amplitude_um: of error_um; roundness_um as below; revolutions;
  //  - phase_error_deg: the index error (the pin's turn about the main axis);
  //  - zero_offset_mm 0 (the gauge is mastered: its reading is absolute), runouts 0.
  LobeAnalysis table;
  // The least-squares circle e(psi) ~ a0 + a1 cos psi + b1 sin psi of error_um:
  double radius_error_um = 0.0;    // a0
  double diameter_error_um = 0.0;  // 2 a0
  double stroke_error_um = 0.0;    // a1: the centre moved along the crank radius, outward
  double index_error_deg = 0.0;    // atan2(b1, R): the centre moved round the main axis, in the sense of C
  double roundness_um = 0.0;       // peak to valley of the residual
};

// The least-squares circle of a pin's radius error in um per whole pin degree:
// e(psi) ~ a0 + a1 cos psi + b1 sin psi. On an even grid over one turn the three functions
// are orthogonal, so each coefficient is a projection; to first order in the error the circle
// is the pin's size (a0) and its centre's offset (a1 outward along the crank radius, b1
// across it, counter-clockwise).
struct LeastSquaresCircle {
  double a0_um = 0.0;
  double a1_um = 0.0;
  double b1_um = 0.0;
  double at_um(std::size_t psi_deg) const;
};
LeastSquaresCircle fit_least_squares_circle(const DegreeTable& error_um);

// Maps every revolution's 360 samples (index = machine degree C) to the pin-frame angle the
// gauge read there (gauge_psi_deg), resamples each revolution onto whole pin degrees with a
// periodic cubic spline through those angles (in C-X they are not evenly spaced: the grinding
// point runs round the pin faster with the pin nearest the wheel), averages the revolutions
// and fits the circle. Errors: kInvalidInput for fewer than 2 revolutions or a non-finite
// sample (naming revolution and machine degree); as validate(PinGeometry).
Result<PinAnalysis> analyse_pin(const MeasuredRun& run, const PinGeometry& pin);

// The pin's characteristics against its tolerances (single figures, keys as core/pin.h):
// roundness, diameter_error, stroke_error, index_error, in that order, each judged (or not
// judged when it has no limits).
std::vector<Characteristic> judge_pin(const PinAnalysis& analysis, const PinTolerances& tolerances);

// One iterative-learning step for a pin, with the lobe's settings and guards where they mean
// the same (gain, harmonic band and its choice, max_correction_um, max_change_um,
// max_repeatability_um): correction = in force + gain * smooth(error_um), the whole error
// smoothed, the circle's first harmonic (stroke and index) and its constant (diameter)
// included: the path corrects them all. A pin has no timing, so max_phase_deg is not used.
// Convention: correction in um per pin-frame degree, positive takes more off
// (corrected_pin_path). Errors: as decide_correction.
Result<CompensationDecision> decide_pin_correction(const PinAnalysis& analysis,
                                                   const DegreeTable& correction_in_force_um,
                                                   const CompensationSettings& settings);

}  // namespace gaugeloop
