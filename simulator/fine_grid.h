// The grid the virtual cam and pin grinders evaluate a turn of the work spindle C on: the
// commanded path, the machine's errors and the ground part are computed at every row.
#pragma once

namespace gaugeloop::fine_grid {

inline constexpr double kFineGridStepDeg = 0.1;
inline constexpr int kFineGridRows = 3600;  // one turn of C

}  // namespace gaugeloop::fine_grid
