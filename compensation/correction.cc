// Smoothing, the learning-control update with its guards, and the corrected wheel path.
#include "compensation/correction.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <unsupported/Eigen/FFT>

#include "compensation/cam_geometry.h"
#include "compensation/message_text.h"
#include "compensation/periodic_spline.h"
#include "compensation/polar_support.h"

namespace gaugeloop {
namespace {

constexpr int kNyquist = kDegreesPerRevolution / 2;

// The design model and the analysis' design table must agree to this (mm): rounding only.
constexpr double kSameDesignMm = 1e-9;

// Contacts closer than this (degrees of follower angle) are one point.
constexpr double kSameContactDeg = 1e-9;

}  // namespace

DegreeTable smooth_harmonics(const DegreeTable& values, int max_harmonic) {
  if (max_harmonic >= kNyquist) return values;
  DegreeTable out{};
  if (max_harmonic < 0) return out;
  // Eigen's FFT keeps its plan (the twiddle factors) in the object: one per thread, reused.
  thread_local Eigen::FFT<double> fft;
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

HarmonicChoice choose_harmonics(const DegreeTable& error_um, const DegreeTable& spread_um, int revolutions, int cap,
                                double sigmas) {
  HarmonicChoice out;
  cap = std::clamp(cap, 0, kNyquist);
  double spread_squares = 0.0;
  for (double s : spread_um) spread_squares += s * s;
  const double mean_noise_um =
      revolutions >= 2 ? std::sqrt(spread_squares / static_cast<double>(kDegrees) / revolutions) : 0.0;
  out.noise_um = mean_noise_um * std::sqrt(2.0 / static_cast<double>(kDegrees));
  out.threshold_um = sigmas * out.noise_um;
  if (!(out.noise_um > 0.0)) {
    out.harmonics = cap;
    return out;
  }
  thread_local Eigen::FFT<double> fft;
  const std::vector<double> in(error_um.begin(), error_um.end());
  std::vector<std::complex<double>> spectrum;
  fft.fwd(spectrum, in);
  for (int k = 1; k <= cap; ++k) {
    // The amplitude of the cosine k theta + phase: 2 |X_k| / N (bins k and N - k together).
    const double amplitude_um = 2.0 * std::abs(spectrum[static_cast<size_t>(k)]) / static_cast<double>(kDegrees);
    if (amplitude_um > out.threshold_um) out.harmonics = k;
  }
  return out;
}

std::string_view compensation_verdict_name(CompensationVerdict verdict) {
  switch (verdict) {
    case CompensationVerdict::kApply:
      return "apply";
    case CompensationVerdict::kHold:
      return "hold";
    case CompensationVerdict::kRefuse:
      return "refuse";
  }
  return "refuse";
}

std::string CompensationDecision::reasons() const {
  std::string out;
  for (const GuardFinding& f : findings) {
    if (!out.empty()) out += "; ";
    out += f.reason;
  }
  return out;
}

Status check_compensation_settings(const CompensationSettings& s) {
  if (!(s.gain > 0.0 && s.gain <= 1.0)) {
    return make_error(ErrorCode::kInvalidInput,
                      "compensation: gain " + format_fixed(s.gain, 3) +
                          " is outside (0, 1]; a gain above 1 overshoots and can diverge, 0 or below "
                          "does nothing or the opposite; set a gain in (0, 1]");
  }
  if (s.max_harmonic < 0 || s.max_harmonic > kNyquist) {
    return make_error(ErrorCode::kInvalidInput,
                      "compensation: max_harmonic " + std::to_string(s.max_harmonic) + " is outside [0, 180]");
  }
  const std::pair<const char*, double> limits[] = {{"max_correction_um", s.max_correction_um},
                                                   {"max_change_um", s.max_change_um},
                                                   {"max_repeatability_um", s.max_repeatability_um},
                                                   {"max_phase_deg", s.max_phase_deg}};
  for (const auto& [name, value] : limits) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      return make_error(ErrorCode::kInvalidInput, std::string("compensation: ") + name + " " + format_fixed(value, 3) +
                                                      " must be a positive number");
    }
  }
  return {};
}

