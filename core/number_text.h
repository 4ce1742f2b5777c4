// The one way gaugeloop turns a number into text, in NC files, reports and messages alike:
// fixed decimals, always a point (whatever the locale), and never "-0.0" for a value that
// rounds to zero.
#pragma once

#include <string>

namespace gaugeloop {

// `value` with `decimals` digits after the point: format_fixed(47.31, 1) == "47.3",
// format_fixed(-0.004, 2) == "0.00". NaN and infinities print as "nan", "inf", "-inf".
std::string format_fixed(double value, int decimals);

// The same with a sign always: "+1.25", "-0.50", "+0.00".
std::string format_signed_fixed(double value, int decimals);

}  // namespace gaugeloop
