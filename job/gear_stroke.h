// A gear's stroke program written from the axes' errors along the stroke: the SIM1 position at
// every spline point (compensation/gear_coupling.h), the program text (nc_out/stroke_program.h)
// written atomically and read back. docs/gears.md. Not yet through the push journal and its
// history: the file is written where it is asked to be, never into the NC directory by itself.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "compensation/gear_coupling.h"
#include "core/result.h"
#include "nc_out/stroke_program.h"

namespace gaugeloop {

struct GearStrokeSettings {
  std::string part_name;
  std::string program_name;  // the part file's nc_program; the file's header names it
  std::filesystem::path out_file;
  double feed_mm_per_min = 300.0;  // the stroke's feed along Z
  StrokeProgramFormat format;
};

struct GearStrokeReport {
  GearCoupling coupling;
  std::vector<StrokeSimPoint> points;
  std::string coupling_lines;  // EGDEF and EGON for the main program
  double sim_max_abs_deg = 0.0;
};

// The points, the program, written atomically to settings.out_file and read back: it must parse,
// match its checksum and hold every point as written (on the control's grid). Errors: validate's
// and stroke_sim_points' kInvalidInput; kIo for a file that cannot be written; kIo for a file that
// does not read back as written.
Result<GearStrokeReport> write_gear_stroke(const GearPart& part, const StrokeAxisErrors& errors,
                                           const GearStrokeSettings& settings);

}  // namespace gaugeloop
