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

// One table point. Frame: machine frame. C in degrees over the table's turn, X the wheel
// infeed in mm (0 on the base circle).
struct CurvePoint {
  double c_deg = 0.0;
  double x_mm = 0.0;
  // kPoly only: the segment that ends at this point, as `PO[X]=(x_mm, a2, a3)` writes it:
  // X(p) = X_before + a1 p + a2 p^2 + a3 p^3, p = 0 .. 1 across the segment's C, a1 derived by
  // the control so that X(1) = x_mm. 0 on the first point and under the other interpolations.
  double a2_mm = 0.0;
  double a3_mm = 0.0;
};

// How the table's values are written. X is rounded to the control's computational resolution
// for linear positions, MD10200 $MN_INT_INCR_PER_MM (the control rounds every programmed
// position to it, so the table the NC holds is the rounded one); C is written to 0.001 deg,
// MD10210 $MN_INT_INCR_PER_DEG at its default 1000. See docs/nc_output.md.
struct CurveTableFormat {
  int c_decimals = 3;  // 0.001 deg
  // Increments per mm of X, a whole number 1..1000000 (check_x_resolution). The default,
  // 10000 (0.1 um), keeps the 0.5 um command error bound on the sample lobes; at the
  // control's default of 1000 the rounding alone can cost 0.5 um.
  double x_increments_per_mm = 10000.0;

  // The fewest decimals that write every increment so that the control reads the same
  // increment back: exact for a power of ten (10000 -> 4), otherwise within half a last
  // decimal, less than half an increment (3000 -> 4 decimals, 0.3333 read as 1/3000 mm).
  int x_decimals() const;
  // X on the control's grid: the nearest whole increment, never a signed zero.
  double round_x_mm(double x_mm) const;
  // A POLY segment's coefficients a2, a3 (mm) are not positions and are not rounded to the
  // grid by the control; they are written with two decimals more than X, so that their
  // rounding moves the segment by at most 0.64 * 0.5e-(x_decimals + 2) mm between its ends.
  int coefficient_decimals() const { return x_decimals() + 2; }
  double round_coefficient_mm(double a_mm) const;
};

// kInvalidInput unless `x_increments_per_mm` is a whole number 1..1000000 (six decimals at
// most), naming `where` (the key or option it came from).
Status check_x_resolution(double x_increments_per_mm, std::string_view where);

// How the NC interpolates between table points: the modal motion command of the blocks.
enum class Interpolation {
  kLinear,       // G1
  kCubicSpline,  // CSPLINE with BNAT ENAT (natural ends), see docs/nc_output.md
  kPoly,         // POLY: one cubic per segment in the segment's normalised C, see docs/nc_output.md
};

// "linear", "cspline" or "poly": as written in the table header and read back.
std::string_view interpolation_name(Interpolation interpolation);

// Checks a periodic table before anything is written: at least 4 points, C strictly
// increasing over one turn (from c0 in [0, 360) to c0 + 360), every X finite and the last X
// equal to the first (the period closes). The message names the point (index and C) and the
// rule broken.
Status validate_curve_points(const std::vector<CurvePoint>& points);

// The table body: one block per point, the first carrying G1 (linear segments), e.g.
//   G1 C0.000 X0.0000
//   C1.000 X0.0003
// X with format.x_decimals(), rounded to the control's increment (round_x_mm). Blocks are
// separated by newlines, with none after the last. Call validate_curve_points first.
std::string render_curve_blocks(const std::vector<CurvePoint>& points, const CurveTableFormat& format = {});

// The table body for either interpolation. kLinear: as render_curve_blocks. kCubicSpline:
// the first block sets the start point with G1, the second switches to CSPLINE with natural
// ends, the rest follow modally:
//   G1 C0.000 X0.0000
//   BNAT ENAT CSPLINE C1.000 X0.0003
//   C2.000 X0.0011
// `following_axis` is the word the following values are written under: X for the wheel
// infeed, Y for the wheel height of a crankpin ground C-X-Y (its values then are Y in mm,
// rounded on the same linear grid). kPoly: the first block sets the start point with G1, the
// second switches to POLY, each segment gives C's end point (C moves linearly in p) and the
// following axis' end point with a2 and a3 (PL not programmed: 1):
//   G1 C0.000 X0.0000
//   POLY PO[C]=(1.000) PO[X]=(0.0003,0.000012,-0.000004)
//   PO[C]=(2.000) PO[X]=(0.0011,0.000010,-0.000003)
// Call validate_curve_points first.
// `leading_axis` C by default; a correction layer's SIM1 is written SIM1=<deg> (an axis name
// with a digit takes '=' before its value).
std::string render_table_blocks(const std::vector<CurvePoint>& points, Interpolation interpolation,
                                const CurveTableFormat& format = {}, std::string_view following_axis = "X",
                                std::string_view leading_axis = "C");

}  // namespace gaugeloop
