// Validation and formatting of curve-table points.
#include "nc_out/curve_table.h"

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

Status validate_curve_points(const std::vector<CurvePoint>& points) {
  if (points.size() < 4) {
    return make_error(ErrorCode::kInvalidInput, "curve table has " + std::to_string(points.size()) +
                                                    " points; a periodic table needs at least 4");
  }
  for (size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i].c_deg) || !std::isfinite(points[i].x_mm)) {
      return make_error(ErrorCode::kRefused,
                        "curve table " + point_name(points, i) + " has NaN or infinity; nothing was written");
    }
    if (i > 0 && !(points[i].c_deg > points[i - 1].c_deg)) {
      return make_error(ErrorCode::kInternal,
                        "curve table " + point_name(points, i) + ": C does not increase; nothing was written");
    }
  }
  if (points.front().c_deg != 0.0 || points.back().c_deg != 360.0) {
    return make_error(ErrorCode::kInternal, "a periodic curve table must run from C0 to C360");
  }
  if (std::abs(points.front().x_mm - points.back().x_mm) > 1e-9) {
    return make_error(ErrorCode::kInternal, "a periodic curve table must end at the X it starts with");
  }
  return {};
}

std::string_view interpolation_name(Interpolation interpolation) {
  return interpolation == Interpolation::kLinear ? "linear" : "cspline";
}

std::string render_curve_blocks(const std::vector<CurvePoint>& points, const CurveTableFormat& format) {
  return render_table_blocks(points, Interpolation::kLinear, format);
}

std::string render_table_blocks(const std::vector<CurvePoint>& points, Interpolation interpolation,
                                const CurveTableFormat& format) {
  std::string out;
  out.reserve(points.size() * 24 + 32);
  for (size_t i = 0; i < points.size(); ++i) {
    if (i > 0) out += '\n';
    if (i == 0) {
      out += "G1 ";
    } else if (i == 1 && interpolation == Interpolation::kCubicSpline) {
      out += "BNAT ENAT CSPLINE ";
    }
    // A tiny negative infeed prints as 0.0000, not as a signed zero (format_fixed).
    out +=
        "C" + format_fixed(points[i].c_deg, format.c_decimals) + " X" + format_fixed(points[i].x_mm, format.x_decimals);
  }
  return out;
}

}  // namespace gaugeloop
