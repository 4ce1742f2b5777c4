// Part files: TOML describing a lobe (lift table, follower, radii, machine angles) or, with a
// [pin] section, a crankpin (throw, radii, angular position, how the wheel chases it).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "compensation/work_speed.h"
#include "core/grinding_cycle.h"
#include "core/part.h"
#include "core/pin.h"
#include "core/result.h"

namespace gaugeloop {

// A part as read from its file, plus the NC program name it is written under.
struct PartFile {
  Part part;
  std::string nc_program;  // subprogram name, letters, digits and '_', starting with a letter
  // [speed]: the work speed program this lobe is ground at (docs/variable_speed.md), absent
  // for one speed. Its keys: base_speed_rpm, lobe_speed_mm_per_min, lobe_threshold_mm,
  // c_acceleration_max_deg_per_s2; the slide's limits are the machine's ([nc] of the service).
  std::optional<WorkSpeedSettings> speed;
  // [pin]: the file describes a crankpin, not a lobe. `part` then holds only the name, the pin
  // number (top-level `pin_number`, 1-based, as Part::lobe) and the wheel radius; its lift
  // table, follower and lobe tolerances are unset. A pin's [speed] is for C-X only, where the
  // grinding-point speed held is lobe_speed_mm_per_min (C-X-Y keeps it constant anyway).
  std::optional<PinGeometry> pin;
  // [grinding]: the allowance per side and the passes that grind it off, rendered into the
  // main program (docs/parts.md). Absent: the defaults of GrindingCycle.
  GrindingCycle grinding;
  // [correction_layer] (a lobe's; docs/nc_output.md, "The correction as a layer"): the CTABDEF
  // number of the design's whole table (design_table_number, 1..999, default 5), which stays
  // on the control as written from the drawing while each correction goes to a table of its
  // own on the virtual axis SIM1. 0: no section, every push writes the whole table.
  int layer_design_table_number = 0;
};

// Parses part TOML. `source_name` is used in messages; a relative `lift_table` is resolved
// against `base_dir`. Errors (kInvalidInput) name the file, the line and the key, and say
// what is allowed. Unknown keys are refused, so a typo never silently falls back to a default.
// A pin file (docs/parts.md) takes name, pin_number, nc_program, [speed] (C-X only), [pin] and
// [pin.tolerance]; a lobe's key in it is refused naming the key, and the pin must pass
// validate(PinGeometry) (compensation/pin_kinematics.h), whose message is given with the file.
Result<PartFile> parse_part_toml(std::string_view text, std::string_view source_name,
                                 const std::filesystem::path& base_dir);

// An NC program name: up to 24 letters, digits and '_', starting with a letter.
bool valid_program_name(std::string_view name);

// Reads a part file; a missing file is kNotFound naming the path. A gear part ([gear]) is
// refused, pointing to config/gear_file.h's reader.
Result<PartFile> read_part_file(const std::filesystem::path& path);

}  // namespace gaugeloop
