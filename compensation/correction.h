// Turning measured lift errors into the correction for the next part, and its wheel path.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "compensation/flat_probe.h"
#include "compensation/wheel_path.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// Keeps harmonics 0..max_harmonic of a periodic table (Fourier truncation with Eigen's FFT),
// in the table's own units. max_harmonic < 0 gives all zeros; >= 180 returns the input.
DegreeTable smooth_harmonics(const DegreeTable& values, int max_harmonic);

// The harmonics of the measured error that stand above the noise of its mean, as a band
// 0..harmonics (choose_harmonics).
struct HarmonicChoice {
  int harmonics = 0;          // the band fed back is 0..harmonics
  double noise_um = 0.0;      // sigma of one harmonic's cosine (or sine) amplitude from gauge noise
  double threshold_um = 0.0;  // the amplitude a harmonic must exceed to count as measured
};

// Chooses how many harmonics of `error_um` to feed back, from the revolutions' repeatability.
// The mean of `revolutions` revolutions carries noise of sigma_m = rms(spread_um) /
// sqrt(revolutions) per degree; white over 360 degrees, that puts sigma_m * sqrt(2 / 360) on
// the cosine and on the sine amplitude of every harmonic (noise_um), and a noise-only
// harmonic's amplitude exceeds `sigmas` times that with probability exp(-sigmas^2 / 2)
// (Rayleigh: 3e-4 for 4, so 30 harmonics of pure noise pass one in a hundred times). The band
// runs from 0 to the highest harmonic up to `cap` whose amplitude exceeds the threshold (0
// when none does). The cap keeps the band below what the gauge sees of the part's own
// vibration: it repeats over the revolutions, so it stands above the noise, but it is new
// every part and feeding it back only puts it on the next one. revolutions < 2 or no spread
// (nothing tells the noise) gives the cap.
HarmonicChoice choose_harmonics(const DegreeTable& error_um, const DegreeTable& spread_um, int revolutions, int cap,
                                double sigmas = 4.0);

struct CompensationSettings {
  double gain = 1.0;                  // g in (0, 1]: fraction of the smoothed error fed back
  int max_harmonic = 30;              // 0..180: the cap of the band, or the band (choose_harmonics)
  double max_correction_um = 100.0;   // refuse: the correction in force after this step, anywhere
  double max_change_um = 50.0;        // hold: the change from the correction in force, anywhere
  double max_repeatability_um = 2.0;  // hold: the revolutions disagree by more (largest spread)
  double max_phase_deg = 0.5;         // hold: the lobe appears turned by more
  // The error is smoothed to harmonics 0..K before it is fed back. True: K from the
  // measurement (choose_harmonics), at most max_harmonic (config `harmonics = "auto"`);
  // false: K = max_harmonic (config `harmonics = N`).
  bool choose_harmonics = true;
};

// The pieces every learning step shares, the lobe's (decide_correction) and the pin's
// (decide_pin_correction): they differ in what is fed back exactly and what the messages
// call a degree and the part, not in the band, the update or the guards.
struct LearningStep {
  DegreeTable smoothed_part_um{};  // smoothed to the band (noise is not fed back)
  DegreeTable exact_part_um{};     // fed back as it is (a lobe's phase part; 0 for a pin)
  DegreeTable spread_um{};         // per-degree spread across revolutions (choose_harmonics)
  int revolutions = 0;
  double repeatability_um = 0.0;                // what max_repeatability_um judges
  std::string_view degree_name = "cam degree";  // how the reasons name an index
  std::string_view part_name = "lobe";          // what the reasons say the chips are on
  std::string change_note;                      // added to the change guard's reason after "from the one in force"
};

// Correction convention: a correction c(theta) in um, cam frame, per whole cam degree, in
// flat-probe reading terms. The next part is ground to the target whose flat-probe reading
// is design - c (correct the target, as iterative learning control does), so a lobe that measured e um high
// asks for c to grow by g * e.

