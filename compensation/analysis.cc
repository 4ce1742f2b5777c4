// Averaging revolutions in the cam frame and comparing the averaged lobe with its design.
#include "compensation/analysis.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <complex>
#include <limits>
#include <numbers>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Dense>
#include <unsupported/Eigen/FFT>

#include "compensation/inspection.h"
#include "compensation/least_squares.h"
#include "compensation/message_text.h"
#include "compensation/thread_fft.h"
#include "core/angles.h"

namespace gaugeloop {
namespace {

constexpr int kMinRevolutions = 3;
constexpr double kWholeDegreeTolerance = 1e-9;
constexpr double kBaseCircleToleranceMm = 1e-3;  // 1 um
// Runout: base-circle degrees must have the design within 1 um for this many degrees either
// side, and at least kMinEroded such degrees, else the margin is dropped.
constexpr int kRampMarginDeg = 3;
constexpr int kMinEroded = 20;
// Phase: Gauss-Newton stops below this step; a design whose slope sum is below kNoSlope
// (mm^2/deg^2 over the turn) is round.
constexpr int kMaxPhaseIterations = 50;
constexpr double kPhaseToleranceDeg = 1e-9;
constexpr double kNoSlope = 1e-12;
// Phase: the last Gauss-Newton step may be extrapolated (see best_rotation_deg) when it is
// below kExtrapolateDeg and the ratio of steps below kExtrapolateRatio.
constexpr double kExtrapolateDeg = 1e-5;
constexpr double kExtrapolateRatio = 0.1;

// cos and sin of every whole degree, computed once (thread-safe static initialisation).
struct DegreeTrig {
  std::array<double, kDegrees> cos{};
  std::array<double, kDegrees> sin{};
};
const DegreeTrig& degree_trig() {
  static const DegreeTrig trig = [] {
    DegreeTrig t;
    for (size_t d = 0; d < kDegrees; ++d) {
      t.cos[d] = std::cos(static_cast<double>(d) * kRadPerDeg);
      t.sin[d] = std::sin(static_cast<double>(d) * kRadPerDeg);
    }
    return t;
  }();
  return trig;
}

// Brings every revolution into the cam frame, one value per whole cam degree.
Result<std::vector<DegreeTable>> to_cam_frame(const MeasuredRun& run, const Part& part, const DesignReading& design) {
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
  // Fractional offsets: interpolate each revolution periodically in the cam frame. What is
  // interpolated is the reading less the design's there (design.at: exact, corners and all),
  // so only the error, which is smooth, is interpolated, and the design is added back at
  // whole degrees from its table.
  std::vector<size_t> order(kDegrees);
  for (size_t c = 0; c < kDegrees; ++c) order[c] = c;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return beta[a] < beta[b]; });
  std::vector<double> angle(kDegrees);
  std::vector<double> value(kDegrees);
  for (size_t k = 0; k < kDegrees; ++k) angle[k] = beta[order[k]];
  for (size_t r = 0; r < run.revolutions.size(); ++r) {
    for (size_t k = 0; k < kDegrees; ++k) value[k] = run.revolutions[r].lift_mm[order[k]] - design.at(angle[k]);
    Result<PeriodicSpline> spline = PeriodicSpline::fit(angle, value);
    if (!spline.ok()) {
      return make_error(ErrorCode::kInternal, "analysis: resampling revolution " +
                                                  std::to_string(run.revolutions[r].revolution) +
                                                  " into the cam frame: " + spline.error().message);
    }
    for (size_t d = 0; d < kDegrees; ++d) cam[r][d] = spline->value(static_cast<double>(d)) + design.table()[d];
  }
  return cam;
}

size_t wrap_degree(int d) {
  return static_cast<size_t>(((d % kDegreesPerRevolution) + kDegreesPerRevolution) % kDegreesPerRevolution);
}

// error ~ zero + cos_um cos(theta) + sin_um sin(theta) on the base circle (see
// fit_base_circle_runout for which degrees).
struct BaseCircleHarmonic {
  double zero_um = 0.0;
  double cos_um = 0.0;
  double sin_um = 0.0;
  int degrees_used = 0;  // 0: no base circle, all 0
};

