// The preview of a new program, as a page an engineer reads before anything goes to the
// control: the wheel path X and its C-derivatives, the work spindle's speed and the
// grinding-point speed, and the table's command position error per degree against its bound.
// Drawn with cairo; PDF, SVG or PNG by the file's extension.
//
// Frame: machine frame, C the work spindle in degrees (0..359), X the wheel infeed in mm.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

struct ProgramPreviewPage {
  std::string title;     // "New program CAM_INTAKE_L1: intake_flat lobe 1"
  std::string subtitle;  // the table chosen, its seam and error; the cycle
  std::string footer;
  // One entry per whole degree of C, all of the same length (360).
  std::vector<double> x_mm, dx_mm_per_deg, d2x_mm_per_deg2;
  std::vector<double> y_mm;  // a C-X-Y pin's wheel height; empty otherwise
  std::vector<double> c_speed_rpm, grinding_point_speed_mm_per_min;
  std::vector<double> command_error_um;    // X table: the largest in each degree
  std::vector<double> y_command_error_um;  // Y table; empty otherwise
  double command_error_bound_um = 0.5;
};

// The page is A4 landscape, as the cam report.
Status write_program_preview(const ProgramPreviewPage& page, const std::filesystem::path& out);

}  // namespace gaugeloop
