// Table writers and the command position error they report.
#include "nc_out/table_writer.h"
#include "core/number_text.h"
#include "nc_out/nc_text.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <limits>
#include <optional>

namespace gaugeloop {
namespace {

using nc_text::round_to;

constexpr double kUmPerMm = 1000.0;
// How many more blocks than the fewest the points of the table in force may grow to before
// the default choice starts afresh (write_default_table).
constexpr double kKeptBlocksOverFewest = 1.25;
// How far either side of a seam candidate its bend is looked at: natural ends force X'' = 0 at
// the seam, and the spline's answer to a wrong end condition dies out over a few segments.
constexpr double kSeamWindowDeg = 1.0;

// Rounds as the table text does (%.*f rounds half away from zero on glibc's exact decimal
// expansion; std::round on the scaled value agrees except at ties nobody can see in a table
// of measured values), never giving a signed zero.
// Grid rows a table step spans, or 0 if the step does not divide 360 or is not a whole
// multiple of the fine step.
std::size_t rows_per_step(const SampledPath& path, double c_step_deg) {
  if (rows_per_turn(c_step_deg) == 0) return 0;
  const double r = c_step_deg / path.c_step_deg;
  if (!(r >= 1.0) || std::abs(r - std::round(r)) > 1e-9 * r) return 0;
  return static_cast<std::size_t>(std::llround(r));
}

Status check_format(const SampledPath& path, const CurveTableFormat& format) {
  if (format.c_decimals < 0 || format.c_decimals > 6) {
    return make_error(ErrorCode::kInvalidInput, "table decimals of C must be 0..6");
  }
  if (Status s = check_x_resolution(format.x_increments_per_mm, "table X resolution"); !s) return s;
  const double q = path.c_step_deg * std::pow(10.0, format.c_decimals);
  if (std::abs(q - std::round(q)) > 1e-6) {
    return make_error(ErrorCode::kInvalidInput, "fine path step " + format_fixed(path.c_step_deg, 6) +
                                                    " deg cannot be written with " + std::to_string(format.c_decimals) +
                                                    " decimals of C; use a step that can or more decimals");
  }
  return {};
}

// Table points at fine-grid rows `rows` (first 0, last n = one turn). Under kPoly each segment
// is the cubic Hermite through its end points as written (on the grid) with the path's exact
// slopes there, in the segment's normalised C p = 0..1 (slope h dX/dC for a segment h wide):
// a2 = 3 d - 2 m0 - m1, a3 = m0 + m1 - 2 d, d the rise; the control derives a1 = d - a2 - a3,
// which is m0 up to the coefficients' rounding.
std::vector<CurvePoint> points_at_rows(const SampledPath& path, const std::vector<std::size_t>& rows,
                                       const CurveTableFormat& format,
                                       Interpolation interpolation = Interpolation::kLinear) {
  const std::size_t n = path.size();
  std::vector<CurvePoint> out;
  out.reserve(rows.size());
  for (std::size_t k : rows) {
    out.push_back({round_to(path.c_deg(k), format.c_decimals), format.round_x_mm(path.x_mm[k % n])});
  }
  out.back().c_deg = 360.0;
  if (interpolation == Interpolation::kPoly) {
    for (std::size_t i = 1; i < out.size(); ++i) {
      const double h = out[i].c_deg - out[i - 1].c_deg;
      const double m0 = h * path.dx_dc_mm_per_deg[rows[i - 1] % n];
      const double m1 = h * path.dx_dc_mm_per_deg[rows[i] % n];
      const double d = out[i].x_mm - out[i - 1].x_mm;
      out[i].a2_mm = format.round_coefficient_mm(3.0 * d - 2.0 * m0 - m1);
      out[i].a3_mm = format.round_coefficient_mm(m0 + m1 - 2.0 * d);
    }
  }
  return out;
}

// Signed error (interpolant - X) in mm at every fine row 0..n (row n is C360 against row 0),
// into `e`, whose storage is reused: a path has 36,000 rows, and a writer that judges many
// tables would otherwise ask the allocator for (and the kernel to map) 288 KB each time.
void fill_row_errors_mm(const SampledPath& path, const TableInterpolant& nc, std::vector<double>& e) {
  const std::size_t n = path.size();
  e.resize(n + 1);
  std::size_t segment = 0;
  for (std::size_t j = 0; j <= n; ++j) {
    const double c = j == n ? 360.0 : path.c_deg(j);
    e[j] = nc.x_mm_at(c, segment) - path.x_mm[j % n];
  }
}

std::vector<double> row_errors_mm(const SampledPath& path, const TableInterpolant& nc) {
  std::vector<double> e;
  fill_row_errors_mm(path, nc, e);
  return e;
}

// The command position error of `nc` on `path` from the error at each row 0..n, error_at(j).
template <typename ErrorAt>
CommandError summarise_rows(const SampledPath& path, const TableInterpolant& nc, ErrorAt error_at) {
  const std::size_t n = path.size();
  CommandError out;
  std::size_t worst = 0;
  double worst_abs_mm = std::abs(error_at(0));
  for (std::size_t j = 1; j <= n; ++j) {
    const double v = std::abs(error_at(j));
    if (v > worst_abs_mm) {
      worst = j;
      worst_abs_mm = v;
    }
  }
  out.max_abs_um = worst_abs_mm * kUmPerMm;
  out.at_c_deg = worst == n ? 360.0 : path.c_deg(worst);
  double x2 = 0.0;
  for (double v : path.d2x_dc2_mm_per_deg2) x2 = std::max(x2, std::abs(v));
  const double h = path.c_step_deg;
  out.between_rows_um = h * h / 8.0 * (x2 + nc.max_abs_d2_mm_per_deg2()) * kUmPerMm;
  return out;
}

CommandError summarise(const SampledPath& path, const TableInterpolant& nc, const std::vector<double>& e) {
  return summarise_rows(path, nc, [&e](std::size_t j) { return e[j]; });
}

// The same, the interpolant evaluated row by row and nothing kept.
CommandError command_error_of(const SampledPath& path, const TableInterpolant& nc) {
  const std::size_t n = path.size();
  std::size_t segment = 0;
  return summarise_rows(path, nc, [&](std::size_t j) {
    const double c = j == n ? 360.0 : path.c_deg(j);
    return nc.x_mm_at(c, segment) - path.x_mm[j % n];
  });
}

// Whether `nc` keeps within bound_mm of the path at every row lo..hi (row n is C360).
bool keeps_bound_on_rows(const SampledPath& path, const TableInterpolant& nc, std::size_t lo, std::size_t hi,
                         double bound_mm) {
  const std::size_t n = path.size();
  std::size_t segment = 0;
  for (std::size_t j = lo; j <= hi; ++j) {
    const double c = j == n ? 360.0 : path.c_deg(j);
    if (!(std::abs(nc.x_mm_at(c, segment) - path.x_mm[j % n]) <= bound_mm)) return false;
  }
  return true;
}

Result<CurveTable> table_at_rows(const SampledPath& path, const std::vector<std::size_t>& rows,
                                 Interpolation interpolation, const CurveTableFormat& format, std::string writer) {
  CurveTable t;
  t.interpolation = interpolation;
  t.points = points_at_rows(path, rows, format, interpolation);
  t.writer = std::move(writer);
  Result<TableInterpolant> nc = TableInterpolant::of(t.points, interpolation);
  if (!nc) return nc.error();
  t.error = command_error_of(path, *nc);
  return t;
}

Status check_inputs(const SampledPath& path, const CurveTableFormat& format) {
  if (Status s = check_sampled_path_shape(path); !s) return s;
  return check_format(path, format);
}

Result<CurveTable> write_uniform(const SampledPath& path, double c_step_deg, const CurveTableFormat& format,
                                 Interpolation interpolation) {
  if (Status s = check_inputs(path, format); !s) return s.error();
  const std::size_t r = rows_per_step(path, c_step_deg);
  if (r == 0) {
    return make_error(ErrorCode::kInvalidInput, "table step " + format_fixed(c_step_deg, 4) +
                                                    " deg must divide 360 and be a whole multiple of the fine step " +
                                                    format_fixed(path.c_step_deg, 4) + " deg");
  }
  std::vector<std::size_t> rows;
  for (std::size_t k = 0; k <= path.size(); k += r) rows.push_back(k);
  if (rows.size() < 4) {
    return make_error(ErrorCode::kInvalidInput,
                      "table step " + format_fixed(c_step_deg, 4) + " deg gives fewer than 4 points");
  }
  const std::string kind = interpolation == Interpolation::kLinear        ? "linear "
                           : interpolation == Interpolation::kCubicSpline ? "spline "
                                                                          : "poly ";
  return table_at_rows(path, rows, interpolation, format, kind + format_fixed(c_step_deg, 3) + " deg");
}

Status check_adaptive(const AdaptiveSettings& s) {
  if (!(s.bound_um > 0.0) || !std::isfinite(s.bound_um)) {
    return make_error(ErrorCode::kInvalidInput, "command position error bound must be a positive number of um");
  }
  if (!(s.max_step_deg > 0.0) || !(s.max_step_deg <= 90.0)) {
    return make_error(ErrorCode::kInvalidInput, "widest table step must be in (0, 90] deg");
  }
  return {};
}

std::string refusal_where(const CommandError& e) {
  return format_fixed(e.max_abs_um, 3) + " um at C" + format_fixed(e.at_c_deg, 3);
}

// Fine rows in the widest table segment settings allow (at least 1).
std::size_t widest_rows(const SampledPath& path, const AdaptiveSettings& settings) {
  return std::max<std::size_t>(1, static_cast<std::size_t>(std::floor(settings.max_step_deg / path.c_step_deg + 1e-9)));
}

// The fine rows of the table in force's points: kInvalidInput unless they run from C0 to
// C360, increasing, each on a row of `path` (a table written on another grid cannot be kept).
Result<std::vector<std::size_t>> rows_of_points(const SampledPath& path, const TablePointsInForce& in_force) {
  const std::vector<double>& c = in_force.c_deg;
  if (c.size() < 4 || c.front() != 0.0 || std::abs(c.back() - 360.0) > 1e-6) {
    return make_error(ErrorCode::kInvalidInput, "the table in force must have at least 4 points from C0 to C360");
  }
  std::vector<std::size_t> rows;
  for (double at : c) {
    const double r = at / path.c_step_deg;
    const long long k = std::llround(r);
    if (std::abs(r - static_cast<double>(k)) > 1e-6 || k < 0 || static_cast<std::size_t>(k) > path.size() ||
        (!rows.empty() && static_cast<std::size_t>(k) <= rows.back())) {
      return make_error(ErrorCode::kInvalidInput, "point C" + format_fixed(at, 6) +
                                                      " of the table in force is not a row of the " +
                                                      format_fixed(path.c_step_deg, 4) + " deg path or not in order");
    }
    rows.push_back(static_cast<std::size_t>(k));
  }
  return rows;
}

// The fine row at `c_deg`, or nullopt when C is not on a row or not in [0, 360).
std::optional<std::size_t> row_at(const SampledPath& path, double c_deg) {
  const double r = c_deg / path.c_step_deg;
  const long long k = std::llround(r);
  if (std::abs(r - static_cast<double>(k)) > 1e-6 || k < 0 || static_cast<std::size_t>(k) >= path.size()) {
    return std::nullopt;
  }
  return static_cast<std::size_t>(k);
}

// `path` turned so that row k0 becomes row 0: a table over it from C0 is the table over `path`
// from C = k0 step.
SampledPath turned(const SampledPath& path, std::size_t k0) {
  const std::size_t n = path.size();
  SampledPath out = path;
  for (std::size_t j = 0; j < n; ++j) {
    out.x_mm[j] = path.x_mm[(j + k0) % n];
    out.dx_dc_mm_per_deg[j] = path.dx_dc_mm_per_deg[(j + k0) % n];
    out.d2x_dc2_mm_per_deg2[j] = path.d2x_dc2_mm_per_deg2[(j + k0) % n];
  }
  return out;
}

// A table written over the path turned by c0_deg, moved back: C from c0 to c0 + 360, the C of
// its largest error in [0, 360). X and the error are unchanged: same points, same rows.
CurveTable moved_back(CurveTable t, double c0_deg, const CurveTableFormat& format) {
  if (c0_deg == 0.0) return t;
  for (CurvePoint& p : t.points) p.c_deg = round_to(p.c_deg + c0_deg, format.c_decimals);
  t.points.back().c_deg = t.points.front().c_deg + 360.0;
  t.error.at_c_deg = std::fmod(t.error.at_c_deg + c0_deg, 360.0);
  t.writer += ", from C" + format_fixed(c0_deg, std::fmod(c0_deg, 1.0) == 0.0 ? 0 : 2);
  return t;
}

// The path turned to start at c0_deg (a row of the path), for writers whose tables are moved
// back: turned once however many tables are written over it (the default choice's CSPLINE
// candidates share one).
class TurnedPath {
 public:
  static Result<TurnedPath> of(const SampledPath& path, double c0_deg) {
    TurnedPath out;
    out.path_ = &path;
    out.c0_deg_ = c0_deg;
    if (c0_deg == 0.0) return out;
    const std::optional<std::size_t> k0 = row_at(path, c0_deg);
    if (!k0) {
      return make_error(ErrorCode::kInvalidInput, "table start C" + format_fixed(c0_deg, 6) + " is not a row of the " +
                                                      format_fixed(path.c_step_deg, 4) + " deg path");
    }
    out.turned_ = turned(path, *k0);
    return out;
  }

