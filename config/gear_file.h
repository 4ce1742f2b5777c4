// Gear part files: TOML describing a gear ground by a worm wheel on a generating grinder,
// the worm and the stroke ([gear], [gear.worm], [gear.stroke]; docs/gears.md).
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "compensation/gear_coupling.h"
#include "compensation/gear_identification.h"
#include "compensation/gear_lead.h"
#include "core/gear.h"
#include "core/result.h"

namespace gaugeloop {

struct GearPartFile {
  std::string name;
  std::string nc_program;  // the stroke program's name, as a part file's nc_program
  GearPart part;
  // The flank tolerance class of ISO 1328-1 the drawing asks for ([gear] tolerance_class, 1 to
  // 11): a measured gear is in when every flank's total helix deviation F_beta is within its
  // tolerance. Empty: gears of the part are not judged.
  std::optional<int> tolerance_class;
};

// Parses gear part TOML. Errors (kInvalidInput) name the file, the line and the key and say what
// is allowed; unknown keys are refused; the part must pass validate(GearPart)
// (compensation/gear_coupling.h), whose message is given with the file and the key's line.
Result<GearPartFile> parse_gear_part_toml(std::string_view text, std::string_view source_name);

// Reads a gear part file; a missing file is kNotFound naming the path.
Result<GearPartFile> read_gear_part_file(const std::filesystem::path& path);

// Whether the part file at `path` describes a gear (it has a [gear] table), so a command that
// takes any part knows which reader to use; errors: the file's reading and TOML errors.
Result<bool> is_gear_part_file(const std::filesystem::path& path);

// The axes' errors along the stroke as CSV (docs/gears.md): a header line naming the columns
// z_mm, y_error_um, z_error_um, b_error_deg, c_error_deg (in any order; no others), then one
// row per Z; blank lines and lines starting with '#' are skipped. kInvalidInput naming the
// line and column of a value that is not a number, a missing or unknown column, a short row.
// Whether the rows increase and cover the stroke is stroke_sim_points' to say.
Result<StrokeAxisErrors> parse_axis_errors_csv(std::string_view text, std::string_view source_name);
Result<StrokeAxisErrors> read_axis_errors_csv(const std::filesystem::path& path);

// Lead traces as a gear checker exports them, CSV (docs/gears.md): a header naming gap, flank,
// z_mm, deviation_um (any order), then one row per point; the rows of a trace (one gap, one
// flank: left or right, or L and R) go up the face, traces may follow each other or interleave.
// kInvalidInput naming the line and column of what is wrong, or a Z that does not increase
// within its trace (naming the line before it).
Result<std::vector<LeadTrace>> parse_lead_traces_csv(std::string_view text, std::string_view source_name);
Result<std::vector<LeadTrace>> read_lead_traces_csv(const std::filesystem::path& path);

// A ballbar circle in the ZY plane as its software lists it, CSV: a header naming angle_deg and
// radial_um (the angle from +Y towards +Z, the bar's length less its nominal), then one row per
// point; `radius_mm` is the circle's. kInvalidInput naming the line and column of what is wrong.
Result<BallbarCircle> parse_ballbar_csv(std::string_view text, std::string_view source_name, double radius_mm);
Result<BallbarCircle> read_ballbar_csv(const std::filesystem::path& path, double radius_mm);

// A ballbar test run both ways, CSV: a header naming direction, angle_deg and radial_um, then one
// row per point; direction is ccw or cw (+Y towards +Z, and back). Comment lines may say
// `# radius_mm: 100` and `# feed_mm_per_min: 1000` (ballbar_test_csv writes them); without them
// `radius_mm` and `feed_mm_per_min` hold. kInvalidInput naming the line and column of what is
// wrong, or a comment's value that is not a positive number.
Result<BallbarTest> parse_ballbar_test_csv(std::string_view text, std::string_view source_name, double radius_mm,
                                           double feed_mm_per_min);
Result<BallbarTest> read_ballbar_test_csv(const std::filesystem::path& path, double radius_mm, double feed_mm_per_min);
// The test as parse_ballbar_test_csv reads it, `title` as its first comment line; angles to
// 0.001 deg, radial deviations to 0.01 um.
std::string ballbar_test_csv(const BallbarTest& test, std::string_view title);

}  // namespace gaugeloop
