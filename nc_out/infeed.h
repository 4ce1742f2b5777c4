// The main program's passes from the blank to size: the wheel starts at the start offset
// (stock + air gap) from the curve table, which is at final size, and is fed towards the part
// over whole turns of C while the table couples X to C.
//
// Frame and units: machine frame; X the wheel infeed in mm, growing as the wheel moves away
// from the part (a lobe's and a pin's alike), so a pass feeds by a negative increment; C the
// work spindle in degrees. Pure text and arithmetic: no I/O.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/grinding_cycle.h"
#include "core/result.h"
#include "nc_out/curve_table.h"

namespace gaugeloop {

// One pass: `turns` whole turns of C, the wheel fed `infeed_mm` towards the part over them.
struct InfeedPass {
  std::string name;  // "roughing", "finishing", "spark-out"
  int turns = 0;
  double infeed_mm = 0.0;  // >= 0, on the control's grid (CurveTableFormat::round_x_mm)
};

struct InfeedPlan {
  // Where the wheel starts, from the table's path: stock + air gap, on the control's grid;
  // the passes' infeeds add up to it exactly, so the last pass ends at the table (final size).
  double start_offset_mm = 0.0;
  std::vector<InfeedPass> passes;  // roughing (air gap and stock less the finishing stock),
                                   // finishing, spark-out; a pass of no turns is left out
  int turns() const;
};

// kInvalidInput naming the part file's key (`[grinding] <key>`), its value and what is
// allowed: stock_mm in [0, 5], air_gap_mm in [0, 5], the infeeds per turn in (0, 1],
// finishing_stock_mm in [0, stock_mm], spark_out_turns in [0, 100], and at most 1000 turns in
// all.
Status validate(const GrindingCycle& cycle);

// The passes of `cycle`, each of the fewest whole turns whose infeed per turn keeps the
// cycle's; increments on the grid of `format` (MD10200). Errors as validate.
Result<InfeedPlan> plan_infeed(const GrindingCycle& cycle, const CurveTableFormat& format = {});

// The passes at one work speed, for {{infeed_blocks}} of a main program that couples X to C
// and turns C itself: FGROUP(C) (the feed is C's: F in deg/min, 360 * work_speed_rpm), one
// `G1 G91 C<360 n> X-<infeed> F<feed>` block a pass, then G90 and FGROUP(). Lines joined with
// "\n", none after the last.
std::string render_infeed_blocks(const InfeedPlan& plan, double work_speed_rpm, const CurveTableFormat& format = {});

// The passes under a speed subprogram (nc_out/speed_table.h), for {{infeed_blocks}} of a main
// program that turns C by calling it: per pass `R1=<infeed per turn>` (negative: towards the
// part) and `<speed_subprogram> P<turns>`; the subprogram's blocks feed X by R1 over each turn
// (X=IC(R1*<turn of the block>/360)). Ends with R1=0.
std::string render_speed_infeed_blocks(const InfeedPlan& plan, std::string_view speed_subprogram);

// What the main program's passes need, carried in the table program's header
// (`; gaugeloop grinding_cycle: ...`, TableProvenance), so a main program rendered again for
// an approval or a rollback has the part's passes without its part file.
struct CycleOnControl {
  GrindingCycle cycle;
  double work_speed_rpm = 60.0;
  CurveTableFormat format;  // the control's grid (MD10200)
};

// "stock_mm 0.2000 air_gap_mm 0.0500 roughing_infeed_mm_per_turn 0.0200 finishing_stock_mm
// 0.0200 finishing_infeed_mm_per_turn 0.0050 spark_out_turns 2 work_speed_rpm 60.000
// int_incr_per_mm 10000": key and value pairs, one line.
std::string grinding_cycle_text(const CycleOnControl& c);

// Reads grinding_cycle_text back; kInvalidInput naming the pair that does not read.
Result<CycleOnControl> read_grinding_cycle_text(std::string_view text);

// The R parameter a speed subprogram reads its infeed per turn from.
inline constexpr std::string_view kSpeedInfeedParameter = "R1";

}  // namespace gaugeloop
