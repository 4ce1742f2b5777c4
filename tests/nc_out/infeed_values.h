// The main program's infeed placeholders as render_main_for_table fills them for the default
// cycle (0.25 mm start offset over 18 turns), for tests that render a main template directly.
#pragma once

#include <map>
#include <string>

namespace gaugeloop::testing {

inline void add_infeed_values(std::map<std::string, std::string>& values) {
  values["infeed_blocks"] = "FGROUP(C)\nG1 G91 C6480.000 X-0.2500 F21600.0\nG90\nFGROUP()";
  values["speed_infeed_blocks"] = "R1=-0.01388889\nCAM_INTAKE_L1_SPEED P18\nR1=0";
  values["start_offset_mm"] = "0.2500";
  values["start_x_mm"] = "0.2500";
  values["start_x_at_c0_mm"] = "8.7500";
  values["infeed_turns"] = "18";
}

}  // namespace gaugeloop::testing
