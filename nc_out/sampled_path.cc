// Shape checks of the fine wheel path.
#include "nc_out/sampled_path.h"

#include <cmath>
#include <string>

namespace gaugeloop {

std::size_t rows_per_turn(double c_step_deg) {
  if (!(c_step_deg > 0.0) || !std::isfinite(c_step_deg)) return 0;
  const double n = 360.0 / c_step_deg;
  if (std::abs(n - std::round(n)) > 1e-9 * n) return 0;
  return static_cast<std::size_t>(std::llround(n));
}

Status check_sampled_path_shape(const SampledPath& path) {
  const std::size_t n = rows_per_turn(path.c_step_deg);
  if (n == 0 || path.c_step_deg > 1.0) {
    return make_error(ErrorCode::kInvalidInput, "fine wheel path step " + std::to_string(path.c_step_deg) +
                                                    " deg must divide 360 and be at most 1 deg (e.g. 0.01)");
  }
  if (path.x_mm.size() != n || path.dx_dc_mm_per_deg.size() != n || path.d2x_dc2_mm_per_deg2.size() != n) {
    return make_error(ErrorCode::kInvalidInput,
                      "fine wheel path at " + std::to_string(path.c_step_deg) + " deg needs " + std::to_string(n) +
                          " rows of X, dX/dC and d2X/dC2; it has " + std::to_string(path.x_mm.size()) + ", " +
                          std::to_string(path.dx_dc_mm_per_deg.size()) + " and " +
                          std::to_string(path.d2x_dc2_mm_per_deg2.size()));
  }
  return {};
}

}  // namespace gaugeloop
