// Curve-table writers: choose the table points for a wheel path and say how exactly the NC
// will follow it.
//
// Frame: machine frame. C (work spindle, leading axis) in degrees, X (wheel infeed,
// following axis) in mm, 0 on the base circle. A table runs over one turn, from C0 to C360 or,
// for a CSPLINE table, from its seam c0 (spline_start_c_deg) to c0 + 360; its
// last point repeats the first X (periodic table, CTABDEF periodicity 1), and the control reads
// any C modulo the table's range.
//
// The command position error of a table is the largest |what the NC interpolates between
// table points - exact X| over the rows of the fine path (SampledPath), with the C where it
// occurs. It is computed from the points as written (rounded to the format's decimals),
// because that is what the control interpolates. What the control interpolates:
//  - kLinear (G1): straight segments between points.
//  - kCubicSpline (CSPLINE with BNAT ENAT): the interpolating cubic spline through all points
//    over C, curvature continuous at inner points, zero curvature at the first and last point
//    (natural ends). Started on the base circle, where X'' is 0 anyway, the natural ends cost
//    nothing. See docs/nc_output.md for where this comes from and what it assumes.
//  - kPoly (POLY, PO[C]=(c_end) PO[X]=(x_end,a2,a3)): in each segment the cubic of the
//    normalised leading value p = (C - C_start) / (C_end - C_start), a1 derived so that it
//    ends at x_end. Never chosen by the default (docs/nc_output.md: what the manual confirms).
//
// Errors: kInvalidInput for a step or setting out of range (named); kRefused when no table of
// the kind asked for keeps the bound (the message gives the best error reached and where).
// Writers do not check values against axis limits: see table_guards.h.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "nc_out/curve_table.h"
#include "nc_out/sampled_path.h"

namespace gaugeloop {

struct CommandError {
  double max_abs_um = 0.0;  // largest |interpolated - exact X| over the fine rows, um
  double at_c_deg = 0.0;    // C of that row
  // Upper bound of how much the error can exceed max_abs_um between fine rows:
  // h^2 / 8 * max|e''| (h the fine step, e = interpolant - X, e'' <= |S''| + |X''|), um.
  double between_rows_um = 0.0;
};

// A table as it will be written: `points` are rounded to the format's decimals, from C0 to
// C360, the last X equal to the first. One block per point (the first block only sets the
// start), so block_count() == points.size().
struct CurveTable {
  Interpolation interpolation = Interpolation::kLinear;
  std::vector<CurvePoint> points;
  std::string writer;  // how the points were chosen, e.g. "linear 0.5 deg", for reports
  CommandError error;

  int block_count() const { return static_cast<int>(points.size()); }
};

// What the NC makes of a periodic table: value, dX/dC and d2X/dC2 at any C; a C outside the
// points' range is read modulo the range, as the control reads a periodic table.
// For kLinear the derivatives are those of the segment (d2 is 0; at a point, the segment
// that starts there). Built from points in increasing C, at least 2 (linear) or 3 (spline).
class TableInterpolant {
 public:
  static Result<TableInterpolant> of(const std::vector<CurvePoint>& points, Interpolation interpolation);

  struct Value {
    double x_mm = 0.0;
    double dx_dc_mm_per_deg = 0.0;
    double d2x_dc2_mm_per_deg2 = 0.0;
  };
  Value at(double c_deg) const;
  // As at(c_deg), for a scan along C: `segment` is the segment the last call found (start
  // with 0); a C in it or the next is found without a search. Same values as at(c_deg).
  Value at(double c_deg, std::size_t& segment) const;
  // X alone, as at(c_deg, segment).x_mm to the last bit: for scans that need no slope.
  // Inlined even where the optimiser would not (the sanitizer builds at -O1).
  [[gnu::always_inline]] double x_mm_at(double c_deg, std::size_t& segment) const;

  // Largest |d2X/dC2| of the interpolant (0 for linear): for the between-rows bound.
  double max_abs_d2_mm_per_deg2() const;