Result<CompensationDecision> learning_step(const LearningStep& step, const DegreeTable& in_force_um,
                                           const CompensationSettings& s) {
  if (Status settings = check_compensation_settings(s); !settings.ok()) return settings.error();
  for (size_t d = 0; d < kDegrees; ++d) {
    if (!std::isfinite(step.smoothed_part_um[d]) || !std::isfinite(step.exact_part_um[d]) ||
        !std::isfinite(in_force_um[d])) {
      return make_error(ErrorCode::kInvalidInput,
                        "compensation: NaN or infinity in the error or in the correction in force at " +
                            std::string(step.degree_name) + " " + std::to_string(signed_degree(d)));
    }
  }
  if (!std::isfinite(step.repeatability_um)) {
    return make_error(ErrorCode::kInvalidInput, "compensation: the analysis' repeatability is not a number");
  }

  CompensationDecision out;
  if (s.choose_harmonics) {
    out.harmonics = choose_harmonics(step.smoothed_part_um, step.spread_um, step.revolutions, s.max_harmonic);
  } else {
    out.harmonics.harmonics = s.max_harmonic;
  }
  const DegreeTable smooth = smooth_harmonics(step.smoothed_part_um, out.harmonics.harmonics);

  size_t worst_correction = 0;
  size_t worst_change = 0;
  size_t worst_form_change = 0;
  DegreeTable form_change_um{};
  for (size_t d = 0; d < kDegrees; ++d) {
    form_change_um[d] = s.gain * smooth[d];
    out.change_um[d] = form_change_um[d] + s.gain * step.exact_part_um[d];
    out.correction_um[d] = in_force_um[d] + out.change_um[d];
    if (std::abs(out.correction_um[d]) > std::abs(out.correction_um[worst_correction])) worst_correction = d;
    if (std::abs(out.change_um[d]) > std::abs(out.change_um[worst_change])) worst_change = d;
    if (std::abs(form_change_um[d]) > std::abs(form_change_um[worst_form_change])) worst_form_change = d;
  }
  out.largest_correction_um = out.correction_um[worst_correction];
  out.largest_correction_deg = signed_degree(worst_correction);
  out.largest_change_um = out.change_um[worst_change];
  out.largest_change_deg = signed_degree(worst_change);
  out.largest_form_change_um = form_change_um[worst_form_change];
  out.largest_form_change_deg = signed_degree(worst_form_change);

  const std::string degree(step.degree_name);
  if (std::abs(out.largest_correction_um) > s.max_correction_um) {
    out.findings.push_back({CompensationGuard::kCorrectionLimit, CompensationVerdict::kRefuse,
                            "the correction would reach " + format_fixed(out.largest_correction_um, 1) + " um at " +
                                degree + " " + std::to_string(out.largest_correction_deg) + ", beyond the " +
                                format_fixed(s.max_correction_um, 1) +
                                " um the wheel path may carry; check the measurement and the setup, or have an "
                                "operator raise the limit"});
  }
  if (std::abs(out.largest_form_change_um) > s.max_change_um) {
    out.findings.push_back({CompensationGuard::kChangeLimit, CompensationVerdict::kHold,
                            "the correction would move by " + format_fixed(out.largest_form_change_um, 1) + " um at " +
                                degree + " " + std::to_string(out.largest_form_change_deg) + " from the one in force" +
                                step.change_note + ", more than the " + format_fixed(s.max_change_um, 1) +
                                " um allowed from one part to the next; check the wheel (dressed, changed?) and "
                                "measure again, or have an operator approve it"});
  }
  if (step.repeatability_um > s.max_repeatability_um) {
    out.findings.push_back({CompensationGuard::kRepeatability, CompensationVerdict::kHold,
                            "the revolutions disagree by up to " + format_fixed(step.repeatability_um, 2) +
                                " um (largest per-degree standard deviation), more than the " +
                                format_fixed(s.max_repeatability_um, 2) +
                                " um a measurement to correct from may show; check the probe tip, coolant and "
                                "chips on the " +
                                std::string(step.part_name) + ", and the clamping, and measure again"});
  }
  settle_verdict(out);
  return out;
}

