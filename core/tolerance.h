// Tolerances of a lobe, and the characteristics and verdicts a run gets against them.
// Plain data: the part file fills LobeTolerances (config/), the analysis judges a run
// against them (compensation/judge_lobe), storage keeps the characteristics, reports and
// the SPC and AQDEF exports read them.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace gaugeloop {

// The zones of a lobe, in the order the follower meets them. Cam frame, nose at 0: the
// follower reads the cam at increasing cam angle as time goes on (cam_angle_at_probe_deg),
// so the lift rises at negative cam angles (the opening side, 180..360) and falls at positive
// ones (the closing side, 0..180).
enum class LobeZone { kBaseCircle, kOpeningRamp, kOpeningFlank, kNose, kClosingFlank, kClosingRamp };
inline constexpr std::array<LobeZone, 6> kLobeZones{LobeZone::kBaseCircle,   LobeZone::kOpeningRamp,
                                                    LobeZone::kOpeningFlank, LobeZone::kNose,
                                                    LobeZone::kClosingFlank, LobeZone::kClosingRamp};
// "base_circle", "opening_ramp", "opening_flank", "nose", "closing_flank", "closing_ramp".
std::string_view lobe_zone_name(LobeZone zone);
// "base circle", "opening ramp"...: as a report prints it.
std::string_view lobe_zone_title(LobeZone zone);
std::optional<LobeZone> lobe_zone_from_name(std::string_view name);

// A tolerance interval. Either bound may be absent (a runout has only an upper limit).
struct Limits {
  std::optional<double> lower;
  std::optional<double> upper;
  bool any() const { return lower.has_value() || upper.has_value(); }
};

// One zone of the lobe and its tolerances.
struct ZoneTolerance {
  LobeZone zone = LobeZone::kBaseCircle;
  // Where the zone is, one of:
  //  - by cam angle: the arc from from_deg up to to_deg (cam frame, nose at 0, degrees in
  //    [-360, 360]; the arc may wrap through 0 or 180), ends included;
  //  - by design lift: the degrees whose design lift (the flat-probe reading the run is
  //    compared with) is in [from_lift_mm, to_lift_mm), on the zone's side of the nose (the
  //    base circle and the nose take both sides).
  bool by_lift = false;
  double from_deg = 0.0;
  double to_deg = 0.0;
  double from_lift_mm = 0.0;
  double to_lift_mm = 0.0;
  Limits lift_error_um;
  Limits velocity_error_mm_per_deg;
  Limits acceleration_error_mm_per_deg2;
};

// Which lift error the lift, velocity and acceleration tolerances judge.
enum class LiftErrorReference {
  kBestFit,  // after removing the best-fit phase, as a cam inspection machine reports it; the
             // timing is judged on its own (phase_deg)
  kNominal,  // at the nominal timing, as compensation corrects it
};
std::string_view lift_error_reference_name(LiftErrorReference reference);  // "best_fit", "nominal"

struct LobeTolerances {
  LiftErrorReference lift_error_reference = LiftErrorReference::kBestFit;
  // Over the whole turn.
  Limits lift_error_um;
  Limits velocity_error_mm_per_deg;
  Limits acceleration_error_mm_per_deg2;
  std::vector<ZoneTolerance> zones;  // at most one per LobeZone; zones never overlap
  Limits phase_deg;                  // timing error of the lobe
  Limits base_circle_runout_um;      // as a dial reads it over the base-circle window
  Limits roundness_um;               // of the base circle
};

// A verdict, per characteristic and per run.
enum class Verdict {
  kNotJudged,  // no limits given for it (or nothing to judge)
  kIn,         // in tolerance
  kOut,        // out of tolerance
};
std::string_view verdict_name(Verdict verdict);  // "not_judged", "in", "out"
std::optional<Verdict> verdict_from_name(std::string_view name);
// A run's verdict: out if any characteristic is out, in if at least one is in and none out,
// not judged otherwise.
Verdict combined_verdict(const std::vector<Verdict>& verdicts);

// One figure of a run with its limits and verdict.
// Keys (stable: stored, exported, used as SPC and DFQ characteristic names):
//   lift_error, velocity_error, acceleration_error       over the whole turn
//   lift_error.<zone>, velocity_error.<zone>, acceleration_error.<zone>
//   phase                                                  timing error, deg
//   base_circle_runout                                     as a dial reads it, um
//   base_circle_runout_h1                                  first harmonic, 2 e, um
//   roundness                                              of the base circle, um
// For a figure over degrees (lift, velocity, acceleration error) `value` is the signed
// extreme (the one of min and max with the larger magnitude) and the verdict holds min and
// max against the limits; for a single figure min = max = value.
struct Characteristic {
  std::string key;
  std::string unit;  // "um", "mm/deg", "mm/deg^2", "deg"
  double value = 0.0;
  double min = 0.0;
  double max = 0.0;
  Limits limits;
  Verdict verdict = Verdict::kNotJudged;
  // For a zone: the arc judged, cam frame, nose at 0, from_deg up to to_deg, whole degrees in
  // (-180, 180]; empty for whole-turn and single figures.
  std::optional<int> from_deg;
  std::optional<int> to_deg;
};

// The verdict of figures [min, max] against limits: kNotJudged without limits.
Verdict judge(double min, double max, const Limits& limits);

// Decimals a figure in `unit` is printed with in text (runs show, runs spc): about 1 nm of
// lift. um 2, deg 4, mm/deg 6, mm/deg^2 7, anything else 4. The cam report's table (its
// page width) and the AQDEF export (K2022) choose their own.
int figure_decimals(std::string_view unit);

// A single figure (min = max = value) judged against `limits`.
Characteristic single_characteristic(std::string key, std::string unit, double value, const Limits& limits);

// What a run measured. A few keys mean a different thing on each: "roundness" is of a
// lobe's base circle and of a pin's whole circumference. A gear's keys are its own ("lead.",
// "profile.").
enum class PartKind { kLobe, kPin, kGear };

// "Lift error, opening flank", "Phase (timing) error"...: a key as a report or a DFQ
// description (K2002) writes it; "harmonic.<k>" (the amplitude of harmonic k of the lift
// error, an export's extra characteristic) is "Lift error, harmonic k". On a pin, "roundness"
// is "Pin roundness"; every other key reads the same on both. A gear's lead: "lead.F_beta"
// (the worst flank), "lead.F_beta.mean", "lead.f_f_beta.mean", "lead.f_H_beta.mean_abs", and per
// trace "lead.<figure>.<gap>.<left|right>" ("Total helix deviation F_beta, gap 1, left flank");
// its profile the same under "profile." with F_alpha, f_f_alpha and f_H_alpha.
// An unknown key comes back as it is.
std::string characteristic_title(std::string_view key, PartKind kind = PartKind::kLobe);

// What a run's characteristics tell of its part, where its settings are not at hand (SPC, the
// AQDEF export): a pin's carry keys only a pin has (diameter_error, stroke_error,
// index_error), a gear's its lead and profile ("lead.", "profile."); anything else, none
// included, is a lobe's.
PartKind part_kind_of(const std::vector<Characteristic>& characteristics);

}  // namespace gaugeloop