BaseCircleHarmonic fit_base_circle_harmonic(const DegreeTable& error_um, const DegreeTable& design_lift_mm) {
  // Base-circle degrees, eroded by the ramp margin; without the margin if too few remain.
  std::vector<bool> on_base(kDegrees);
  for (size_t d = 0; d < kDegrees; ++d) on_base[d] = std::abs(design_lift_mm[d]) <= kBaseCircleToleranceMm;
  std::vector<int> used;
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    bool all = true;
    for (int k = -kRampMarginDeg; k <= kRampMarginDeg && all; ++k) all = on_base[wrap_degree(d + k)];
    if (all) used.push_back(d);
  }
  if (used.size() < static_cast<size_t>(kMinEroded)) {
    used.clear();
    for (int d = 0; d < kDegreesPerRevolution; ++d) {
      if (on_base[static_cast<size_t>(d)]) used.push_back(d);
    }
  }
  BaseCircleHarmonic out;
  if (used.size() < 3) return out;
  // Least squares by QR: on a short arc the columns are nearly dependent, and QR keeps what
  // accuracy there is.
  Eigen::MatrixXd a(static_cast<Eigen::Index>(used.size()), 3);
  Eigen::VectorXd b(static_cast<Eigen::Index>(used.size()));
  const DegreeTrig& trig = degree_trig();
  for (size_t i = 0; i < used.size(); ++i) {
    const size_t deg = static_cast<size_t>(used[i]);
    const Eigen::Index row = static_cast<Eigen::Index>(i);
    a(row, 0) = 1.0;
    a(row, 1) = trig.cos[deg];
    a(row, 2) = trig.sin[deg];
    b(row) = error_um[static_cast<size_t>(used[i])];
  }
  const Eigen::VectorXd c = least_squares(a, b);
  out.zero_um = c(0);
  out.cos_um = c(1);
  out.sin_um = c(2);
  out.degrees_used = static_cast<int>(used.size());
  return out;
}

// The measurement with the base-circle first harmonic and zero taken out, for the phase fit:
// mean - (zero + e cos(theta - theta0)) / 1000, `fit` taken on mean - design.
DegreeTable without_base_circle_eccentricity(const DegreeTable& mean_mm, const BaseCircleHarmonic& fit) {
  const DegreeTrig& trig = degree_trig();
  DegreeTable shifted = mean_mm;
  for (size_t d = 0; d < kDegrees; ++d) {
    shifted[d] -= (fit.zero_um + fit.cos_um * trig.cos[d] + fit.sin_um * trig.sin[d]) / 1000.0;
  }
  return shifted;
}

// The base-circle fit of mean - design.
BaseCircleHarmonic base_circle_harmonic_of(const DegreeTable& mean_mm, const DegreeTable& design_mm) {
  DegreeTable error_um{};
  for (size_t d = 0; d < kDegrees; ++d) error_um[d] = (mean_mm[d] - design_mm[d]) * 1000.0;
  return fit_base_circle_harmonic(error_um, design_mm);
}

// The rotation phi (deg, in (-180, 180]) for which mean(theta) ~ design(theta - phi) in
// least squares, the mean with its base-circle eccentricity (`base`, fitted on
// mean - design) removed; nullopt when the design has no slope.
std::optional<double> best_rotation_deg(const DegreeTable& mean_mm, const BaseCircleHarmonic& base,
                                        const DesignReading& design) {
  const DegreeTable& design_mm = design.table();
  const DegreeTable target = without_base_circle_eccentricity(mean_mm, base);
  // Coarse: the whole-degree shift k maximising sum_d target[d] design[d - k], i.e. the
  // inverse transform of T conj(D). With both tables zeroed on the base circle that is the
  // least-squares shift on the whole-degree grid.
  Eigen::FFT<double>& fft = thread_fft();
  const std::vector<double> t(target.begin(), target.end());
  const std::vector<double> s(design_mm.begin(), design_mm.end());
  std::vector<std::complex<double>> tf;
  std::vector<std::complex<double>> sf;
  fft.fwd(tf, t);
  fft.fwd(sf, s);
  for (size_t k = 0; k < tf.size(); ++k) tf[k] *= std::conj(sf[k]);
  std::vector<double> correlation;
  fft.inv(correlation, tf);
  const size_t best =
      static_cast<size_t>(std::max_element(correlation.begin(), correlation.end()) - correlation.begin());
  double phi = best > kDegrees / 2 ? static_cast<double>(best) - 360.0 : static_cast<double>(best);

  // Fine: Gauss-Newton on r(theta) = target(theta) - design(theta - phi), dr/dphi =
  // design'(theta - phi) per degree; a step that does not lower the sum of squares is halved.
  struct Pass {
    double squares = 0.0;
    double rj = 0.0;
    double jj = 0.0;
  };
  auto pass = [&](double p) {
    Pass out;
    for (int d = 0; d < kDegreesPerRevolution; ++d) {
      const DesignReading::Sample at = design.sample(d - p);
      const double r = target[static_cast<size_t>(d)] - at.reading_mm;
      const double j = at.slope_mm_per_deg;
      out.squares += r * r;
      out.rj += r * j;
      out.jj += j * j;
    }
    return out;
  };
  Pass current = pass(phi);
  if (!(current.jj > kNoSlope)) return std::nullopt;
  double last_full_step = 0.0;  // the previous step if taken whole, else 0
  for (int iter = 0; iter < kMaxPhaseIterations; ++iter) {
    double step = -current.rj / current.jj;
    if (std::abs(step) < kPhaseToleranceDeg) break;  // converged; below this, rounding rules
    // Gauss-Newton converges linearly here (the residual is not zero), at a steady ratio
    // rho of one step to the last (-3e-3 on the exhaust roller, 2e-5 on a lobe only turned).
    // Once the step it would take next, step * rho, is below the tolerance, this step and
    // the rest of the geometric series, step / (1 - rho), are taken without the pass that
    // would only confirm convergence: what is left is ~ step rho^2, below the tolerance.
    // Only for small steps (kExtrapolateDeg), whose descent need not be checked.
    if (last_full_step != 0.0 && std::abs(step) < kExtrapolateDeg) {
      const double rho = step / last_full_step;
      if (std::abs(rho) < kExtrapolateRatio && std::abs(step * rho) < kPhaseToleranceDeg) {
        phi += step / (1.0 - rho);
        break;
      }
    }
    bool accepted = false;
    last_full_step = step;
    for (int halving = 0; halving < 30 && !accepted && std::abs(step) >= kPhaseToleranceDeg; ++halving) {
      const Pass next = pass(phi + step);
      if (next.squares <= current.squares && next.jj > kNoSlope) {
        phi += step;
        current = next;
        accepted = true;
      } else {
        step *= 0.5;
        last_full_step = 0.0;
      }
    }
    if (!accepted) break;  // no descent left: at the minimum to rounding
  }
  phi = std::remainder(phi, 360.0);
  if (phi <= -180.0) phi += 360.0;
  return phi;
}

}  // namespace

