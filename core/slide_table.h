// A compensation table of the control for a slide: values at equally spaced positions of an input
// axis, acting on an output axis, linear between the points and held beyond the ends, as the
// SINUMERIK 840D's leadscrew error compensation (LEC, `$AA_ENC_COMP`: the output axis is the
// input axis) and interpolatory sag/angularity compensation (CEC, `$AN_CEC`: another axis)
// apply them (docs/gears.md, "The slides"). Plain data: compensation/ fills it from a ballbar,
// nc_out/ writes and reads the control's files, the simulator applies it.
#pragma once

#include <string>
#include <vector>

namespace gaugeloop {

enum class SlideTableKind {
  kLeadscrew,      // LEC: the axis' own position error, function of its own position
  kInterpolatory,  // CEC: the output axis' error as a function of the input axis' position
};

struct SlideCompensationTable {
  SlideTableKind kind = SlideTableKind::kLeadscrew;
  char input_axis = 'Y';   // 'Y' or 'Z'
  char output_axis = 'Y';  // the same as input_axis for kLeadscrew
  double min_mm = 0.0;     // the input axis' position of the first point
  double step_mm = 1.0;    // between points, > 0
  // The error the table takes out at each point (mm): where the output axis stands less where it
  // was commanded, before compensation. The control's own values and signs are the file's
  // business (nc_out/slide_compensation.h).
  std::vector<double> error_mm;
  double max_mm() const;
  // The error taken out with the input axis at `position_mm`: linear between the points, the end
  // values held beyond them.
  double taken_out_mm(double position_mm) const;
};

// The sum of what every table acting on `output_axis` takes out with Y and Z at (y_mm, z_mm).
double taken_out_mm(const std::vector<SlideCompensationTable>& tables, char output_axis, double y_mm, double z_mm);

}  // namespace gaugeloop
