// Validation and formatting of curve-table points.
#include "nc_out/curve_table.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/number_text.h"

namespace gaugeloop {
namespace {

std::string point_name(const std::vector<CurvePoint>& points, size_t i) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "point %zu (C%.3f)", i, points[i].c_deg);
  return buf;
}

}  // namespace

int CurveTableFormat::x_decimals() const {
  // 1e-9: log10 of a power of ten is not always exact in binary.
  return std::max(0, static_cast<int>(std::ceil(std::log10(x_increments_per_mm) - 1e-9)));
}

double CurveTableFormat::round_x_mm(double x_mm) const {
  const double r = std::round(x_mm * x_increments_per_mm) / x_increments_per_mm;
  return r == 0.0 ? 0.0 : r;
}

double CurveTableFormat::round_coefficient_mm(double a_mm) const {
  const double q = std::pow(10.0, coefficient_decimals());
  const double r = std::round(a_mm * q) / q;
  return r == 0.0 ? 0.0 : r;
}

Status check_x_resolution(double x_increments_per_mm, std::string_view where) {
  if (!(x_increments_per_mm >= 1.0 && x_increments_per_mm <= 1e6) ||
      x_increments_per_mm != std::round(x_increments_per_mm)) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(where) + ": " + format_fixed(x_increments_per_mm, 3) +
                          " increments per mm: expected a whole number 1..1000000, the control's MD10200 "
                          "$MN_INT_INCR_PER_MM (10000 for 0.1 um)");
  }
  return {};
}

Status validate_curve_points(const std::vector<CurvePoint>& points) {
  if (points.size() < 4) {
    return make_error(ErrorCode::kInvalidInput, "curve table has " + std::to_string(points.size()) +
                                                    " points; a periodic table needs at least 4");
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i].c_deg) || !std::isfinite(points[i].x_mm) || !std::isfinite(points[i].a2_mm) ||
        !std::isfinite(points[i].a3_mm)) {
      return make_error(ErrorCode::kRefused,
                        "curve table " + point_name(points, i) + " has NaN or infinity; nothing was written");
    }
    if (i > 0 && !(points[i].c_deg > points[i - 1].c_deg)) {
      return make_error(ErrorCode::kInternal,
                        "curve table " + point_name(points, i) + ": C does not increase; nothing was written");
    }
  }
  // One turn to well within C's resolution (0.001 deg): a start such as C179.99 read back from
  // its text is not exactly 360 below the end's double.
  if (!(points.front().c_deg >= 0.0 && points.front().c_deg < 360.0) ||
      std::abs(points.back().c_deg - (points.front().c_deg + 360.0)) > 1e-6) {
    return make_error(ErrorCode::kInternal,
                      "a periodic curve table must run over one turn, from C0 to C360 or "
                      "from a start below C360 to 360 deg after it");
  }
  if (std::abs(points.front().x_mm - points.back().x_mm) > 1e-9) {
    return make_error(ErrorCode::kInternal, "a periodic curve table must end at the X it starts with");
  }
  return {};
}

std::string_view interpolation_name(Interpolation interpolation) {
  switch (interpolation) {
    case Interpolation::kLinear:
      return "linear";
    case Interpolation::kCubicSpline:
      return "cspline";
    case Interpolation::kPoly:
      return "poly";
  }
  return "linear";
}

std::string render_curve_blocks(const std::vector<CurvePoint>& points, const CurveTableFormat& format) {
  return render_table_blocks(points, Interpolation::kLinear, format);
}

std::string render_table_blocks(const std::vector<CurvePoint>& points, Interpolation interpolation,
                                const CurveTableFormat& format, std::string_view following_axis,
                                std::string_view leading_axis) {
  const std::string lead(leading_axis);
  const std::string lead_word = lead + (lead.size() > 1 ? "=" : "");
  std::string out;
  out.reserve(points.size() * 24 + 32);
  for (size_t i = 0; i < points.size(); ++i) {
    if (i > 0) out += '\n';
    // A tiny negative infeed prints as 0.0000, not as a signed zero (format_fixed).
    const std::string c = format_fixed(points[i].c_deg, format.c_decimals);
    const std::string x = format_fixed(format.round_x_mm(points[i].x_mm), format.x_decimals());
    if (i > 0 && interpolation == Interpolation::kPoly) {
      const int ad = format.coefficient_decimals();
      out += std::string(i == 1 ? "POLY " : "") + "PO[" + lead + "]=(" + c + ") PO[" + std::string(following_axis) +
             "]=(" + x + "," + format_fixed(format.round_coefficient_mm(points[i].a2_mm), ad) + "," +
             format_fixed(format.round_coefficient_mm(points[i].a3_mm), ad) + ")";
      continue;
    }
    if (i == 0) {
      out += "G1 ";
    } else if (i == 1 && interpolation == Interpolation::kCubicSpline) {
      out += "BNAT ENAT CSPLINE ";
    }
    out += lead_word + c + " " + std::string(following_axis) + x;
  }
  return out;
}

}  // namespace gaugeloop