void settle_verdict(CompensationDecision& decision) {
  decision.verdict = CompensationVerdict::kApply;
  for (const GuardFinding& f : decision.findings) {
    if (f.verdict == CompensationVerdict::kRefuse || decision.verdict == CompensationVerdict::kApply)
      decision.verdict = f.verdict;
  }
}

namespace {

// The step both overloads share; `design` null: no phase part, the whole error is smoothed.
Result<CompensationDecision> decide(const LobeAnalysis& analysis, const DesignReading* design,
                                    const DegreeTable& in_force_um, const CompensationSettings& s) {
  // The settings first, as ever; a NaN in the error or the correction in force is
  // learning_step's to name (the design is finite, so it stays NaN in the remainder).
  if (Status settings = check_compensation_settings(s); !settings.ok()) return settings.error();
  const double phi = analysis.phase_error_deg;
  if (!std::isfinite(phi) || !std::isfinite(analysis.repeatability_um)) {
    return make_error(ErrorCode::kInvalidInput, "compensation: the analysis' phase or repeatability is not a number");
  }

  if (design != nullptr) {
    for (size_t d = 0; d < kDegrees; ++d) {
      if (!(std::abs(design->table()[d] - analysis.design_lift_mm[d]) <= kSameDesignMm)) {
        return make_error(ErrorCode::kInvalidInput,
                          "compensation: the design model does not read what the analysis was made against (cam "
                          "degree " +
                              std::to_string(d) + "); pass the DesignReading the analysis used");
      }
    }
  }

  // Fit the phase first, compensate the remainder.
  LearningStep step;
  step.spread_um = analysis.spread_um;
  step.revolutions = analysis.revolutions;
  step.repeatability_um = analysis.repeatability_um;
  if (design != nullptr && phi != 0.0) {
    for (size_t d = 0; d < kDegrees; ++d) {
      step.exact_part_um[d] = (design->at(static_cast<double>(d) - phi) - design->table()[d]) * 1000.0;
    }
    step.change_note =
        " (not counting the lobe's turn of " + format_fixed(phi, 3) + " deg, which max_phase_deg judges)";
  }
  for (size_t d = 0; d < kDegrees; ++d) step.smoothed_part_um[d] = analysis.error_um[d] - step.exact_part_um[d];
  Result<CompensationDecision> out = learning_step(step, in_force_um, s);
  if (!out.ok()) return out;
  if (std::abs(phi) > s.max_phase_deg) {
    out->findings.push_back({CompensationGuard::kPhase, CompensationVerdict::kHold,
                             "the lobe appears turned by " + format_fixed(phi, 3) + " deg, more than the " +
                                 format_fixed(s.max_phase_deg, 3) +
                                 " deg a correction may turn it; in-process that is more often a mis-set "
                                 "probe_offset_deg or a late gauge latch than the grinding: check them, or have an "
                                 "operator approve it"});
    settle_verdict(*out);
  }
  return out;
}

}  // namespace

Result<CompensationDecision> decide_correction(const LobeAnalysis& analysis, const DesignReading& design,
                                               const DegreeTable& correction_in_force_um,
                                               const CompensationSettings& settings) {
  return decide(analysis, &design, correction_in_force_um, settings);
}

Result<CompensationDecision> decide_correction(const LobeAnalysis& analysis, const DegreeTable& correction_in_force_um,
                                               const CompensationSettings& settings) {
  return decide(analysis, nullptr, correction_in_force_um, settings);
}

Result<DegreeTable> next_correction(const LobeAnalysis& analysis, const DegreeTable& correction_in_force_um,
                                    const CompensationSettings& s) {
  Result<CompensationDecision> decision = decide_correction(analysis, correction_in_force_um, s);
  if (!decision.ok()) return decision.error();
  if (!decision->apply()) {
    return make_error(ErrorCode::kRefused, std::string("the correction is ") +
                                               (decision->verdict == CompensationVerdict::kHold ? "held" : "refused") +
                                               ": " + decision->reasons());
  }
  return decision->correction_um;
}