// What to do with the correction a measurement asks for.
//  - kApply: grind the next part with it.
//  - kHold: keep the correction in force. The measurement is doubtful (its revolutions
//    disagree), or the step is unusual (a large change since the last part, a large phase);
//    an operator may approve the proposed correction, or measure again.
//  - kRefuse: the proposed correction is beyond what the machine may carry at all
//    (max_correction_um); it is not applied without raising the limit.
enum class CompensationVerdict { kApply, kHold, kRefuse };
std::string_view compensation_verdict_name(CompensationVerdict verdict);  // "apply", "hold", "refuse"

// Which guard spoke, so a caller can store or count it without parsing text.
enum class CompensationGuard {
  kCorrectionLimit,  // refuse: |correction| > max_correction_um
  kChangeLimit,      // hold: |correction - in force| > max_change_um
  kRepeatability,    // hold: repeatability_um > max_repeatability_um
  kPhase,            // hold: |phase_error_deg| > max_phase_deg
};

struct GuardFinding {
  CompensationGuard guard = CompensationGuard::kCorrectionLimit;
  CompensationVerdict verdict = CompensationVerdict::kHold;  // kHold or kRefuse
  std::string reason;  // what, where (degree, value, limit) and what to do, in the shop's words
};

// The outcome of one compensation step. The proposed correction is computed whatever the
// verdict, so an operator can see it and approve it.
struct CompensationDecision {
  CompensationVerdict verdict = CompensationVerdict::kApply;  // the strongest finding's, or kApply
  DegreeTable correction_um{};  // proposed: in force + gain * step (see decide_correction)
  DegreeTable change_um{};      // correction_um - correction in force
  // The value of largest magnitude (signed) and its cam degree (signed_degree).
  double largest_correction_um = 0.0;
  int largest_correction_deg = 0;
  double largest_change_um = 0.0;
  int largest_change_deg = 0;
  // The change without the phase part (gain * smoothed remainder): what max_change_um judges,
  // the phase part being max_phase_deg's. Equal to the above without a design model.
  double largest_form_change_um = 0.0;
  int largest_form_change_deg = 0;
  HarmonicChoice harmonics;            // the band fed back (harmonics.harmonics) and why
  std::vector<GuardFinding> findings;  // empty when applied, else one per guard tripped

  bool apply() const { return verdict == CompensationVerdict::kApply; }
  // The findings' reasons joined with "; ", "" when applied.
  std::string reasons() const;
};

// kInvalidInput for gain outside (0, 1], max_harmonic outside [0, 180] or a limit that is not
// a positive number (decide_correction's checks of its settings).
Status check_compensation_settings(const CompensationSettings& settings);

// correction = in force + gain * (smooth(smoothed_part_um) + exact_part_um), the band K from
// choose_harmonics(smoothed_part_um, spread_um, revolutions, max_harmonic) or max_harmonic,
// with the correction, change (of the smoothed part alone) and repeatability guards and the
// verdict they give. A phase guard is the caller's (then settle_verdict again).
// Errors: as check_compensation_settings; kInvalidInput for NaN or infinity in either part,
// the correction in force or the repeatability, naming the degree.
Result<CompensationDecision> learning_step(const LearningStep& step, const DegreeTable& correction_in_force_um,
                                           const CompensationSettings& settings);

// Sets decision.verdict from its findings: kRefuse if any refuses, else kHold if any holds,
// else kApply.
void settle_verdict(CompensationDecision& decision);

