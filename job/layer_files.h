// A correction layer's files beside its table (docs/nc_output.md, "The correction as a
// layer"): the design table's program <dir>/<stem>_DESIGN.SPF, which the layer is added to, and
// what the control holds there.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// The design table's program of the layer `nc_file`: <dir>/<stem>_DESIGN.SPF.
std::filesystem::path design_program_path(const std::filesystem::path& nc_file);

// The design table under a layer, as the control holds it.
struct LayerOnControl {
  std::filesystem::path design_file;  // named by the layer's header (design_program)
  int design_table_number = 0;
  std::string design_text;  // empty when `problem` says why it cannot be used
  std::string problem;      // empty: the design table is there, the one numbered, unedited
};

// For the table program `program_text` at `nc_file`: nothing when it is not a layer; else its
// design table read from beside it and checked (read_design_table), a missing, unreadable or
// edited one described in `problem`. kInvalidInput for a program that does not parse or a
// layer header naming half its design table.
Result<std::optional<LayerOnControl>> layer_on_control(std::string_view program_text,
                                                       const std::filesystem::path& nc_file);

}  // namespace gaugeloop