  // `write` run over the turned path, its table moved back.
  template <typename Write>
  Result<CurveTable> write(const CurveTableFormat& format, Write write) const {
    if (!turned_) return write(*path_);
    Result<CurveTable> t = write(*turned_);
    if (!t) {
      Error e = t.error();
      e.message += " (C counted from the table's start C" + format_fixed(c0_deg_, 3) + ")";
      return e;
    }
    return moved_back(std::move(*t), c0_deg_, format);
  }

 private:
  const SampledPath* path_ = nullptr;
  std::optional<SampledPath> turned_;
  double c0_deg_ = 0.0;
};

// A writer run over the path turned to start at c0_deg (a row of the path), its table moved back.
template <typename Write>
Result<CurveTable> written_from(const SampledPath& path, double c0_deg, const CurveTableFormat& format, Write write) {
  Result<TurnedPath> from = TurnedPath::of(path, c0_deg);
  if (!from) return from.error();
  return from->write(format, write);
}

}  // namespace

Result<TableInterpolant> TableInterpolant::of(const std::vector<CurvePoint>& points, Interpolation interpolation) {
  const std::size_t m = points.size();
  if (m < 2 || (interpolation == Interpolation::kCubicSpline && m < 3)) {
    return make_error(ErrorCode::kInvalidInput, "a table needs at least 2 points (3 for a spline)");
  }
  TableInterpolant t;
  t.interpolation_ = interpolation;
  for (std::size_t i = 0; i < m; ++i) {
    if (!std::isfinite(points[i].c_deg) || !std::isfinite(points[i].x_mm) ||
        (i > 0 && !(points[i].c_deg > points[i - 1].c_deg))) {
      return make_error(ErrorCode::kInvalidInput, "table point " + std::to_string(i) + " (C" +
                                                      format_fixed(points[i].c_deg, 3) +
                                                      ") is not finite or C does not increase");
    }
    t.c_deg_.push_back(points[i].c_deg);
    t.x_mm_.push_back(points[i].x_mm);
    if (interpolation == Interpolation::kPoly) {
      t.a2_mm_.push_back(points[i].a2_mm);
      t.a3_mm_.push_back(points[i].a3_mm);
    }
  }
  t.moment_.assign(m, 0.0);
  if (interpolation == Interpolation::kCubicSpline && m > 2) {
    // Natural cubic spline in moments M_i = S''(C_i), M_0 = M_{m-1} = 0 (BNAT, ENAT):
    // h_{i-1} M_{i-1} + 2 (h_{i-1} + h_i) M_i + h_i M_{i+1} = 6 (d_i - d_{i-1}), d the chord
    // slopes. Diagonally dominant tridiagonal: Thomas algorithm without pivoting is stable.
    const std::size_t k = m - 2;  // unknowns M_1 .. M_{m-2}
    std::vector<double> diag(k), upper(k), rhs(k);
    for (std::size_t j = 0; j < k; ++j) {
      const std::size_t i = j + 1;
      const double h0 = t.c_deg_[i] - t.c_deg_[i - 1];
      const double h1 = t.c_deg_[i + 1] - t.c_deg_[i];
      diag[j] = 2.0 * (h0 + h1);
      upper[j] = h1;
      rhs[j] = 6.0 * ((t.x_mm_[i + 1] - t.x_mm_[i]) / h1 - (t.x_mm_[i] - t.x_mm_[i - 1]) / h0);
      if (j > 0) {
        const double lower = h0;  // coefficient of M_{i-1}
        const double w = lower / diag[j - 1];
        diag[j] -= w * upper[j - 1];
        rhs[j] -= w * rhs[j - 1];
      }
    }
    for (std::size_t j = k; j-- > 0;) {
      const double next = j + 1 < k ? t.moment_[j + 2] : 0.0;
      t.moment_[j + 1] = (rhs[j] - upper[j] * next) / diag[j];
    }
  }
  return t;
}

TableInterpolant::Value TableInterpolant::at(double c_deg) const {
  std::size_t segment = c_deg_.size();  // no hint: search
  return at(c_deg, segment);
}

std::size_t TableInterpolant::locate(double c_deg, double& c, std::size_t& segment) const {
  const std::size_t m = c_deg_.size();
  // Outside the definition range a periodic table is read modulo its range (a table starting on
  // the base circle covers C0 this way); within it, as defined.
  c = c_deg;
  if (c < c_deg_.front() || c > c_deg_.back()) {
    const double range = c_deg_.back() - c_deg_.front();
    c = c_deg_.front() + std::fmod(std::fmod(c - c_deg_.front(), range) + range, range);
  }
  c = std::clamp(c, c_deg_.front(), c_deg_.back());
  // Segment i holds c_i <= C < c_i+1; the last one holds its end too (as upper_bound finds).
  // The hint first, then the segment after it, then a search.
  const double* cs = c_deg_.data();
  std::size_t i = segment;
  if (!(i + 2 <= m && cs[i] <= c && (c < cs[i + 1] || i + 2 == m))) {
    ++i;
    if (!(i + 2 <= m && cs[i] <= c && (c < cs[i + 1] || i + 2 == m))) {
      i = static_cast<std::size_t>(std::upper_bound(cs, cs + m, c) - cs);
      i = std::min(i == 0 ? 0 : i - 1, m - 2);
    }
  }
  segment = i;
  return i;
}

TableInterpolant::Value TableInterpolant::at(double c_deg, std::size_t& segment) const {
  double c = 0.0;
  const std::size_t i = locate(c_deg, c, segment);
  const double h = c_deg_[i + 1] - c_deg_[i];
  const double y0 = x_mm_[i];
  const double y1 = x_mm_[i + 1];
  Value v;
  v.x_mm = x_mm_in(i, c);
  if (interpolation_ == Interpolation::kLinear) {
    v.dx_dc_mm_per_deg = (y1 - y0) / h;
    return v;
  }
  if (interpolation_ == Interpolation::kPoly) {
    const double a2 = a2_mm_[i + 1];
    const double a3 = a3_mm_[i + 1];
    const double a1 = y1 - y0 - a2 - a3;
    const double p = (c - c_deg_[i]) / h;
    v.dx_dc_mm_per_deg = (a1 + p * (2.0 * a2 + 3.0 * p * a3)) / h;
    v.d2x_dc2_mm_per_deg2 = (2.0 * a2 + 6.0 * p * a3) / (h * h);
    return v;
  }
  const double a = (c_deg_[i + 1] - c) / h;
  const double b = (c - c_deg_[i]) / h;
  const double m0 = moment_[i];
  const double m1 = moment_[i + 1];
  v.dx_dc_mm_per_deg = (y1 - y0) / h + ((1.0 - 3.0 * a * a) * m0 + (3.0 * b * b - 1.0) * m1) * h / 6.0;
  v.d2x_dc2_mm_per_deg2 = a * m0 + b * m1;
  return v;
}

double TableInterpolant::max_abs_d2_mm_per_deg2() const {
  double m = 0.0;
  for (double v : moment_) m = std::max(m, std::abs(v));
  // POLY: X'' is linear across a segment, largest at one of its ends.
  for (std::size_t i = 1; i < a2_mm_.size(); ++i) {
    const double h = c_deg_[i] - c_deg_[i - 1];
    m = std::max({m, std::abs(2.0 * a2_mm_[i]) / (h * h), std::abs(2.0 * a2_mm_[i] + 6.0 * a3_mm_[i]) / (h * h)});
  }
  return m;
}

Result<CommandError> command_position_error(const SampledPath& path, const std::vector<CurvePoint>& points,
                                            Interpolation interpolation) {
  if (Status s = check_sampled_path_shape(path); !s) return s.error();
  if (Status s = validate_curve_points(points); !s) return make_error(ErrorCode::kInvalidInput, s.error().message);
  Result<TableInterpolant> nc = TableInterpolant::of(points, interpolation);
  if (!nc) return nc.error();
  return command_error_of(path, *nc);
}

Result<std::vector<double>> command_error_per_degree_um(const SampledPath& path, const CurveTable& table) {
  if (Status s = check_sampled_path_shape(path); !s) return s.error();
  Result<TableInterpolant> nc = TableInterpolant::of(table.points, table.interpolation);
  if (!nc) return nc.error();
  const std::vector<double> e = row_errors_mm(path, *nc);
  std::vector<double> out(360, 0.0);
  for (std::size_t j = 0; j < path.size(); ++j) {
    const auto d = std::min<std::size_t>(359, static_cast<std::size_t>(std::floor(path.c_deg(j) + 1e-9)));
    out[d] = std::max(out[d], std::abs(e[j]) * kUmPerMm);
  }
  return out;
}

Result<CurveTable> write_poly_table(const SampledPath& path, double c_step_deg, const CurveTableFormat& format) {
  return write_uniform(path, c_step_deg, format, Interpolation::kPoly);
}

Result<CurveTable> write_linear_table(const SampledPath& path, double c_step_deg, const CurveTableFormat& format) {
  return write_uniform(path, c_step_deg, format, Interpolation::kLinear);
}

double spline_start_c_deg(const SampledPath& path) {
  if (!check_sampled_path_shape(path)) return 0.0;
  const std::size_t n = path.size();
  // Score of row k: the largest |X''| within kSeamWindowDeg either side, a sliding maximum over
  // the periodic rows (a deque of candidate rows, each pushed and popped once).
  const std::size_t w = std::min(n / 4, static_cast<std::size_t>(std::llround(kSeamWindowDeg / path.c_step_deg)));
  auto bend = [&](std::size_t j) { return std::abs(path.d2x_dc2_mm_per_deg2[j % n]); };
  std::vector<double> score(n);
  std::deque<std::size_t> window;  // rows of the window, |X''| decreasing
  for (std::size_t j = 0; j < n + 2 * w; ++j) {
    while (!window.empty() && bend(window.back()) <= bend(j)) window.pop_back();
    window.push_back(j);
    if (j < 2 * w) continue;
    while (window.front() + 2 * w < j) window.pop_front();
    score[(j - w) % n] = bend(window.front());  // window centred on row j - w
  }
  double peak = 0.0;
  double least = std::numeric_limits<double>::infinity();
  for (double v : score) {
    peak = std::max(peak, v);
    least = std::min(least, v);
  }
  // Rows within a millionth of the largest bend of the least count as equally good: on a base
  // circle the spline of the lift still rings by that little. The seam goes to the middle of
  // the longest such run (the base circle's middle, furthest from either flank).
  const double tie = least + 1e-6 * peak;
  std::size_t start = 0;
  while (start < n && score[start] <= tie) ++start;
  if (start == n) return 0.0;  // the same bend everywhere: a circle; C0 is as good as any
  std::size_t best_first = 0;
  std::size_t best_length = 0;
  std::size_t run_first = 0;
  std::size_t run_length = 0;
  for (std::size_t i = 1; i <= n; ++i) {
    const std::size_t k = (start + i) % n;
    if (i < n && score[k] <= tie) {
      if (run_length == 0) run_first = k;
      ++run_length;
      continue;
    }
    if (run_length > best_length) {
      best_first = run_first;
      best_length = run_length;
    }
    run_length = 0;
  }
  return path.c_deg((best_first + (best_length - 1) / 2) % n);
}

namespace {

// A CSPLINE table of step c_step_deg over the path turned to its seam.
Result<CurveTable> spline_over(const TurnedPath& seam, double c_step_deg, const CurveTableFormat& format) {
  return seam.write(
      format, [&](const SampledPath& p) { return write_uniform(p, c_step_deg, format, Interpolation::kCubicSpline); });
}

}  // namespace

Result<CurveTable> write_spline_table(const SampledPath& path, double c_step_deg, const CurveTableFormat& format) {
  if (Status s = check_inputs(path, format); !s) return s.error();
  Result<TurnedPath> seam = TurnedPath::of(path, spline_start_c_deg(path));
  if (!seam) return seam.error();
  return spline_over(*seam, c_step_deg, format);
}

Result<CurveTable> write_adaptive_linear_table(const SampledPath& path, const AdaptiveSettings& settings,
                                               const CurveTableFormat& format) {
  if (Status s = check_inputs(path, format); !s) return s.error();
  if (Status s = check_adaptive(settings); !s) return s.error();
  const std::size_t n = path.size();
  const double bound_mm = settings.bound_um / kUmPerMm;
  const std::size_t max_rows = widest_rows(path, settings);
  auto x_written = [&](std::size_t k) { return format.round_x_mm(path.x_mm[k % n]); };
  // The chord from row a to row b as written keeps the bound at every row in between.
  auto keeps_bound = [&](std::size_t a, std::size_t b) {
    const double ya = x_written(a);
    const double slope = (x_written(b) - ya) / static_cast<double>(b - a);
    for (std::size_t j = a; j <= b; ++j) {
      if (std::abs(ya + slope * static_cast<double>(j - a) - path.x_mm[j % n]) > bound_mm) return false;
    }
    return true;
  };
  std::vector<std::size_t> rows{0};
  std::size_t a = 0;
  while (a < n) {
    const std::size_t reach = std::min(max_rows, n - a);
    if (!keeps_bound(a, a + 1)) {
      return make_error(ErrorCode::kRefused, "adaptive G1 table: even one fine step at C" +
                                                 format_fixed(path.c_deg(a), 3) + " breaks the " +
                                                 format_fixed(settings.bound_um, 3) + " um bound (rounding to " +
                                                 format_fixed(1000.0 / format.x_increments_per_mm, 3) +
                                                 " um, the control's X resolution?); raise MD10200 and "
                                                 "int_incr_per_mm, or the bound");
    }
    // Furthest row that keeps the bound: grow the chord by doubling, then bisect between the
    // last length that kept it and the first that did not. A chord of X that bends one way
    // keeps the bound on every shorter chord too, so this finds the furthest row there.
    std::size_t good = 1;
    std::size_t bad = 0;
    while (good < reach) {
      const std::size_t next = std::min(good * 2, reach);
      if (keeps_bound(a, a + next)) {
        good = next;
      } else {
        bad = next;
        break;
      }
    }
    while (bad != 0 && bad - good > 1) {
      const std::size_t mid = good + (bad - good) / 2;
      if (keeps_bound(a, a + mid)) {
        good = mid;
      } else {
        bad = mid;
      }
    }
    a += good;
    rows.push_back(a);
  }
  return table_at_rows(path, rows, Interpolation::kLinear, format,
                       "adaptive linear, bound " + format_fixed(settings.bound_um, 3) + " um");
}

namespace {

Result<CurveTable> adaptive_spline_from_c0(const SampledPath& path, const AdaptiveSettings& settings,
                                           const CurveTableFormat& format) {
  if (Status s = check_adaptive(settings); !s) return s.error();
  const std::size_t n = path.size();
  const double bound_mm = settings.bound_um / kUmPerMm;
  std::optional<CurveTable> best;
  CommandError closest;
  closest.max_abs_um = std::numeric_limits<double>::infinity();
  const std::size_t max_rows = widest_rows(path, settings);
  for (double start_deg : {settings.max_step_deg, 2.0, 1.0}) {
    if (start_deg > settings.max_step_deg) continue;
    const std::size_t r = rows_per_step(path, start_deg);
    if (r == 0 || n / r < 3) continue;
    std::vector<std::size_t> rows;
    for (std::size_t k = 0; k <= n; k += r) rows.push_back(k);
    std::vector<double> e;  // each round's row errors, one buffer
    // Halve each segment that breaks the bound; 40 rounds halve a segment far below a row.
    for (int round = 0; round < 40; ++round) {
      const std::vector<CurvePoint> pts = points_at_rows(path, rows, format);
      Result<TableInterpolant> nc = TableInterpolant::of(pts, Interpolation::kCubicSpline);
      if (!nc) return nc.error();
      fill_row_errors_mm(path, *nc, e);
      std::vector<std::size_t> next{rows.front()};
      bool split = false;
      bool stuck = false;
      for (std::size_t i = 0; i + 1 < rows.size(); ++i) {
        double worst = 0.0;
        for (std::size_t j = rows[i]; j <= rows[i + 1]; ++j) worst = std::max(worst, std::abs(e[j]));
        if (worst > bound_mm) {
          if (rows[i + 1] - rows[i] >= 2) {
            next.push_back(rows[i] + (rows[i + 1] - rows[i]) / 2);
            split = true;
          } else {
            stuck = true;
          }
        }
        next.push_back(rows[i + 1]);
      }
      if (!split) {
        if (!stuck) {
          // Halving overshoots: drop every point whose removal still keeps the bound and the
          // widest step (one pass; C0 and C360 stay). A trial is judged on the rows within 8
          // points either side: the influence of one point on a cubic spline decays by
          // 2 - sqrt(3) = 0.27 a point, so beyond that the change is below 1e-4 of the local
          // one. The pruned table is then evaluated in full, and kept only if it holds.
          std::vector<std::size_t> pruned = rows;
          std::vector<CurvePoint> pruned_points = pts;  // each point depends on its row alone
          std::vector<std::size_t> fewer;               // a trial's rows and points, their storage reused
          std::vector<CurvePoint> fewer_points;
          for (std::size_t i = 1; i + 1 < pruned.size();) {
            if (pruned[i + 1] - pruned[i - 1] > max_rows || pruned.size() <= 4) {
              ++i;
              continue;
            }
            fewer.assign(pruned.begin(), pruned.end());
            fewer.erase(fewer.begin() + static_cast<std::ptrdiff_t>(i));
            fewer_points.assign(pruned_points.begin(), pruned_points.end());
            fewer_points.erase(fewer_points.begin() + static_cast<std::ptrdiff_t>(i));
            Result<TableInterpolant> trial = TableInterpolant::of(fewer_points, Interpolation::kCubicSpline);
            if (!trial) return trial.error();
            const std::size_t lo = fewer[i >= 9 ? i - 9 : 0];
            const std::size_t hi = fewer[std::min(i + 8, fewer.size() - 1)];
            if (keeps_bound_on_rows(path, *trial, lo, hi, bound_mm)) {
              std::swap(pruned, fewer);
              std::swap(pruned_points, fewer_points);
            } else {
              ++i;
            }
          }
          Result<TableInterpolant> full = TableInterpolant::of(pruned_points, Interpolation::kCubicSpline);
          if (!full) return full.error();
          if (keeps_bound_on_rows(path, *full, 0, n, bound_mm)) rows = std::move(pruned);
          Result<CurveTable> t = table_at_rows(path, rows, Interpolation::kCubicSpline, format,
                                               "adaptive spline from " + format_fixed(start_deg, 3) + " deg, bound " +
                                                   format_fixed(settings.bound_um, 3) + " um");
          if (!t) return t.error();
          if (!best || t->block_count() < best->block_count()) best = std::move(*t);
        } else {
          CommandError ce = summarise(path, *nc, e);
          if (ce.max_abs_um < closest.max_abs_um) closest = ce;
        }
        break;
      }
      rows = std::move(next);
    }
  }
  if (!best) {
    return make_error(ErrorCode::kRefused, "adaptive CSPLINE table: no knot choice keeps the " +
                                               format_fixed(settings.bound_um, 3) + " um bound; closest " +
                                               refusal_where(closest) + "; use a G1 table or raise the bound");
  }
  return std::move(*best);
}

// The adaptive CSPLINE table over the path turned to its seam.
Result<CurveTable> adaptive_spline_over(const TurnedPath& seam, const AdaptiveSettings& settings,
                                        const CurveTableFormat& format) {
  return seam.write(format, [&](const SampledPath& p) { return adaptive_spline_from_c0(p, settings, format); });
}

}  // namespace

Result<CurveTable> write_adaptive_spline_table(const SampledPath& path, const AdaptiveSettings& settings,
                                               const CurveTableFormat& format) {
  if (Status s = check_inputs(path, format); !s) return s.error();
  Result<TurnedPath> seam = TurnedPath::of(path, spline_start_c_deg(path));
  if (!seam) return seam.error();
  return adaptive_spline_over(*seam, settings, format);
}

namespace {

// The table in force's points as seen from its own start: C0 .. C360.
TablePointsInForce from_its_start(const TablePointsInForce& in_force) {
  TablePointsInForce out = in_force;
  if (!out.c_deg.empty()) {
    const double c0 = in_force.c_deg.front();
    for (double& c : out.c_deg) c -= c0;
  }
  return out;
}

double start_of(const TablePointsInForce& in_force) { return in_force.c_deg.empty() ? 0.0 : in_force.c_deg.front(); }

}  // namespace

Result<CurveTable> write_table_at_points(const SampledPath& path, const TablePointsInForce& in_force,
                                         const CurveTableFormat& format) {
  if (Status s = check_inputs(path, format); !s) return s.error();
  const TablePointsInForce own = from_its_start(in_force);
  return written_from(path, start_of(in_force), format, [&](const SampledPath& p) -> Result<CurveTable> {
    Result<std::vector<std::size_t>> rows = rows_of_points(p, own);
    if (!rows) return rows.error();
    return table_at_rows(p, *rows, in_force.interpolation, format, "points of the table in force");
  });
}

namespace {

// `in_force`'s points with X from `path`, plus, in every segment that breaks the bound, the
// row where it breaks it most (in one wider than the widest step, its middle), until none
// does or 40 rounds have passed (the caller checks the bound).
Result<CurveTable> refine_points_in_force(const SampledPath& path, const TablePointsInForce& in_force,
                                          const AdaptiveSettings& settings, const CurveTableFormat& format) {
  Result<std::vector<std::size_t>> kept = rows_of_points(path, in_force);
  if (!kept) return kept.error();
  std::vector<std::size_t> rows = std::move(*kept);
  const std::size_t points_in_force = rows.size();
  const double bound_mm = settings.bound_um / kUmPerMm;
  const std::size_t max_rows = widest_rows(path, settings);
  std::vector<double> e;  // each round's row errors, one buffer
  for (int round = 0; round < 40; ++round) {
    Result<TableInterpolant> nc =
        TableInterpolant::of(points_at_rows(path, rows, format, in_force.interpolation), in_force.interpolation);
    if (!nc) return nc.error();
    fill_row_errors_mm(path, *nc, e);
    std::vector<std::size_t> next{rows.front()};
    bool split = false;
    for (std::size_t i = 0; i + 1 < rows.size(); ++i) {
      std::size_t worst = rows[i];
      for (std::size_t j = rows[i]; j <= rows[i + 1]; ++j) {
        if (std::abs(e[j]) > std::abs(e[worst])) worst = j;
      }
      const bool too_wide = rows[i + 1] - rows[i] > max_rows;
      if (std::abs(e[worst]) > bound_mm || too_wide) {
        if (too_wide || worst == rows[i] || worst == rows[i + 1]) worst = rows[i] + (rows[i + 1] - rows[i]) / 2;
        if (worst != rows[i]) {
          next.push_back(worst);
          split = true;
        }
      }
      next.push_back(rows[i + 1]);
    }
    if (!split) break;
    rows = std::move(next);
  }
  const std::size_t added = rows.size() - points_in_force;
  return table_at_rows(path, rows, in_force.interpolation, format,
                       added == 0 ? "points of the table in force"
                                  : "points of the table in force, " + std::to_string(added) + " added");
}

}  // namespace

Result<std::vector<TableCandidate>> default_table_candidates(const SampledPath& path,
                                                             const TableChoiceSettings& settings,
                                                             const CurveTableFormat& format) {
  const AdaptiveSettings adaptive{settings.bound_um, settings.max_step_deg};
  if (Status s = check_inputs(path, format); !s) return s.error();
  if (Status s = check_adaptive(adaptive); !s) return s.error();
  std::vector<TableCandidate> out;
  auto add = [&out](std::string writer, Result<CurveTable> t) -> Status {
    TableCandidate c;
    c.writer = std::move(writer);
    if (t) {
      c.table = std::move(*t);
    } else if (t.error().code == ErrorCode::kRefused) {
      c.refused = t.error().message;
    } else {
      return t.error();
    }
    out.push_back(std::move(c));
    return {};
  };
  auto step_text = [](double step) { return format_fixed(step, step < 0.5 ? 2 : (step < 1.0 ? 1 : 0)); };
  for (double step : {1.0, 0.5, 0.25, 0.2, 0.1}) {
    if (rows_per_step(path, step) == 0) continue;
    if (Status s = add("linear " + step_text(step) + " deg", write_linear_table(path, step, format)); !s) {
      return s.error();
    }
  }
  if (Status s = add("adaptive linear", write_adaptive_linear_table(path, adaptive, format)); !s) return s.error();
  if (settings.allow_spline) {
    // One seam and one turned path for every CSPLINE candidate.
    Result<TurnedPath> seam = TurnedPath::of(path, spline_start_c_deg(path));
    if (!seam) return seam.error();
    for (double step : {5.0, 4.0, 3.0, 2.0, 1.0, 0.5}) {
      if (step > settings.max_step_deg || rows_per_step(path, step) == 0) continue;
      if (Status s = add("spline " + step_text(step) + " deg", spline_over(*seam, step, format)); !s) {
        return s.error();
      }
    }
    if (Status s = add("adaptive spline", adaptive_spline_over(*seam, adaptive, format)); !s) return s.error();
  }
  return out;
}

Result<CurveTable> write_default_table(const SampledPath& path, const TableChoiceSettings& settings,
                                       const CurveTableFormat& format, const TablePointsInForce* in_force) {
  const AdaptiveSettings adaptive{settings.bound_um, settings.max_step_deg};
  Result<std::vector<TableCandidate>> candidates = default_table_candidates(path, settings, format);
  if (!candidates) return candidates.error();
  std::optional<CurveTable> best;
  CommandError closest;
  closest.max_abs_um = std::numeric_limits<double>::infinity();
  for (TableCandidate& candidate : *candidates) {
    if (!candidate.table) continue;
    CurveTable& c = *candidate.table;
    if (c.error.max_abs_um < closest.max_abs_um) closest = c.error;
    if (c.error.max_abs_um > settings.bound_um) continue;
    const bool fewer = !best || c.block_count() < best->block_count() ||
                       (c.block_count() == best->block_count() && c.interpolation == Interpolation::kLinear &&
                        best->interpolation != Interpolation::kLinear);
    if (fewer) best = std::move(c);
  }
  if (!best) {
    return make_error(ErrorCode::kRefused, "no curve table keeps the command position error at or below " +
                                               format_fixed(settings.bound_um, 3) + " um; the closest reached " +
                                               refusal_where(closest) +
                                               "; raise the bound or allow CSPLINE tables; nothing was written");
  }
  if (in_force && (in_force->interpolation == Interpolation::kLinear || settings.allow_spline)) {
    const TablePointsInForce own = from_its_start(*in_force);
    Result<CurveTable> kept = written_from(path, start_of(*in_force), format, [&](const SampledPath& p) {
      return refine_points_in_force(p, own, adaptive, format);
    });
    if (kept && kept->error.max_abs_um <= settings.bound_um &&
        kept->block_count() <= kKeptBlocksOverFewest * best->block_count()) {
      return kept;
    }
  }
  return std::move(*best);
}

}  // namespace gaugeloop
