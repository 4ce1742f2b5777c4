// The work spindle's speed over a turn: the seam between the code that computes a speed
// program (compensation), the code that writes it for the control (nc_out) and the virtual
// grinder that grinds at it (simulator). Plain data; each side checks what it needs.
#pragma once

#include <vector>

namespace gaugeloop {

// The commanded speed of the work spindle C at each C position of one turn, machine frame:
// speed_rpm[k] at C = k * c_step_deg, k = 0 .. 360 / c_step_deg - 1, periodic (the entry after
// the last is the first). c_step_deg divides 360. A constant program has every entry equal.
// Speeds are positive (the sense of rotation is the part's, not the program's).
struct WorkSpeedProgram {
  double c_step_deg = 1.0;
  std::vector<double> speed_rpm;
};

}  // namespace gaugeloop