 private:
  // The segment holding `c_deg` (read modulo the range outside it) and C within the range.
  std::size_t locate(double c_deg, double& c, std::size_t& segment) const;
  [[gnu::always_inline]] double x_mm_in(std::size_t i, double c) const;

  Interpolation interpolation_ = Interpolation::kLinear;
  std::vector<double> c_deg_;
  std::vector<double> x_mm_;
  std::vector<double> moment_;         // spline: S'' at each point (natural ends: 0 at both ends)
  std::vector<double> a2_mm_, a3_mm_;  // POLY: each point's segment coefficients (CurvePoint)
};

// Inline: the writers scan tables at every fine row of C, a few million reads a table.
// X in segment i at C (within it): the one formula at() and x_mm_at() share.
inline double TableInterpolant::x_mm_in(std::size_t i, double c) const {
  const double* cs = c_deg_.data();
  const double* xs = x_mm_.data();
  const double h = cs[i + 1] - cs[i];
  const double y0 = xs[i];
  const double y1 = xs[i + 1];
  if (interpolation_ == Interpolation::kLinear) return y0 + (y1 - y0) / h * (c - cs[i]);
  if (interpolation_ == Interpolation::kPoly) {
    // The segment ending at point i + 1, in p = 0..1 (PL 1); a1 as the control derives it.
    const double a2 = a2_mm_[i + 1];
    const double a3 = a3_mm_[i + 1];
    const double a1 = y1 - y0 - a2 - a3;
    const double p = (c - cs[i]) / h;
    return y0 + p * (a1 + p * (a2 + p * a3));
  }
  const double* ms = moment_.data();
  const double a = (cs[i + 1] - c) / h;
  const double b = (c - cs[i]) / h;
  return a * y0 + b * y1 + ((a * a * a - a) * ms[i] + (b * b * b - b) * ms[i + 1]) * h * h / 6.0;
}

inline double TableInterpolant::x_mm_at(double c_deg, std::size_t& segment) const {
  // A scan along C within the range: walk on from the hint (the segment locate would find).
  const double* cs = c_deg_.data();
  const std::size_t m = c_deg_.size();
  std::size_t i = segment;
  if (i + 2 <= m && cs[i] <= c_deg && c_deg <= cs[m - 1]) {
    while (i + 2 < m && !(c_deg < cs[i + 1])) ++i;
    segment = i;
    return x_mm_in(i, c_deg);
  }
  double c = 0.0;
  i = locate(c_deg, c, segment);
  return x_mm_in(i, c);
}

// The command position error of `points` against `path`. Points need not lie on the fine
// grid. kInvalidInput if the path's shape is wrong or the points do not form a table.
Result<CommandError> command_position_error(const SampledPath& path, const std::vector<CurvePoint>& points,
                                            Interpolation interpolation);

// The command position error of `table` per whole degree of C: entry d is the largest
// |interpolated - exact X| over the fine rows in [d, d + 1), um. For the preview's picture.
Result<std::vector<double>> command_error_per_degree_um(const SampledPath& path, const CurveTable& table);

// G1 table at a uniform step: c_step_deg must divide 360 and be a whole multiple of the
// path's step; points are the path's rows at those C.
Result<CurveTable> write_linear_table(const SampledPath& path, double c_step_deg, const CurveTableFormat& format = {});

// Where a CSPLINE table starts (its seam): the row of the path whose largest |X''| within
// 1 deg either side is least, any C on the path's grid; where many rows tie (a base circle),
// the middle of the longest such run. Natural ends force X'' = 0 at the start: true on the
// base circle and at a crankpin's inflection (X'' = 0 where the pin passes the wheel's
// height), wrong by the most at a lobe's nose or a pin's turning point. docs/nc_output.md has
// the figures.
double spline_start_c_deg(const SampledPath& path);

// CSPLINE table at a uniform step (same rules as write_linear_table), from spline_start_c_deg.
Result<CurveTable> write_spline_table(const SampledPath& path, double c_step_deg, const CurveTableFormat& format = {});

// POLY table at a uniform step from C0 (same rules as write_linear_table): each segment the
// cubic Hermite of its end points (on the control's grid) and the path's exact slopes there;
// a POLY table has no end condition, so no seam to place. Error of the cubic Hermite: at most
// h^4 / 384 max|X4| within a segment of h deg (X4 the fourth C-derivative), plus the grid's
// rounding.
Result<CurveTable> write_poly_table(const SampledPath& path, double c_step_deg, const CurveTableFormat& format = {});

struct AdaptiveSettings {
  double bound_um = 0.5;       // largest command position error allowed
  double max_step_deg = 10.0;  // no table segment wider than this
};

// G1 table with points chosen from the fine rows: from C0 on, each segment reaches as far as
// the bound allows (at most max_step_deg), so points are dense only where X bends.
// kRefused if even one fine step breaks the bound (only rounding could do that).
Result<CurveTable> write_adaptive_linear_table(const SampledPath& path, const AdaptiveSettings& settings,
                                               const CurveTableFormat& format = {});

// CSPLINE table with points chosen from the fine rows: starts from a uniform step and halves
// every segment whose error breaks the bound until none does (the spline is global: each
// round re-solves it), then drops, in one pass from its start on, every point whose removal
// keeps the bound and the widest step. Starts from max_step_deg, 2 and 1 deg; keeps the fewest
// points. Runs from spline_start_c_deg. kRefused if no start converges.
Result<CurveTable> write_adaptive_spline_table(const SampledPath& path, const AdaptiveSettings& settings,
                                               const CurveTableFormat& format = {});

struct TableChoiceSettings {
  double bound_um = 0.5;       // the default keeps the command position error at or below this
  double max_step_deg = 10.0;  // widest segment
  bool allow_spline = true;    // false: G1 tables only (a control without CSPLINE in tables)
};

// Where the points of the table in force for this lobe lie, and how the NC interpolates
// between them: what the next table of the lobe may keep.
struct TablePointsInForce {
  Interpolation interpolation = Interpolation::kLinear;
  std::vector<double> c_deg;  // from its start c0 to c0 + 360, increasing
};

// A table of `in_force`'s kind at its C positions, X from `path`. kInvalidInput if a C is not
// a row of the path (a table written on another grid) or the positions do not run over one
// turn from a start in [0, 360) (C0 for tables written before splines started on the base
// circle).
Result<CurveTable> write_table_at_points(const SampledPath& path, const TablePointsInForce& in_force,
                                         const CurveTableFormat& format = {});

// One table the default choice weighs: its writer ("linear 0.5 deg", "adaptive spline") and
// the table, or why the writer refused (a fine step that breaks the bound by rounding alone).
struct TableCandidate {
  std::string writer;
  std::optional<CurveTable> table;
  std::string refused;  // set when table is empty
};

// The candidates of write_default_table, in its order, each with its blocks, seam (its first
// point) and command position error: what an engineer reads to see why the default chose
// what it chose. Errors as the writers' (kInvalidInput for bad settings).
Result<std::vector<TableCandidate>> default_table_candidates(const SampledPath& path,
                                                             const TableChoiceSettings& settings,
                                                             const CurveTableFormat& format = {});

// The default: of the candidates (G1 at 1, 0.5, 0.25, 0.2, 0.1 deg; adaptive G1; CSPLINE at
// 5, 4, 3, 2, 1, 0.5 deg; adaptive CSPLINE), the one with the fewest blocks whose command
// position error is at or below the bound; on a tie, G1 (it needs no spline model). kRefused
// naming the smallest error reached if none keeps the bound.
//
// With `in_force` (the table in force for the lobe): its points are kept, X moved to the new
// path, with a point added in every segment that breaks the bound (or is wider than
// max_step_deg), while that needs at most 1.25 times the blocks of the fewest choice. A closed
// loop then meets the same interpolation error part after part and cancels it, instead of
// chasing a new pattern in every table; and one version compares with the next point by
// point. Beyond 1.25 times, or for points not on the path's grid, the fewest choice.
Result<CurveTable> write_default_table(const SampledPath& path, const TableChoiceSettings& settings,
                                       const CurveTableFormat& format = {},
                                       const TablePointsInForce* in_force = nullptr);

}  // namespace gaugeloop
