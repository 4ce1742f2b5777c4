// Gear part files: TOML describing a gear ground by a worm wheel on a generating grinder,
// the worm and the stroke ([gear], [gear.worm], [gear.stroke]; docs/gears.md).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

#include "core/gear.h"
#include "core/result.h"

namespace gaugeloop {

struct GearPartFile {
  std::string name;
  std::string nc_program;  // the stroke program's name, as a part file's nc_program
  GearPart part;
};

// Parses gear part TOML. Errors (kInvalidInput) name the file, the line and the key and say what
// is allowed; unknown keys are refused; the part must pass validate(GearPart)
// (compensation/gear_coupling.h), whose message is given with the file and the key's line.
Result<GearPartFile> parse_gear_part_toml(std::string_view text, std::string_view source_name);

// Reads a gear part file; a missing file is kNotFound naming the path.
Result<GearPartFile> read_gear_part_file(const std::filesystem::path& path);

}  // namespace gaugeloop
