// Reading a pin from its gauge, judging it and correcting it; see pin_analysis.h.
#include "compensation/pin_analysis.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "compensation/analysis.h"
#include "compensation/periodic_spline.h"
#include "compensation/pin_kinematics.h"
#include "core/angles.h"

namespace gaugeloop {
namespace {

// Two revolutions are the fewest that tell a spread; the lobe asks for 3 because its zero
// and phase come from the run too, a pin's gauge is mastered.
constexpr int kMinPinRevolutions = 2;

}  // namespace

double LeastSquaresCircle::at_um(std::size_t psi_deg) const {
  const double psi = static_cast<double>(psi_deg) * kRadPerDeg;
  return a0_um + a1_um * std::cos(psi) + b1_um * std::sin(psi);
}

LeastSquaresCircle fit_least_squares_circle(const DegreeTable& e) {
  LeastSquaresCircle c;
  for (size_t d = 0; d < kDegrees; ++d) {
    const double psi = static_cast<double>(d) * kRadPerDeg;
    c.a0_um += e[d];
    c.a1_um += e[d] * std::cos(psi);
    c.b1_um += e[d] * std::sin(psi);
  }
  const double n = static_cast<double>(kDegrees);
  c.a0_um /= n;
  c.a1_um *= 2.0 / n;
  c.b1_um *= 2.0 / n;
  return c;
}

Result<PinAnalysis> analyse_pin(const MeasuredRun& run, const PinGeometry& pin) {
  if (Status valid = validate(pin); !valid.ok()) return valid.error();
  const int revolutions = static_cast<int>(run.revolutions.size());
  if (revolutions < kMinPinRevolutions) {
    return make_error(ErrorCode::kInvalidInput, "pin analysis: the run has " + std::to_string(revolutions) +
                                                    " complete revolution(s); at least " +
                                                    std::to_string(kMinPinRevolutions) +
                                                    " are needed to average and to judge repeatability; measure again");
  }
  for (const RevolutionSamples& rev : run.revolutions) {
    for (size_t c = 0; c < kDegrees; ++c) {
      if (!std::isfinite(rev.lift_mm[c])) {
        return make_error(ErrorCode::kInvalidInput, "pin analysis: revolution " + std::to_string(rev.revolution) +
                                                        " has no valid reading at machine degree " + std::to_string(c) +
                                                        "; discard the run and measure again");
      }
    }
  }

  // The pin-frame angle read at every machine degree, in increasing order: psi falls as C
  // rises and covers one turn, so sorting gives the samples in pin order, no two alike.
  std::vector<std::pair<double, size_t>> order(kDegrees);
  for (size_t c = 0; c < kDegrees; ++c) order[c] = {gauge_psi_deg(pin, static_cast<double>(c)), c};
  std::sort(order.begin(), order.end());
  std::vector<double> psi_deg(kDegrees);
  for (size_t i = 0; i < kDegrees; ++i) psi_deg[i] = order[i].first;

  std::vector<DegreeTable> resampled(run.revolutions.size());
  std::vector<double> value_mm(kDegrees);
  for (size_t r = 0; r < run.revolutions.size(); ++r) {
    for (size_t i = 0; i < kDegrees; ++i) value_mm[i] = run.revolutions[r].lift_mm[order[i].second];
    Result<PeriodicSpline> spline = PeriodicSpline::fit(psi_deg, value_mm);
    if (!spline.ok()) {
      return make_error(
          spline.error().code,
          "pin analysis: revolution " + std::to_string(run.revolutions[r].revolution) + ": " + spline.error().message);
    }
    for (size_t d = 0; d < kDegrees; ++d) resampled[r][d] = spline->value(static_cast<double>(d));
  }

  PinAnalysis out;
  LobeAnalysis& a = out.table;
  a.revolutions = revolutions;
  for (size_t d = 0; d < kDegrees; ++d) {
    double sum = 0.0;
    for (const DegreeTable& rev : resampled) sum += rev[d];
    const double mean = sum / revolutions;
    double spread_squares = 0.0;
    for (const DegreeTable& rev : resampled) spread_squares += (rev[d] - mean) * (rev[d] - mean);
    a.spread_um[d] = std::sqrt(spread_squares / (revolutions - 1)) * 1000.0;
    a.repeatability_um = std::max(a.repeatability_um, a.spread_um[d]);
    a.mean_lift_mm[d] = mean;
    a.error_um[d] = mean * 1000.0;
  }
  const DegreeFigures error = degree_figures(a.error_um);
  a.max_abs_error_um = error.max_abs;
  a.rms_error_um = error.rms;
  a.peak_to_valley_um = error.peak_to_valley;
  a.harmonic_amplitude_um = harmonic_amplitudes_um(a.error_um);

  const LeastSquaresCircle circle = fit_least_squares_circle(a.error_um);
  for (size_t d = 0; d < kDegrees; ++d) a.residual_error_um[d] = a.error_um[d] - circle.at_um(d);
  const DegreeFigures residual = degree_figures(a.residual_error_um);
  a.max_abs_residual_um = residual.max_abs;
  a.rms_residual_um = residual.rms;
  a.peak_to_valley_residual_um = residual.peak_to_valley;

  out.radius_error_um = circle.a0_um;
  out.diameter_error_um = 2.0 * circle.a0_um;
  out.stroke_error_um = circle.a1_um;
  // The centre moved b1 across the crank radius, counter-clockwise (the sense of C), at R from
  // the main axis: the pin stands turned by that angle about it.
  out.index_error_deg = std::atan2(circle.b1_um, pin.throw_mm * 1000.0) / kRadPerDeg;
  out.roundness_um = a.peak_to_valley_residual_um;
  a.phase_error_deg = out.index_error_deg;
  a.roundness_um = out.roundness_um;
  return out;
}

std::vector<Characteristic> judge_pin(const PinAnalysis& analysis, const PinTolerances& tolerances) {
  return {
      single_characteristic("roundness", "um", analysis.roundness_um, tolerances.roundness_um),
      single_characteristic("diameter_error", "um", analysis.diameter_error_um, tolerances.diameter_error_um),
      single_characteristic("stroke_error", "um", analysis.stroke_error_um, tolerances.stroke_error_um),
      single_characteristic("index_error", "deg", analysis.index_error_deg, tolerances.index_error_deg),
  };
}

Result<CompensationDecision> decide_pin_correction(const PinAnalysis& analysis,
                                                   const DegreeTable& correction_in_force_um,
                                                   const CompensationSettings& settings) {
  // The whole error is smoothed and fed back: the circle's constant and first harmonic are
  // errors of the path like any other, and a pin has no timing to fit first.
  LearningStep step;
  step.smoothed_part_um = analysis.table.error_um;
  step.spread_um = analysis.table.spread_um;
  step.revolutions = analysis.table.revolutions;
  step.repeatability_um = analysis.table.repeatability_um;
  step.degree_name = "pin degree";
  step.part_name = "pin";
  return learning_step(step, correction_in_force_um, settings);
}

}  // namespace gaugeloop