namespace {

// The lift correction (um) at each knot of `design` of a roller or knife-edge lobe: the
// reading at probe angle theta is the support of the pitch curve there, less rr; it touches
// the pitch curve at polar angle beta (the follower angle), whose normal is theta = beta -
// alpha. So the correction at whole degree theta moves the follower at that contact by
// c(theta) / cos(alpha). Each whole degree is carried to its own contact (contacts[theta])
// and the lift corrections are interpolated in beta: where the probe bridges a concave
// flank, the bridge's two ends share one normal but take the correction from their own side
// of it (the correction may step there, as the reading's slope does), and the flank between
// them, which no probe touches, is interpolated.
Result<std::vector<double>> roller_lift_correction_um(const LiftTable& design, const DegreeTable& correction_um,
                                                      const std::vector<DesignReading::Contact>& contacts,
                                                      const Part& part) {
  std::vector<std::pair<double, double>> contact;  // (beta, lift correction um)
  contact.reserve(kDegrees);
  for (size_t d = 0; d < kDegrees; ++d) {
    contact.emplace_back(contacts[d].beta_deg, correction_um[d] / contacts[d].cos_pressure_angle);
  }
  std::sort(contact.begin(), contact.end());
  std::vector<double> beta_deg;
  std::vector<double> value_um;
  beta_deg.reserve(kDegrees);
  value_um.reserve(kDegrees);
  for (const auto& [beta, value] : contact) {
    // Two probe angles resting on one point (a corner of the pitch curve's hull sampled
    // twice) add nothing: keep the first.
    if (!beta_deg.empty() && beta - beta_deg.back() < kSameContactDeg) continue;
    beta_deg.push_back(beta);
    value_um.push_back(value);
  }
  Result<PeriodicSpline> spread = PeriodicSpline::fit(beta_deg, value_um);
  if (!spread.ok()) {
    return make_error(ErrorCode::kRefused, "corrected lift: too few points of the lobe of part '" + part.name +
                                               "' touch a flat probe to carry a correction");
  }
  const size_t n = design.angle_deg.size();
  std::vector<double> lift_correction_um(n);
  for (size_t i = 0; i < n; ++i) lift_correction_um[i] = spread->value(design.angle_deg[i]);
  return lift_correction_um;
}

Status check_finite(const DegreeTable& correction_um) {
  for (size_t d = 0; d < kDegrees; ++d) {
    if (!std::isfinite(correction_um[d])) {
      return make_error(ErrorCode::kInvalidInput, "corrected lift: the correction at cam degree " +
                                                      std::to_string(signed_degree(d)) + " is NaN or infinite");
    }
  }
  return {};
}

// design - lift correction / 1000 at the design's knots, as a spline through them.
Result<PeriodicSpline> target_lift(const LiftTable& design, const std::vector<double>& lift_correction_um) {
  const size_t n = design.angle_deg.size();
  std::vector<double> target(n);
  for (size_t i = 0; i < n; ++i) target[i] = design.lift_mm[i] - lift_correction_um[i] / 1000.0;
  return PeriodicSpline::fit(design.angle_deg, target);
}

}  // namespace

