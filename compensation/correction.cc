// Smoothing, the learning-control update with its guards, and the corrected wheel path.
#include "compensation/correction.h"

#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <vector>

#include <unsupported/Eigen/FFT>

#include "compensation/cam_geometry.h"
#include "compensation/message_text.h"
#include "compensation/periodic_spline.h"
#include "compensation/polar_support.h"

namespace gaugeloop {
namespace {

constexpr size_t kDegrees = static_cast<size_t>(kDegreesPerRevolution);
constexpr int kNyquist = kDegreesPerRevolution / 2;

// A cam surface point lies on the convex hull when the support in its normal direction is
// attained there: within this of the point's own normal distance from the axis.
constexpr double kHullToleranceMm = 1e-6;

}  // namespace

DegreeTable smooth_harmonics(const DegreeTable& values, int max_harmonic) {
  if (max_harmonic >= kNyquist) return values;
  DegreeTable out{};
  if (max_harmonic < 0) return out;
  Eigen::FFT<double> fft;
  const std::vector<double> in(values.begin(), values.end());
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, in);  // full spectrum, N bins
  // Harmonic k lives in bins k and N - k; keep 0..max_harmonic and their mirrors.
  for (size_t k = static_cast<size_t>(max_harmonic) + 1; k + static_cast<size_t>(max_harmonic) < kDegrees; ++k) {
    spectrum[k] = 0.0;
  }
  std::vector<double> smoothed;
  fft.inv(smoothed, spectrum);
  for (size_t d = 0; d < kDegrees; ++d) out[d] = smoothed[d];
  return out;
}

Result<DegreeTable> next_correction(const LobeAnalysis& analysis, const DegreeTable& correction_in_force_um,
                                    const CompensationSettings& s) {
  if (!(s.gain > 0.0 && s.gain <= 1.0)) {
    return make_error(ErrorCode::kRefused,
                      "compensation: gain " + format_fixed(s.gain, 3) +
                          " is outside (0, 1]; a gain above 1 overshoots and can diverge, 0 or below "
                          "does nothing or the opposite; set a gain in (0, 1]");
  }
  if (s.max_harmonic < 0 || s.max_harmonic > kNyquist) {
    return make_error(ErrorCode::kInvalidInput,
                      "compensation: max_harmonic " + std::to_string(s.max_harmonic) + " is outside [0, 180]");
  }
  if (!(s.max_correction_um > 0.0)) {
    return make_error(ErrorCode::kInvalidInput,
                      "compensation: max_correction_um " + format_fixed(s.max_correction_um, 3) + " must be positive");
  }
  for (size_t d = 0; d < kDegrees; ++d) {
    if (!std::isfinite(analysis.error_um[d]) || !std::isfinite(correction_in_force_um[d])) {
      return make_error(ErrorCode::kInvalidInput,
                        "compensation: NaN or infinity in the error or in the "
                        "correction in force at cam degree " +
                            std::to_string(d));
    }
  }
  const DegreeTable smooth = smooth_harmonics(analysis.error_um, s.max_harmonic);
  DegreeTable next{};
  size_t worst = 0;
  for (size_t d = 0; d < kDegrees; ++d) {
    next[d] = correction_in_force_um[d] + s.gain * smooth[d];
    if (std::abs(next[d]) > std::abs(next[worst])) worst = d;
  }
  if (std::abs(next[worst]) > s.max_correction_um) {
    return make_error(ErrorCode::kRefused,
                      "compensation: the correction would reach " + format_fixed(next[worst], 1) +
                          " um at cam degree " + std::to_string(worst) + ", beyond the " +
                          format_fixed(s.max_correction_um, 1) +
                          " um allowed; check the measurement and the setup, or have an operator approve it");
  }
  return next;
}

Result<WheelPath> corrected_wheel_path(const LiftTable& design, const DegreeTable& correction_um, const Part& part,
                                       double step_deg) {
  for (size_t d = 0; d < kDegrees; ++d) {
    if (!std::isfinite(correction_um[d])) {
      return make_error(ErrorCode::kInvalidInput, "corrected wheel path: the correction at cam degree " +
                                                      std::to_string(d) + " is NaN or infinite");
    }
  }
  Result<PeriodicSpline> lift = PeriodicSpline::fit(design.angle_deg, design.lift_mm);
  if (!lift.ok()) {
    return make_error(lift.error().code, "design lift table '" + design.source + "': " + lift.error().message);
  }
  Result<FollowerGeometry> geometry = follower_geometry(part);
  if (!geometry.ok()) return geometry.error();
  const FollowerGeometry& g = geometry.value();

  const PeriodicSpline correction = PeriodicSpline::fit(correction_um);
  const size_t n = design.angle_deg.size();
  std::vector<double> lift_correction_um(n, 0.0);
  if (g.kind == FollowerKind::kFlat) {
    for (size_t i = 0; i < n; ++i) lift_correction_um[i] = correction.value(design.angle_deg[i]);
  } else {
    if (Status shape = check_lobe_shape(*lift, g); !shape.ok()) return shape.error();
    const double rb = g.base_circle_radius_mm;
    const double rr = g.roller_radius_mm;
    const PolarSupport pitch(*lift, rb + rr);
    std::vector<double> hull_angle;
    std::vector<double> hull_value;
    std::vector<bool> on_hull(n, false);
    for (size_t i = 0; i < n; ++i) {
      const double beta = design.angle_deg[i];
      const double rho = rb + rr + lift->value(beta);
      const double alpha = std::atan(lift->d1(beta) / rho);
      const double normal_deg = beta - alpha * 180.0 / std::numbers::pi;
      // rho cos(alpha) is this point's distance from the axis along its own normal.
      if (pitch.at(normal_deg).support_mm - rho * std::cos(alpha) < kHullToleranceMm) {
        on_hull[i] = true;
        lift_correction_um[i] = correction.value(normal_deg) / std::cos(alpha);
        hull_angle.push_back(beta);
        hull_value.push_back(lift_correction_um[i]);
      }
    }
    if (hull_angle.size() < n) {
      Result<PeriodicSpline> bridge = PeriodicSpline::fit(hull_angle, hull_value);
      if (!bridge.ok()) {
        return make_error(ErrorCode::kRefused, "corrected wheel path: too few points of the lobe of part '" +
                                                   part.name + "' touch a flat probe to carry a correction");
      }
      for (size_t i = 0; i < n; ++i) {
        if (!on_hull[i]) lift_correction_um[i] = bridge->value(design.angle_deg[i]);
      }
    }
  }
  std::vector<double> target(n);
  for (size_t i = 0; i < n; ++i) target[i] = design.lift_mm[i] - lift_correction_um[i] / 1000.0;
  Result<PeriodicSpline> target_lift = PeriodicSpline::fit(design.angle_deg, target);
  if (!target_lift.ok()) return target_lift.error();
  return compute_wheel_path(*target_lift, part, step_deg);
}

}  // namespace gaugeloop
