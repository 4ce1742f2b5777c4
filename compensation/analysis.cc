// Averaging revolutions in the cam frame and comparing the averaged lobe with its design.
#include "compensation/analysis.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "compensation/message_text.h"

namespace gaugeloop {
namespace {

constexpr size_t kDegrees = static_cast<size_t>(kDegreesPerRevolution);
constexpr int kMinRevolutions = 3;
constexpr double kWholeDegreeTolerance = 1e-9;
constexpr double kBaseCircleToleranceMm = 1e-3;  // 1 um

// Brings every revolution into the cam frame, one value per whole cam degree.
Result<std::vector<DegreeTable>> to_cam_frame(const MeasuredRun& run, const Part& part) {
  std::vector<double> beta(kDegrees);
  bool whole = true;
  for (size_t c = 0; c < kDegrees; ++c) {
    beta[c] = cam_angle_at_probe_deg(part, static_cast<double>(c));
    if (std::abs(beta[c] - std::round(beta[c])) > kWholeDegreeTolerance) whole = false;
  }
  std::vector<DegreeTable> cam(run.revolutions.size());
  if (whole) {
    // A permutation of the degrees: sense +-1 and whole-degree offsets.
    std::vector<size_t> target(kDegrees);
    std::vector<bool> hit(kDegrees, false);
    for (size_t c = 0; c < kDegrees; ++c) {
      target[c] = static_cast<size_t>(std::lround(beta[c])) % kDegrees;
      if (hit[target[c]]) {
        return make_error(ErrorCode::kInternal, "analysis: machine degrees do not map one to one onto cam degrees");
      }
      hit[target[c]] = true;
    }
    for (size_t r = 0; r < run.revolutions.size(); ++r) {
      for (size_t c = 0; c < kDegrees; ++c) cam[r][target[c]] = run.revolutions[r].lift_mm[c];
    }
    return cam;
  }
  // Fractional offsets: interpolate each revolution periodically in the cam frame.
  std::vector<size_t> order(kDegrees);
  for (size_t c = 0; c < kDegrees; ++c) order[c] = c;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return beta[a] < beta[b]; });
  std::vector<double> angle(kDegrees);
  std::vector<double> value(kDegrees);
  for (size_t k = 0; k < kDegrees; ++k) angle[k] = beta[order[k]];
  for (size_t r = 0; r < run.revolutions.size(); ++r) {
    for (size_t k = 0; k < kDegrees; ++k) value[k] = run.revolutions[r].lift_mm[order[k]];
    Result<PeriodicSpline> spline = PeriodicSpline::fit(angle, value);
    if (!spline.ok()) {
      return make_error(ErrorCode::kInternal, "analysis: resampling revolution " +
                                                  std::to_string(run.revolutions[r].revolution) +
                                                  " into the cam frame: " + spline.error().message);
    }
    for (size_t d = 0; d < kDegrees; ++d) cam[r][d] = spline->value(static_cast<double>(d));
  }
  return cam;
}

}  // namespace

