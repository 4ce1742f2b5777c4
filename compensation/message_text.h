// Angle-range formatting for the messages compensation/ puts in its errors (numbers:
// core/number_text.h, included here for the callers).
#pragma once

#include <string>
#include <vector>

#include "core/number_text.h"

namespace gaugeloop {

// Describes where `flagged[i]` holds on a periodic grid of angles, as at most `max_ranges`
// ranges, e.g. "52.3 to 61.0 deg and 299.0 to 307.7 deg". `angle_deg` must be strictly
// increasing over less than one turn (the grid wraps from its last angle back to the first);
// printed angles are wrapped into [0, 360). A run touching both ends of the grid is one range.
// Returns "" when nothing is flagged.
std::string describe_angle_ranges(const std::vector<double>& angle_deg, const std::vector<bool>& flagged,
                                  int max_ranges = 4);

}  // namespace gaugeloop
