// A slide's compensation table: linear between its points, held beyond them.
#include "core/slide_table.h"

#include <algorithm>
#include <cmath>

namespace gaugeloop {

double SlideCompensationTable::max_mm() const {
  return min_mm + step_mm * static_cast<double>(error_mm.empty() ? 0 : error_mm.size() - 1);
}

double SlideCompensationTable::taken_out_mm(double position_mm) const {
  if (error_mm.empty()) return 0.0;
  if (position_mm <= min_mm || error_mm.size() == 1) return error_mm.front();
  const double u = (position_mm - min_mm) / step_mm;
  // Beyond the last point, and a position that is not a number, hold the last value.
  if (!(u < static_cast<double>(error_mm.size() - 1))) return error_mm.back();
  const auto i = static_cast<std::size_t>(std::floor(u));
  const double t = u - static_cast<double>(i);
  return error_mm[i] + t * (error_mm[i + 1] - error_mm[i]);
}

double taken_out_mm(const std::vector<SlideCompensationTable>& tables, char output_axis, double y_mm, double z_mm) {
  double sum = 0.0;
  for (const SlideCompensationTable& t : tables) {
    if (t.output_axis != output_axis) continue;
    sum += t.taken_out_mm(t.input_axis == 'Y' ? y_mm : z_mm);
  }
  return sum;
}

}  // namespace gaugeloop