// One iterative-learning step: fit the phase first, compensate the remainder.
// With phi = analysis.phase_error_deg and D the design reading model:
//   phase part  p(theta) = (D(theta - phi) - D(theta)) * 1000, the error a turned lobe
//               shows at nominal timing, computed exactly, not smoothed: it is one fitted
//               number and carries no noise, and cutting its harmonics would leave ripple
//               where the flanks meet the base circle;
//   remainder   r = error_um - p, smoothed to harmonics 0..K (noise is not fed back), K
//               from choose_harmonics(r, analysis.spread_um, analysis.revolutions,
//               max_harmonic) or max_harmonic (CompensationSettings::choose_harmonics);
//   correction  = correction_in_force + gain * (smooth(r) + p).
// So a timing error (servo lag, a late latch) is corrected through the lift, as a turn of the
// target lobe: the table is what holds the correction, and moving c_offset_deg instead would
// also move the gauge's frame mapping (which uses it) and hide the error rather than remove
// it. A phase beyond max_phase_deg is held: in-process, the gauge and the wheel share the C
// axis, and a large apparent phase is more often a mis-set probe_offset_deg.
// Guards, each a GuardFinding: see CompensationGuard. The change guard judges the change
// without the phase part (largest_form_change_um): a turn within max_phase_deg is the phase
// guard's to judge, and on a steep flank 0.3 deg is already tens of um of lift, which must not
// be blamed on the wheel. The verdict is kRefuse if any finding
// refuses, else kHold if any holds, else kApply.
// Errors (kInvalidInput): gain outside (0, 1]; max_harmonic outside [0, 180]; a limit that is
// not a positive number; NaN or infinity in the analysis or the correction in force; a
// `design` whose table differs from analysis.design_lift_mm (not the model it was made with).
Result<CompensationDecision> decide_correction(const LobeAnalysis& analysis, const DesignReading& design,
                                               const DegreeTable& correction_in_force_um,
                                               const CompensationSettings& settings);

// Without the design model: the phase part cannot be evaluated between whole degrees exactly
// for a roller lobe (its reading has corners), so the whole error, phase included, is
// smoothed: step = gain * smooth(error_um). Otherwise as above.
Result<CompensationDecision> decide_correction(const LobeAnalysis& analysis, const DegreeTable& correction_in_force_um,
                                               const CompensationSettings& settings);

// The table-only step as a plain result, for callers that do not store held or refused runs:
// decide_correction(analysis, correction_in_force_um, s); the proposed correction when
// applied, else kRefused whose message names the verdict and every reason.
// Errors: as decide_correction.
Result<DegreeTable> next_correction(const LobeAnalysis& analysis, const DegreeTable& correction_in_force_um,
                                    const CompensationSettings& s);

// The target lift the next part is ground to: the design with `correction_um` applied
// (convention above), as a periodic spline through the design's knots. The correction table
// is interpolated with a PeriodicSpline; at each knot of `design`:
//  - flat follower: target lift = design lift - c(beta) / 1000 (the lift is the reading);
//  - roller and knife edge: the reading at probe angle theta moves the cam surface point
//    whose normal is theta; the follower at beta = theta + alpha (alpha the pressure angle)
//    sees that move divided by cos(alpha). So target lift = design lift
//    - c(beta - alpha(beta)) / cos(alpha(beta)) / 1000 wherever the cam surface is on its
//    convex hull (first order in c). A concave flank is invisible to a flat probe; there the
//    lift correction is interpolated periodically between the neighbouring hull points.
// A zero correction gives exactly the spline of the design.
// Errors: as PeriodicSpline::fit (design table) and follower_geometry; kRefused (as
// check_lobe_shape) when a roller lobe's lift reaches below -rb; kInvalidInput for a
// non-finite correction. The corrected lobe's shape is checked by compute_wheel_path.
Result<PeriodicSpline> corrected_lift(const LiftTable& design, const DegreeTable& correction_um, const Part& part);

// The same, bit for bit, taking the contacts from `reading` (DesignReading::of_lobe of this
// design and part, made once per part) instead of finding them again: for a roller lobe
// that is 360 support-function solves a correction saved. A reading without the lobe model
// (interpolating) or of a flat follower gives the overload above.
// Errors: as above; kInvalidInput when `reading` was made from another lift table or
// follower geometry.
Result<PeriodicSpline> corrected_lift(const LiftTable& design, const DesignReading& reading,
                                      const DegreeTable& correction_um, const Part& part);

// compute_wheel_path of corrected_lift. Errors: as those two.
Result<WheelPath> corrected_wheel_path(const LiftTable& design, const DegreeTable& correction_um, const Part& part,
                                       double step_deg);
Result<WheelPath> corrected_wheel_path(const LiftTable& design, const DesignReading& reading,
                                       const DegreeTable& correction_um, const Part& part, double step_deg);

}  // namespace gaugeloop
