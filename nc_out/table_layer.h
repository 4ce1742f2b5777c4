// The correction as a layer of its own (docs/nc_output.md, "The correction as a layer"): the
// design's whole table stays on the control as it was approved, X from C; a second table
// holds the correction alone, X from the virtual axis SIM1 that follows C 1:1, and the
// electronic gearbox adds the two. What the control commands is
//   X(C) = design(C) + layer(SIM1 = C),
// each table as the NC interpolates it. The layer is written against the design table as the
// control interpolates it (not the exact design path), so the sum is the corrected path to the
// layer's own command error: the design table's interpolation error is corrected too.
//
// Frames and units as nc_out: machine frame, C and SIM1 in degrees, X in mm.
#pragma once

#include <string>
#include <string_view>

#include "core/result.h"
#include "nc_out/sampled_path.h"
#include "nc_out/table_guards.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"

namespace gaugeloop {

// The design table a layer is summed with, read from its program: what the NC makes of it.
struct DesignTable {
  ParsedTable parsed;
  TableInterpolant nc;
};

// Reads the design table's program `text` (file `file_name`, for messages): one periodic
// CTABDEF of X from C defining table `number`, its checksum intact. kInvalidInput naming the
// file and what is wrong (parse errors with the line); kRefused for a design table edited by
// hand (its checksum), which the loop does not build on until a person writes it again.
Result<DesignTable> read_design_table(std::string_view text, std::string_view file_name, int number);

// The layer the control must add to `design` to command `whole` (the exact corrected path):
// whole - design at every row, with the derivatives' differences (a G1 design's kinks show
// in the layer's slope, negated). Shape errors as check_sampled_path_shape.
Result<SampledPath> layer_path(const SampledPath& whole, const TableInterpolant& design);

// The guards of the sum as the control runs it: design and layer interpolated at the rows of
// `whole` and added, then check_path_guards on that path (travel, velocity, acceleration).
Status check_layered_guards(const CurveTable& layer, const TableInterpolant& design, const SampledPath& whole,
                            const AxisLimits& limits);

// The design table named by a layer program's header (design_program, design_table_number):
// empty name when the table is not a layer. kInvalidInput for a layer whose header names the
// design table's number but not its program, or a number that cannot be read.
struct LayerOf {
  std::string design_program;  // empty: not a layer
  int design_table_number = 0;
};
Result<LayerOf> layer_of(const ParsedTable& table, std::string_view file_name);

}  // namespace gaugeloop
