// Inspection figures of a lobe beyond the lift error: velocity and acceleration error, the
// base-circle runout as a dial reads it, and the roundness of the base circle.
#pragma once

#include "compensation/analysis.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// The smoothing behind the derivatives. A lift error table carries gauge noise at every
// degree, and differentiating noise amplifies it by the harmonic number (velocity) or its
// square (acceleration), so the error is first band-limited: harmonics 0..max_harmonic are
// kept (Fourier truncation with Eigen's FFT, as the correction smooths with the same
// default of 30), and the kept harmonics are differentiated exactly in the spectrum
// (harmonic k times i k 2 pi / 360 per degree). A truncated Fourier series was chosen over a
// periodic spline because its pass band is stated in the shop's own terms (undulations per
// turn, as harmonic_amplitudes_um reports them), a band-limited error is differentiated
// without error, and its noise is known in closed form (derivative_noise_rms).
struct InspectionSettings {
  int max_harmonic = 30;  // harmonics kept before differentiating, 1..179
};

// Velocity and acceleration error, cam frame, index = whole cam degree: the first and
// second derivative of the smoothed lift error with respect to cam angle. The largest
// magnitudes are given with the degree where they occur (among equal extremes, the one that
// rounding makes largest).
struct ErrorDerivatives {
  DegreeTable velocity_error_mm_per_deg{};
  DegreeTable acceleration_error_mm_per_deg2{};
  double max_abs_velocity_error_mm_per_deg = 0.0;
  int max_velocity_error_deg = 0;
  double max_abs_acceleration_error_mm_per_deg2 = 0.0;
  int max_acceleration_error_deg = 0;
};

// error_um: the lift error table (LobeAnalysis::error_um), um.
// Errors (kInvalidInput): a non-finite error value (naming the degree); max_harmonic
// outside 1..179.
Result<ErrorDerivatives> error_derivatives(const DegreeTable& error_um, const InspectionSettings& settings = {});

// The noise the derivatives carry. With white gauge noise of RMS gauge_noise_um per reading,
// averaged over `revolutions` readings per degree, the error table carries white noise of
// variance s^2 = gauge_noise_um^2 / revolutions per degree. Its harmonic k (1 <= k < 180)
// has E|X_k|^2 = 360 s^2, the filter keeps k = 1..K and multiplies harmonic k by
// (k w)^order, w = 2 pi / 360 rad per degree, so the derivative's noise has, at every
// degree, variance (2 s^2 / 360) * sum_{k=1..K} (k w)^(2 order). Returns its RMS in
// mm/deg^order (order 1: velocity, 2: acceleration); the zeroing constant does not enter.
// The figure assumes the whole-degree frame mapping; interpolated frames (a fractional
// c_offset_deg) smooth the noise a little, so it is then slightly high.
// Errors (kInvalidInput): a negative or non-finite noise, fewer than 1 revolution, order
// not 1 or 2, max_harmonic outside 1..179.
Result<double> derivative_noise_rms(double gauge_noise_um, int revolutions, int order,
                                    const InspectionSettings& settings = {});

// The base circle as a dial and a roundness tester see it, over the base-circle window of
// the analysis settings (the whole cam degrees within centre +- half width, as analyse_lobe
// zeroes on), from the lift error table error_um (um):
//  - dial_runout_um: peak to valley of the error over the window, what a dial indicator
//    swept over that arc reads. For an eccentricity e it is at most the all-round figure
//    2 e (base_circle_runout_um) and less over a part arc: over a window of half width w
//    it is e (1 - cos w) with the high point at the window centre and 2 e sin w with it
//    90 degrees away.
//  - roundness_um: peak to valley over the window of the error after removing the least
//    squares fit a + b cos(theta) + c sin(theta) over the same degrees (theta the cam
//    angle): the form left once the mean and the eccentricity are taken out. For a flat
//    probe a displaced circle reads exactly a first harmonic, so this is the deviation from
//    the least-squares circle of the arc. On a short arc the fit also takes in part of
//    any slow form (harmonics 2, 3 over a 60 degree arc look much like a tilt), so the
//    figure reads low there; over nearly the whole turn it is the full form error.
// Errors (kInvalidInput): a non-finite error value; a window centre or half width that is
// not finite or not in (0, 180) deg; a window holding fewer than 3 whole degrees (naming
// the window).
struct BaseCircleInspection {
  double dial_runout_um = 0.0;
  double roundness_um = 0.0;
  int degrees_used = 0;  // whole cam degrees in the window
};

Result<BaseCircleInspection> inspect_base_circle(const DegreeTable& error_um, const AnalysisSettings& window);

}  // namespace gaugeloop
