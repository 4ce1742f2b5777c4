// Sinumerik 840D curve-table blocks (CTABDEF body) for a wheel path X(C).
//
// Frame: machine frame; C (work spindle, leading axis) in degrees, X (wheel infeed,
// following axis) in mm, 0 on the base circle. Pure text: no I/O.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

// One table point. Frame: machine frame. C in degrees in [0, 360], X the wheel infeed in mm
// (0 on the base circle).
struct CurvePoint {
  double c_deg = 0.0;
  double x_mm = 0.0;
};

struct CurveTableFormat {
  int c_decimals = 3;  // 0.001 deg
  int x_decimals = 4;  // 0.1 um
};

// How the NC interpolates between table points: the modal motion command of the blocks.
enum class Interpolation {
  kLinear,       // G1
  kCubicSpline,  // CSPLINE with BNAT ENAT (natural ends), see docs/nc_output.md
};

// "linear" or "cspline": as written in the table header and read back.
std::string_view interpolation_name(Interpolation interpolation);

// Checks a periodic table before anything is written: at least 4 points, C strictly
// increasing from 0 to 360, every X finite and the last X equal to the first (the period
// closes). The message names the point (index and C) and the rule broken.
Status validate_curve_points(const std::vector<CurvePoint>& points);

// The table body: one block per point, the first carrying G1 (linear segments), e.g.
//   G1 C0.000 X0.0000
//   C1.000 X0.0003
// Blocks are separated by newlines, with none after the last. Call validate_curve_points first.
std::string render_curve_blocks(const std::vector<CurvePoint>& points, const CurveTableFormat& format = {});

// The table body for either interpolation. kLinear: as render_curve_blocks. kCubicSpline:
// the first block sets the start point with G1, the second switches to CSPLINE with natural
// ends, the rest follow modally:
//   G1 C0.000 X0.0000
//   BNAT ENAT CSPLINE C1.000 X0.0003
//   C2.000 X0.0011
// Call validate_curve_points first.
std::string render_table_blocks(const std::vector<CurvePoint>& points, Interpolation interpolation,
                                const CurveTableFormat& format = {});

}  // namespace gaugeloop
