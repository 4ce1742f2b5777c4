// The tolerances a run is judged against, as canonical settings lines, so that two runs
// judged alike show the same settings (and settings hash) and `runs compare` shows a change
// of tolerance like any other setting.
#pragma once

#include <string>

#include "core/pin.h"
#include "core/tolerance.h"

namespace gaugeloop {

// One "key = value" line per limit given, in a fixed order whatever the order in the file:
//   tolerance.lift_error = best_fit
//   tolerance.lift_error_um = -20 20
//   tolerance.base_circle_runout_um = none 8
//   tolerance.zone.opening_flank.angle_deg = -70 -20     (or .lift_mm = 0.3 7.5)
//   tolerance.zone.opening_flank.lift_error_um = -12 12
// A limit is "lower upper", an absent bound "none", numbers in their shortest exact form.
// Whole-turn keys first, then the zones in the order the follower meets them. Limits not
// given have no line, and tolerances that judge nothing give "" (so a part without
// [tolerance] keeps the settings it had before tolerances existed).
std::string tolerances_settings_text(const LobeTolerances& tolerances);

// A crankpin's, in the same form: tolerance.roundness_um, diameter_error_um, stroke_error_um,
// index_error_deg, those given.
std::string tolerances_settings_text(const PinTolerances& tolerances);

}  // namespace gaugeloop
