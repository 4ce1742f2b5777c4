// Shaft files: TOML naming a camshaft's lobes (part files) and their nominal angular positions
// from the shaft's reference, for the shaft record of a serial (`runs shaft`).
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "report/shaft.h"

namespace gaugeloop {

// A shaft as read from its file.
struct ShaftFile {
  ShaftLayout layout;
  // Things worth saying that do not stop the file being used, e.g. a part file whose
  // c_offset_deg grinds its nose elsewhere than the shaft places it (its runs would then show
  // that difference as index error).
  std::vector<std::string> notes;
};

// Parses shaft TOML:
//   name = "..."                 required
//   reference_c_deg = 0.0        C angle of the shaft's reference when clamped; [-360, 360]
//   index_tolerance_deg = 0.25   optional, +- on each lobe's index error; (0, 180]
//   [[lobe]]                     one or more
//   part = "intake_flat.toml"    a part file, relative to `base_dir` (the shaft file's folder);
//                                it gives the lobe's part name and lobe number
//   angle_deg = 0.0              the lobe's nominal nose position from the reference, in the
//                                sense of C; [-360, 360]
// Lobe numbers are unique on a shaft. Errors (kInvalidInput) name the file, the line and the
// key; unknown keys are refused; a part file that cannot be read is its own error prefixed
// with where the shaft file names it.
Result<ShaftFile> parse_shaft_toml(std::string_view text, std::string_view source_name,
                                   const std::filesystem::path& base_dir);

// Reads a shaft file; a missing file is kNotFound naming the path.
Result<ShaftFile> read_shaft_file(const std::filesystem::path& path);

}  // namespace gaugeloop
