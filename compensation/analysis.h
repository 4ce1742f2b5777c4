// From a measured run to the lift error table: frame mapping, averaging, zeroing, comparison.
#pragma once

#include "compensation/periodic_spline.h"
#include "core/part.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// Where the base circle is, to zero the measurement. Cam frame, degrees.
struct AnalysisSettings {
  double base_circle_center_deg = 180.0;
  double base_circle_half_width_deg = 30.0;  // window = centre +- half width, whole degrees
};

// Analyses one run against the design.
//  - run: samples indexed by MACHINE degree C (gauge reading, mm, not zeroed).
//  - design_lift_mm: what a flat probe should read on the design lobe, cam frame, mm
//    (flat_probe_reading), 0 on the base circle.
//  - part: gives the frame mapping beta = cam_angle_at_probe_deg(part, C). When every beta is
//    a whole degree the mapping is a permutation; otherwise each revolution is interpolated
//    periodically (PeriodicSpline) onto whole cam degrees.
// Result (cam frame, index = whole cam degree): per-degree mean over revolutions, zeroed by
// subtracting its mean over the base-circle window (zero_offset_mm); spread_um = per-degree
// sample standard deviation across revolutions; error_um = (mean - design) * 1000; the
// summary figures; repeatability_um = the largest spread.
// Errors (kInvalidInput): fewer than 3 revolutions; a non-finite sample or design value;
// a window that is not in (0, 180) deg wide or holds no whole degree; a window where the
// design lift is not on the base circle (|design| > 1 um), naming the degrees.
Result<LobeAnalysis> analyse_lobe(const MeasuredRun& run, const DegreeTable& design_lift_mm, const Part& part,
                                  const AnalysisSettings& settings);

// Phase (timing) error: the rotation phi of the lobe, in cam degrees, that best explains the
// measurement in least squares, mean(theta) ~ design(theta - phi) (a positive phi means
// the lobe features appear phi degrees later in cam angle). Fitted by Gauss-Newton on the
// periodic spline of the design. The residual is the error left after removing that
// rotation: residual_error_um = (mean(theta) - design(theta - phi)) * 1000.
struct PhaseFit {
  double phase_error_deg = 0.0;
  DegreeTable residual_error_um{};
  double rms_residual_um = 0.0;
};

// Errors: kInvalidInput when the design has no lift to align on (a round part);
// kRefused when the best rotation exceeds `max_phase_deg` (a clamping or setup fault:
// check c_offset_deg and the probe offset before compensating).
Result<PhaseFit> fit_phase_error(const LobeAnalysis& analysis, double max_phase_deg = 5.0);

// Base-circle runout as a total indicator reading in um: twice the amplitude of the first
// harmonic of `error_um` (an eccentric lobe reads as e cos(theta - theta0) all round).
double first_harmonic_runout_um(const DegreeTable& error_um);

}  // namespace gaugeloop