std::string base_circle_window_text(const AnalysisSettings& settings) {
  const double center = settings.base_circle_center_deg;
  const double half = settings.base_circle_half_width_deg;
  return format_fixed(center - half, 1) + " to " + format_fixed(center + half, 1) + " deg";
}

Result<std::vector<size_t>> base_circle_window_degrees(const AnalysisSettings& settings, std::string_view who) {
  const double center = settings.base_circle_center_deg;
  const double half = settings.base_circle_half_width_deg;
  if (!std::isfinite(center) || !std::isfinite(half) || half <= 0.0 || half >= 180.0) {
    return make_error(ErrorCode::kInvalidInput, std::string(who) + ": base-circle window centre " +
                                                    format_fixed(center, 3) + " deg, half width " +
                                                    format_fixed(half, 3) +
                                                    " deg; give a finite centre and a half width in (0, 180) deg");
  }
  std::vector<size_t> degrees;
  for (size_t d = 0; d < kDegrees; ++d) {
    double offset = std::fmod(static_cast<double>(d) - center, 360.0);
    if (offset > 180.0) offset -= 360.0;
    if (offset < -180.0) offset += 360.0;
    if (std::abs(offset) <= half + 1e-9) degrees.push_back(d);
  }
  if (degrees.empty()) {
    return make_error(ErrorCode::kInvalidInput, std::string(who) + ": the base-circle window " +
                                                    base_circle_window_text(settings) +
                                                    " holds no whole cam degree; widen base_circle_half_width_deg");
  }
  return degrees;
}

Result<LobeAnalysis> analyse_lobe(const MeasuredRun& run, const DegreeTable& design_lift_mm, const Part& part,
                                  const AnalysisSettings& settings) {
  return analyse_lobe(run, DesignReading::interpolating(design_lift_mm), part, settings);
}

namespace {

// The lift error left after turning the design by phi: (mean(theta) - design(theta - phi)).
PhaseFit residual_after_rotation(const DegreeTable& mean_lift_mm, const DesignReading& design, double phi) {
  PhaseFit fit;
  fit.phase_error_deg = phi;
  double squares = 0.0;
  double lowest = std::numeric_limits<double>::infinity();
  double highest = -std::numeric_limits<double>::infinity();
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    const size_t i = static_cast<size_t>(d);
    const double r = (mean_lift_mm[i] - design.at(d - phi)) * 1000.0;
    fit.residual_error_um[i] = r;
    fit.max_abs_residual_um = std::max(fit.max_abs_residual_um, std::abs(r));
    squares += r * r;
    lowest = std::min(lowest, r);
    highest = std::max(highest, r);
  }
  fit.rms_residual_um = std::sqrt(squares / kDegreesPerRevolution);
  fit.peak_to_valley_residual_um = highest - lowest;
  return fit;
}

}  // namespace

