// The exact wheel path as nc_out receives it: X and its C-derivatives on a fine uniform C grid.
//
// nc_out does not call compensation: app/ fills this from compensation's MachinePath (same
// rows, same units), so nc_out depends on core/ only.
//
// Frame: machine frame. Row k is the work spindle at C = k * c_step_deg, k = 0 .. n-1 with
// n = 360 / c_step_deg; the path is periodic, row n would be row 0 again. x_mm is the wheel
// infeed X in mm (0 on the base circle), dx_dc_mm_per_deg = dX/dC, d2x_dc2_mm_per_deg2 =
// d2X/dC2. The rows are exact values of the path (not an interpolation of coarser data), so
// the command position error of a table is measured against them; see docs/nc_output.md for
// how fine the grid must be (0.01 deg is the product's choice).
#pragma once

#include <cstddef>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

struct SampledPath {
  double c_step_deg = 0.01;
  std::vector<double> x_mm;
  std::vector<double> dx_dc_mm_per_deg;
  std::vector<double> d2x_dc2_mm_per_deg2;

  std::size_t size() const { return x_mm.size(); }
  double c_deg(std::size_t k) const { return static_cast<double>(k) * c_step_deg; }
};

// The number of rows a step gives, if 360 / step is a whole number (to 1e-9); 0 otherwise.
std::size_t rows_per_turn(double c_step_deg);

// Checks the shape only (values are the guards' business, see table_guards.h): step in
// (0, 1] deg with 360 / step whole, the three vectors of n = 360 / step rows each.
// kInvalidInput naming what is wrong.
Status check_sampled_path_shape(const SampledPath& path);

}  // namespace gaugeloop
