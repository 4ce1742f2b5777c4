// From a measured run to the lift error table: frame mapping, averaging, zeroing, comparison.
#pragma once

#include <array>
#include <string>
#include <string_view>
#include <vector>

#include "compensation/flat_probe.h"
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

// The whole cam degrees of the base-circle window (centre +- half width, wrapping through 0),
// in increasing order. kInvalidInput, starting with `who`, for a centre or half width that is
// not finite or a half width not in (0, 180) deg, or a window holding no whole degree.
Result<std::vector<size_t>> base_circle_window_degrees(const AnalysisSettings& settings, std::string_view who);
// "150.0 to 210.0 deg": the window as messages name it.
std::string base_circle_window_text(const AnalysisSettings& settings);

// Analyses one run against the design.
//  - run: samples indexed by MACHINE degree C (gauge reading, mm, not zeroed).
//  - design_lift_mm: what a flat probe should read on the design lobe at whole cam degrees,
//    cam frame, mm (flat_probe_reading), 0 on the base circle.
//  - part: gives the frame mapping beta = cam_angle_at_probe_deg(part, C). When every beta is
//    a whole degree the mapping is a permutation; otherwise each revolution is interpolated
//    periodically (PeriodicSpline) onto whole cam degrees.
// Result (cam frame, index = whole cam degree): per-degree mean over revolutions, zeroed by
// subtracting its mean over the base-circle window (zero_offset_mm); spread_um = per-degree
// sample standard deviation across revolutions; repeatability_um = the largest spread.
//
// Lift error: error_um = (mean - design) * 1000 at the nominal timing, and max_abs_error_um,
// rms_error_um and peak_to_valley_um are of that table. The phase is NOT removed from them:
// in-process the gauge and the wheel both work from the C axis, so a timing error seen here
// is an error of the table the next part is ground with (servo lag, a late gauge latch, a
// wrong probe offset), and this table is what compensation corrects (next_correction). A cam
// inspection machine reports the profile error after a best-fit phase; that is
// fit_phase_error's residual (max, RMS, peak to valley), and the phase beside it:
//  - phase_error_deg: the rotation of the lobe, least squares (fit_phase_error);
//  - base_circle_runout_um: total indicator reading of the base circle, 2 e for an
//    eccentricity e (fit_base_circle_runout);
//  - harmonic_amplitude_um[k]: amplitude of harmonic k of error_um (harmonic_amplitudes_um);
//  - residual_error_um and its max, RMS and peak to valley: the lift error after turning the
//    design by phase_error_deg (fit_phase_error's residual, without its limit on the phase);
//  - dial_runout_um, roundness_um: inspect_base_circle over the base-circle window of
//    `settings` (0 for a window of fewer than 3 whole degrees).
// Errors (kInvalidInput): fewer than 3 revolutions; a non-finite sample or design value;
// a window that is not in (0, 180) deg wide or holds no whole degree; a window where the
// design lift is not on the base circle (|design| > 1 um), naming the degrees.
Result<LobeAnalysis> analyse_lobe(const MeasuredRun& run, const DegreeTable& design_lift_mm, const Part& part,
                                  const AnalysisSettings& settings);

// The same, with the design reading as a model at any angle (DesignReading::of_lobe), which
// the phase fit and the resampling of fractional frame offsets evaluate between whole
// degrees. Prefer it: for a roller lobe whose reading has corners (a probe bridging a
// concave flank) the table-only overload above interpolates the design there and reports
// a phase-aligned error of several um that is not on the part.
Result<LobeAnalysis> analyse_lobe(const MeasuredRun& run, const DesignReading& design, const Part& part,
                                  const AnalysisSettings& settings);

// Base-circle runout. An eccentric lobe (its centre displaced e from the C axis towards cam
// angle theta0) reads e cos(theta - theta0) more than its design all round: exactly, for a
// flat probe, since that is how a support function moves under a translation. Fitting that
// first harmonic to the whole error table would also take in whatever first harmonic the
// flank and nose errors carry, so it is fitted, with a constant (the zero), on the base
// circle only: the degrees where the design reading is within 1 um of 0 for 3 degrees
// either side (off the ramps, where a phase error would leak in). On a base circle shorter
// than 20 such degrees the 3-degree margin is dropped. The figure is the total indicator
// reading a dial on the base circle would show if it ran all round: 2 e.
struct BaseCircleRunout {
  double runout_um = 0.0;        // total indicator reading, 2 e
  double eccentricity_um = 0.0;  // e
  double high_point_deg = 0.0;   // theta0, cam frame, in [0, 360): where the base circle reads highest
  int degrees_used = 0;          // base-circle degrees the fit used (0: no base circle, figures 0)
};

// error_um and design_lift_mm as in LobeAnalysis (cam frame, whole degrees).
BaseCircleRunout fit_base_circle_runout(const DegreeTable& error_um, const DegreeTable& design_lift_mm);

// Phase (timing) error: the rotation phi of the lobe, in cam degrees, that best explains the
// measurement in least squares, mean(theta) ~ design(theta - phi) (a positive phi means
// the lobe features appear phi degrees later in cam angle, i.e. the lobe is turned
// counter-clockwise in the cam frame). Fitted on the periodic spline of the design, over
// all 360 degrees, with the base-circle eccentricity (fit_base_circle_runout) taken out of
// the measurement first, so a displaced lobe does not read as a rotated one: first the whole
// degree of best circular correlation (Eigen FFT), so any rotation is found, then
// Gauss-Newton with step halving to 1e-9 deg. The residual is the error left after removing
// that rotation, the profile error a cam inspection report shows:
// residual_error_um = (mean(theta) - design(theta - phi)) * 1000 (eccentricity left in).
struct PhaseFit {
  double phase_error_deg = 0.0;
  DegreeTable residual_error_um{};
  double max_abs_residual_um = 0.0;
  double rms_residual_um = 0.0;
  double peak_to_valley_residual_um = 0.0;
};

// Uses analysis.mean_lift_mm and the design: its model `design` (as analyse_lobe), or in
// the first overload the spline through analysis.design_lift_mm.
// Errors: kInvalidInput when the design has no lift to align on (a round part);
// kRefused when the best rotation exceeds `max_phase_deg` (a clamping or setup fault:
// check c_offset_deg and the probe offset before compensating).
Result<PhaseFit> fit_phase_error(const LobeAnalysis& analysis, double max_phase_deg = 5.0);
Result<PhaseFit> fit_phase_error(const LobeAnalysis& analysis, const DesignReading& design, double max_phase_deg = 5.0);

// Largest |value|, RMS and peak to valley of a per-degree table, in its unit.
struct DegreeFigures {
  double max_abs = 0.0;
  double rms = 0.0;
  double peak_to_valley = 0.0;
};
DegreeFigures degree_figures(const DegreeTable& values);

// Amplitudes of harmonics 0..30 of a per-degree table (Eigen FFT), in the table's unit:
// the table is sum over k of A_k cos(k theta + phase_k), A_0 = |mean|. Harmonic k has k
// undulations per turn.
std::array<double, 31> harmonic_amplitudes_um(const DegreeTable& values_um);

}  // namespace gaugeloop