Result<LobeAnalysis> analyse_lobe(const MeasuredRun& run, const DesignReading& design, const Part& part,
                                  const AnalysisSettings& settings) {
  const DegreeTable& design_lift_mm = design.table();
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
  Result<std::vector<size_t>> window = base_circle_window_degrees(settings, "analysis");
  if (!window) return window.error();
  std::vector<bool> in_window(kDegrees, false);
  for (size_t d : *window) in_window[d] = true;
  const int window_count = static_cast<int>(window->size());
  const std::string window_text = base_circle_window_text(settings);
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

  Result<std::vector<DegreeTable>> cam = to_cam_frame(run, part, design);
  if (!cam.ok()) return cam.error();

  LobeAnalysis a;
  a.design_lift_mm = design_lift_mm;
  a.revolutions = static_cast<int>(cam->size());
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

  const BaseCircleHarmonic base = fit_base_circle_harmonic(a.error_um, design_lift_mm);
  a.base_circle_runout_um = 2.0 * std::hypot(base.cos_um, base.sin_um);
  // A round design has no timing to report: 0.
  a.phase_error_deg = best_rotation_deg(a.mean_lift_mm, base, design).value_or(0.0);
  a.harmonic_amplitude_um = harmonic_amplitudes_um(a.error_um);
  const PhaseFit fit = residual_after_rotation(a.mean_lift_mm, design, a.phase_error_deg);
  a.residual_error_um = fit.residual_error_um;
  a.max_abs_residual_um = fit.max_abs_residual_um;
  a.rms_residual_um = fit.rms_residual_um;
  a.peak_to_valley_residual_um = fit.peak_to_valley_residual_um;
  // A window of fewer than 3 whole degrees has no roundness to tell: both stay 0.
  if (Result<BaseCircleInspection> circle = inspect_base_circle(a.error_um, settings)) {
    a.dial_runout_um = circle->dial_runout_um;
    a.roundness_um = circle->roundness_um;
  }
  return a;
}

Result<PhaseFit> fit_phase_error(const LobeAnalysis& analysis, double max_phase_deg) {
  return fit_phase_error(analysis, DesignReading::interpolating(analysis.design_lift_mm), max_phase_deg);
}

Result<PhaseFit> fit_phase_error(const LobeAnalysis& analysis, const DesignReading& design, double max_phase_deg) {
  const std::optional<double> phi =
      best_rotation_deg(analysis.mean_lift_mm, base_circle_harmonic_of(analysis.mean_lift_mm, design.table()), design);
  if (!phi) {
    return make_error(ErrorCode::kInvalidInput,
                      "phase fit: the design lift has no slope to align on (a round lobe); no "
                      "phase error to report");
  }
  if (!(std::abs(*phi) <= max_phase_deg)) {
    return make_error(ErrorCode::kRefused, "phase fit: the lobe appears rotated by " + format_fixed(*phi, 3) +
                                               " deg, more than the " + format_fixed(max_phase_deg, 3) +
                                               " deg accepted; check the clamping, c_offset_deg "
                                               "and probe_offset_deg before compensating");
  }
  return residual_after_rotation(analysis.mean_lift_mm, design, *phi);
}

BaseCircleRunout fit_base_circle_runout(const DegreeTable& error_um, const DegreeTable& design_lift_mm) {
  const BaseCircleHarmonic fit = fit_base_circle_harmonic(error_um, design_lift_mm);
  BaseCircleRunout out;
  if (fit.degrees_used == 0) return out;
  out.eccentricity_um = std::hypot(fit.cos_um, fit.sin_um);
  out.runout_um = 2.0 * out.eccentricity_um;
  double high = std::atan2(fit.sin_um, fit.cos_um) / kRadPerDeg;
  if (high < 0.0) high += 360.0;
  out.high_point_deg = high;
  out.degrees_used = fit.degrees_used;
  return out;
}

DegreeFigures degree_figures(const DegreeTable& values) {
  DegreeFigures f;
  double squares = 0.0;
  double lowest = values[0];
  double highest = values[0];
  for (double v : values) {
    f.max_abs = std::max(f.max_abs, std::abs(v));
    squares += v * v;
    lowest = std::min(lowest, v);
    highest = std::max(highest, v);
  }
  f.rms = std::sqrt(squares / static_cast<double>(values.size()));
  f.peak_to_valley = highest - lowest;
  return f;
}

std::array<double, 31> harmonic_amplitudes_um(const DegreeTable& values_um) {
  Eigen::FFT<double>& fft = thread_fft();
  const std::vector<double> in(values_um.begin(), values_um.end());
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, in);
  std::array<double, 31> amplitude{};
  const double n = static_cast<double>(kDegreesPerRevolution);
  amplitude[0] = std::abs(spectrum[0]) / n;
  // A real table's harmonic k lives in bins k and N - k with equal magnitude: 2 |X_k| / N.
  for (size_t k = 1; k < amplitude.size(); ++k) amplitude[k] = 2.0 * std::abs(spectrum[k]) / n;
  return amplitude;
}

Eigen::FFT<double>& thread_fft() {
  thread_local Eigen::FFT<double> fft;
  return fft;
}

}  // namespace gaugeloop
