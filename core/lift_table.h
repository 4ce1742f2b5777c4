// Design lift tables: CSV `angle_deg,lift_mm` over one full turn of the cam, validated on read.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

// Lift of an in-line translating follower against cam angle.
// Frame: cam frame, angles counter-clockwise in degrees, 0 at the nose, in [0, 360).
// Invariant (after parse): angles strictly increasing, both vectors the same size (>= 4),
// every value finite, no gap between neighbours (including the wrap 360 -> 0) wider than
// the limit it was read with.
struct LiftTable {
  std::vector<double> angle_deg;
  std::vector<double> lift_mm;
  std::string source;  // file name or label, for messages
};

struct LiftTableLimits {
  double max_gap_deg = 5.0;  // widest allowed spacing between neighbouring angles
};

// Parses CSV text. Errors name `source_name` and the 1-based line, say what was wrong and
// what to do. Accepts a header line `angle_deg,lift_mm`, blank lines and `#` comments.
Result<LiftTable> parse_lift_table_csv(std::string_view text, std::string_view source_name,
                                       const LiftTableLimits& limits = {});

// Reads and parses a file; a missing or unreadable file is an error naming the path.
Result<LiftTable> read_lift_table_csv(const std::filesystem::path& path, const LiftTableLimits& limits = {});

}  // namespace gaugeloop