Result<PeriodicSpline> corrected_lift(const LiftTable& design, const DegreeTable& correction_um, const Part& part) {
  if (Status finite = check_finite(correction_um); !finite.ok()) return finite.error();
  Result<PeriodicSpline> lift = PeriodicSpline::fit(design.angle_deg, design.lift_mm);
  if (!lift.ok()) {
    return make_error(lift.error().code, "design lift table '" + design.source + "': " + lift.error().message);
  }
  Result<FollowerGeometry> geometry = follower_geometry(part);
  if (!geometry.ok()) return geometry.error();
  const FollowerGeometry& g = geometry.value();

  const size_t n = design.angle_deg.size();
  if (g.kind == FollowerKind::kFlat) {
    const PeriodicSpline correction = PeriodicSpline::fit(correction_um);
    std::vector<double> lift_correction_um(n);
    for (size_t i = 0; i < n; ++i) lift_correction_um[i] = correction.value(design.angle_deg[i]);
    return target_lift(design, lift_correction_um);
  }
  const double rb = g.base_circle_radius_mm;
  const double rr = g.roller_radius_mm;
  // The support function needs the lobe round the axis, rb + H > 0 (exact, piece by piece;
  // the sampled check says where). Undercut and a wheel too large are the wheel path's to
  // refuse, on the corrected lift, which is what will be ground.
  if (!(flat_lobe_minima(*lift, rb).support_mm > 0.0)) {
    if (Status shape = check_lobe_shape(*lift, g); !shape.ok()) return shape.error();
    return make_error(ErrorCode::kRefused, "corrected lift: the design lift of part '" + part.name +
                                               "' reaches below minus the base circle radius between the "
                                               "check's samples; check the lift table and base_circle_radius_mm");
  }
  // Where the probe at each whole degree rests (DesignReading::of_lobe keeps the same).
  const PolarSupport pitch(*lift, rb + rr);
  std::vector<DesignReading::Contact> contacts(kDegrees);
  for (size_t d = 0; d < kDegrees; ++d) {
    const double beta = pitch.at(static_cast<double>(d)).phi_deg;
    contacts[d] = {beta, std::cos(std::atan(lift->d1(beta) / (rb + rr + lift->value(beta))))};
  }
  Result<std::vector<double>> lift_correction_um = roller_lift_correction_um(design, correction_um, contacts, part);
  if (!lift_correction_um.ok()) return lift_correction_um.error();
  return target_lift(design, *lift_correction_um);
}

Result<PeriodicSpline> corrected_lift(const LiftTable& design, const DesignReading& reading,
                                      const DegreeTable& correction_um, const Part& part) {
  const PeriodicSpline* lift = reading.lift();
  Result<FollowerGeometry> geometry = follower_geometry(part);
  // Without the lobe model, or for a flat follower (nothing to reuse), or a lobe whose
  // contacts were not kept: as without it, which also gives its errors.
  if (lift == nullptr || !geometry.ok() || geometry->kind == FollowerKind::kFlat || reading.contacts().empty()) {
    return corrected_lift(design, correction_um, part);
  }
  const FollowerGeometry& g = reading.geometry();
  const size_t n = design.angle_deg.size();
  bool same = geometry->kind == g.kind && geometry->base_circle_radius_mm == g.base_circle_radius_mm &&
              geometry->roller_radius_mm == g.roller_radius_mm && static_cast<std::ptrdiff_t>(n) == lift->size();
  for (size_t i = 0; i < n && same; ++i) {
    same = design.angle_deg[i] == lift->knots_deg()[i] && design.lift_mm[i] == lift->knot_values()[i];
  }
  if (!same) {
    return make_error(ErrorCode::kInvalidInput, "corrected lift: the design reading of part '" + part.name +
                                                    "' was not made from design lift table '" + design.source +
                                                    "' and this follower; pass DesignReading::of_lobe of them");
  }
  if (Status finite = check_finite(correction_um); !finite.ok()) return finite.error();
  Result<std::vector<double>> lift_correction_um =
      roller_lift_correction_um(design, correction_um, reading.contacts(), part);
  if (!lift_correction_um.ok()) return lift_correction_um.error();
  return target_lift(design, *lift_correction_um);
}

Result<WheelPath> corrected_wheel_path(const LiftTable& design, const DegreeTable& correction_um, const Part& part,
                                       double step_deg) {
  Result<PeriodicSpline> target = corrected_lift(design, correction_um, part);
  if (!target.ok()) return target.error();
  return compute_wheel_path(*target, part, step_deg);
}

Result<WheelPath> corrected_wheel_path(const LiftTable& design, const DesignReading& reading,
                                       const DegreeTable& correction_um, const Part& part, double step_deg) {
  Result<PeriodicSpline> target = corrected_lift(design, reading, correction_um, part);
  if (!target.ok()) return target.error();
  return compute_wheel_path(*target, part, step_deg);
}

}  // namespace gaugeloop
