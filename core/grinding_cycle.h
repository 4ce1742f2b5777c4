// How the wheel takes a part from its blank to size: the allowance (stock) per side and the
// passes that grind it off. The seam between the part file (config), the main program's
// infeed (nc_out) and the virtual grinder: plain data, each side checks what it needs.
//
// Units: mm, radial (per side), measured along the wheel's infeed X; turns of the work
// spindle C. The curve table is at final size: X = table(C) is the finished part; the
// passes feed the wheel from the start offset (stock + air gap) down to it (docs/nc_output.md,
// "Allowance and infeed").
#pragma once

namespace gaugeloop {

struct GrindingCycle {
  double stock_mm = 0.2;     // allowance per side the part comes with
  double air_gap_mm = 0.05;  // the wheel starts this far off the stock
  // Roughing: the stock less finishing_stock_mm, and the air gap, at this infeed per turn.
  double roughing_infeed_mm_per_turn = 0.02;
  // Finishing: the last of the stock at the finishing infeed per turn.
  double finishing_stock_mm = 0.02;
  double finishing_infeed_mm_per_turn = 0.005;
  int spark_out_turns = 2;  // turns at size, no infeed: the wheel and part relax
};

}  // namespace gaugeloop
