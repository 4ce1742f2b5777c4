// Number and angle-range formatting for the messages compensation/ puts in its errors.
#pragma once

#include <string>
#include <vector>

namespace gaugeloop {

// `value` with `decimals` digits after the point, e.g. format_fixed(47.31, 1) == "47.3".
std::string format_fixed(double value, int decimals);

// Describes where `flagged[i]` holds on a periodic grid of angles, as at most `max_ranges`
// ranges, e.g. "52.3 to 61.0 deg and 299.0 to 307.7 deg". `angle_deg` must be strictly
// increasing over less than one turn (the grid wraps from its last angle back to the first);
// printed angles are wrapped into [0, 360). A run touching both ends of the grid is one range.
// Returns "" when nothing is flagged.
std::string describe_angle_ranges(const std::vector<double>& angle_deg, const std::vector<bool>& flagged,
                                  int max_ranges = 4);

}  // namespace gaugeloop
