// Guards between a wheel path and the machine: what the infeed axis X can do at the work speed.
//
// Frame: machine frame, C (work spindle) in degrees, X (wheel infeed) in mm. At a constant
// work speed n (rpm) C turns 6 n deg/s, so dX/dt = dX/dC * 6n (mm/s) and
// d2X/dt2 = d2X/dC2 * (6n)^2 (mm/s^2); a negative speed uses |n|.
//
// Both guards run before anything is rendered. A refusal says what, where (the C degree,
// the value and the limit) and what to do:
//  - kInvalidInput: the limits themselves are not usable (not finite, min >= max, ...).
//  - kRefused: NaN or infinity, X outside [x_min_mm, x_max_mm], velocity or acceleration
//    beyond the limit.
#pragma once

#include "core/result.h"
#include "nc_out/sampled_path.h"
#include "nc_out/table_writer.h"

namespace gaugeloop {

struct AxisLimits {
  double x_min_mm = 0.0;  // software limits of the infeed, in the table's frame (0 on the base circle)
  double x_max_mm = 0.0;
  double x_velocity_max_mm_per_s = 0.0;
  double x_acceleration_max_mm_per_s2 = 0.0;
  double speed_rpm = 0.0;  // programmed work speed of C
  // The axis the limits are of, as messages name it: 'X' (the infeed; keys x_min_mm...) or
  // 'Y' (a crankpin's vertical slide in C-X-Y; keys y_min_mm...). The fields keep their x_
  // names for either.
  char axis = 'X';
};

// Checks the limits themselves: kInvalidInput naming the setting.
Status check_axis_limits(const AxisLimits& limits);

// The exact path: every row finite, X within limits, |dX/dt| and |d2X/dt2| within limits.
Status check_path_guards(const SampledPath& path, const AxisLimits& limits);

// The table as the NC will run it, evaluated at the fine rows' C: points finite, the
// interpolated X within limits (a spline can overshoot between points), its velocity within
// the limit, and for CSPLINE its acceleration too. A G1 table has no finite acceleration at
// its points (the control's own jerk and acceleration limits smooth the corners); its
// acceleration is guarded through the exact path only.
Status check_table_guards(const CurveTable& table, const SampledPath& path, const AxisLimits& limits);

}  // namespace gaugeloop