Result<LobeAnalysis> analyse_lobe(const MeasuredRun& run, const DegreeTable& design_lift_mm, const Part& part,
                                  const AnalysisSettings& settings) {
  const int revolutions = static_cast<int>(run.revolutions.size());
  if (revolutions < kMinRevolutions) {
    return make_error(ErrorCode::kInvalidInput, "analysis: the run has " + std::to_string(revolutions) +
                                                    " complete revolution(s); at least " +
                                                    std::to_string(kMinRevolutions) +
                                                    " are needed to average and to judge repeatability; measure again");
  }
  if (part.rotation_sense != 1 && part.rotation_sense != -1) {
    return make_error(ErrorCode::kInvalidInput, "part '" + part.name + "': rotation_sense is " +
                                                    std::to_string(part.rotation_sense) + "; it must be +1 or -1");
  }
  if (!std::isfinite(part.c_offset_deg) || !std::isfinite(part.probe_offset_deg)) {
    return make_error(ErrorCode::kInvalidInput,
                      "part '" + part.name + "': c_offset_deg and probe_offset_deg must be finite");
  }
  for (const RevolutionSamples& rev : run.revolutions) {
    for (size_t c = 0; c < kDegrees; ++c) {
      if (!std::isfinite(rev.lift_mm[c])) {
        return make_error(ErrorCode::kInvalidInput, "analysis: revolution " + std::to_string(rev.revolution) +
                                                        " has no valid reading at machine degree " + std::to_string(c) +
                                                        "; discard the run and measure again");
      }
    }
  }
  for (size_t d = 0; d < kDegrees; ++d) {
    if (!std::isfinite(design_lift_mm[d])) {
      return make_error(ErrorCode::kInvalidInput,
                        "analysis: the design lift at cam degree " + std::to_string(d) + " is NaN or infinite");
    }
  }
  const double center = settings.base_circle_center_deg;
  const double half = settings.base_circle_half_width_deg;
  if (!std::isfinite(center) || !std::isfinite(half) || half <= 0.0 || half >= 180.0) {
    return make_error(ErrorCode::kInvalidInput, "analysis: base-circle window centre " + format_fixed(center, 3) +
                                                    " deg, half width " + format_fixed(half, 3) +
                                                    " deg; give a finite centre and a half width in (0, 180) deg");
  }
  std::vector<bool> in_window(kDegrees, false);
  int window_count = 0;
  for (size_t d = 0; d < kDegrees; ++d) {
    double offset = std::fmod(static_cast<double>(d) - center, 360.0);
    if (offset > 180.0) offset -= 360.0;
    if (offset < -180.0) offset += 360.0;
    if (std::abs(offset) <= half + 1e-9) {
      in_window[d] = true;
      ++window_count;
    }
  }
  const std::string window_text = format_fixed(center - half, 1) + " to " + format_fixed(center + half, 1) + " deg";
  if (window_count == 0) {
    return make_error(ErrorCode::kInvalidInput, "analysis: the base-circle window " + window_text +
                                                    " holds no whole cam degree; widen base_circle_half_width_deg");
  }
  std::vector<bool> off_base(kDegrees, false);
  bool any_off = false;
  double worst_mm = 0.0;
  size_t worst_deg = 0;
  for (size_t d = 0; d < kDegrees; ++d) {
    if (in_window[d] && std::abs(design_lift_mm[d]) > kBaseCircleToleranceMm) {
      off_base[d] = any_off = true;
      if (std::abs(design_lift_mm[d]) > std::abs(worst_mm)) {
        worst_mm = design_lift_mm[d];
        worst_deg = d;
      }
    }
  }
  if (any_off) {
    std::vector<double> degrees(kDegrees);
    for (size_t d = 0; d < kDegrees; ++d) degrees[d] = static_cast<double>(d);
    return make_error(ErrorCode::kInvalidInput,
                      "analysis: the base-circle window " + window_text +
                          " (cam frame) is not on the base circle: the design lift exceeds 1 um at cam degree " +
                          describe_angle_ranges(degrees, off_base) + " (" + format_fixed(worst_mm * 1000.0, 1) +
                          " um at " + std::to_string(worst_deg) +
                          " deg); move base_circle_center_deg / base_circle_half_width_deg onto the base circle");
  }

  Result<std::vector<DegreeTable>> cam = to_cam_frame(run, part);
  if (!cam.ok()) return cam.error();

  LobeAnalysis a;
  a.design_lift_mm = design_lift_mm;
  DegreeTable mean{};
  for (size_t d = 0; d < kDegrees; ++d) {
    double sum = 0.0;
    for (const DegreeTable& rev : *cam) sum += rev[d];
    mean[d] = sum / revolutions;
    double squares = 0.0;
    for (const DegreeTable& rev : *cam) squares += (rev[d] - mean[d]) * (rev[d] - mean[d]);
    a.spread_um[d] = std::sqrt(squares / (revolutions - 1)) * 1000.0;
  }
  double window_sum = 0.0;
  for (size_t d = 0; d < kDegrees; ++d) {
    if (in_window[d]) window_sum += mean[d];
  }
  a.zero_offset_mm = window_sum / window_count;

  double squares = 0.0;
  double lowest = std::numeric_limits<double>::infinity();
  double highest = -std::numeric_limits<double>::infinity();
  for (size_t d = 0; d < kDegrees; ++d) {
    a.mean_lift_mm[d] = mean[d] - a.zero_offset_mm;
    const double e = (a.mean_lift_mm[d] - design_lift_mm[d]) * 1000.0;
    a.error_um[d] = e;
    a.max_abs_error_um = std::max(a.max_abs_error_um, std::abs(e));
    squares += e * e;
    lowest = std::min(lowest, e);
    highest = std::max(highest, e);
    a.repeatability_um = std::max(a.repeatability_um, a.spread_um[d]);
  }
  a.rms_error_um = std::sqrt(squares / kDegreesPerRevolution);
  a.peak_to_valley_um = highest - lowest;
  return a;
}

Result<PhaseFit> fit_phase_error(const LobeAnalysis& analysis, double max_phase_deg) {
  const PeriodicSpline design = PeriodicSpline::fit(analysis.design_lift_mm);
  constexpr double kRadPerDeg = std::numbers::pi / 180.0;
  double phi = 0.0;
  for (int iter = 0; iter < 50; ++iter) {
    // r(theta) = mean(theta) - design(theta - phi); dr/dphi = design'(theta - phi) per degree.
    double rj = 0.0;
    double jj = 0.0;
    for (int d = 0; d < kDegreesPerRevolution; ++d) {
      const double r = analysis.mean_lift_mm[static_cast<size_t>(d)] - design.value(d - phi);
      const double j = design.d1(d - phi) * kRadPerDeg;
      rj += r * j;
      jj += j * j;
    }
    if (!(jj > 1e-12)) {
      return make_error(ErrorCode::kInvalidInput,
                        "phase fit: the design lift has no slope to align on (a round lobe); no "
                        "phase error to report");
    }
    const double step = -rj / jj;
    phi += step;
    if (!(std::abs(phi) <= 90.0)) break;
    if (std::abs(step) < 1e-12) break;
  }
  if (!(std::abs(phi) <= max_phase_deg)) {
    return make_error(ErrorCode::kRefused, "phase fit: the lobe appears rotated by " + format_fixed(phi, 3) +
                                               " deg, more than the " + format_fixed(max_phase_deg, 3) +
                                               " deg accepted; check the clamping, c_offset_deg "
                                               "and probe_offset_deg before compensating");
  }
  PhaseFit fit;
  fit.phase_error_deg = phi;
  double squares = 0.0;
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    const size_t i = static_cast<size_t>(d);
    fit.residual_error_um[i] = (analysis.mean_lift_mm[i] - design.value(d - phi)) * 1000.0;
    squares += fit.residual_error_um[i] * fit.residual_error_um[i];
  }
  fit.rms_residual_um = std::sqrt(squares / kDegreesPerRevolution);
  return fit;
}

double first_harmonic_runout_um(const DegreeTable& error_um) {
  std::complex<double> c1 = 0.0;
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    const double theta = d * std::numbers::pi / 180.0;
    c1 += error_um[static_cast<size_t>(d)] * std::complex<double>(std::cos(theta), -std::sin(theta));
  }
  // Amplitude of the first harmonic is 2 |c1| / N; the indicator swings twice that.
  return 2.0 * (2.0 * std::abs(c1) / kDegreesPerRevolution);
}

}  // namespace gaugeloop
