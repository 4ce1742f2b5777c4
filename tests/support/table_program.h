// A real curve-table program to push in tests: a linear table of 360 blocks on a cosine path,
// through the shipped Sinumerik template (the one the command embeds), with the header of a
// run and table version. Needs GAUGELOOP_SOURCE_DIR (set by tests/ CMake).
#pragma once

#include <cmath>
#include <map>
#include <numbers>
#include <string>

#include "core/text_file.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"

namespace gaugeloop::testing {

// The program of program CAM_TEST for `run` and `version`, on a path whose stroke is `stroke_mm`;
// with `numbers` set, the table goes to the number of its version and the header names both.
inline Result<std::string> program_for(std::int64_t run, int version, double stroke_mm, TableNumbers numbers = {0, 0}) {
  SampledPath p;
  p.c_step_deg = 0.01;
  constexpr double kRad = std::numbers::pi / 180.0;
  for (int k = 0; k < 36000; ++k) {
    const double c = k * 0.01 * kRad;
    p.x_mm.push_back(5.0 + stroke_mm * std::cos(c));
    p.dx_dc_mm_per_deg.push_back(-stroke_mm * std::sin(c) * kRad);
    p.d2x_dc2_mm_per_deg2.push_back(-stroke_mm * std::cos(c) * kRad * kRad);
  }
  Result<CurveTable> table = write_linear_table(p, 1.0);
  if (!table) return table.error();
  Result<std::string> nc_template =
      read_regular_file(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/sinumerik/cam_table.spf", "NC template");
  if (!nc_template) return nc_template.error();
  std::map<std::string, std::string> values = {{"program_name", "CAM_TEST"},
                                               {"part", "intake"},
                                               {"lobe", "1"},
                                               {"version", "test"},
                                               {"run_id", std::to_string(run)},
                                               {"origin", "run " + std::to_string(run)},
                                               {"created_utc", ""},
                                               {"correction_max_um", "0"},
                                               {"table_number", "1"}};
  TableProvenance provenance{run, version, numbers};
  return render_table_program(*nc_template, "cam_table.spf", values, *table, provenance);
}

}  // namespace gaugeloop::testing
