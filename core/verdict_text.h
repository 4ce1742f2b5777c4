// A run's verdict as a line of text, for the job's step and the measure command.
#pragma once

#include <string>
#include <vector>

#include "core/tolerance.h"

namespace gaugeloop {

// "out: lift_error.nose, phase (19 of 25 characteristics judged)", "in (19 of 25
// characteristics judged)", or "not judged (no limits given)".
std::string verdict_summary(Verdict verdict, const std::vector<Characteristic>& characteristics);

}  // namespace gaugeloop
