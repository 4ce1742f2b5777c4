// The virtual grinder for crankpins: both slides through follow_slide, the pin from the
// envelope of the wheel (pin_grinder.h).
#include "simulator/pin_grinder.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>

#include "compensation/analysis.h"
#include "compensation/pin_analysis.h"
#include "compensation/pin_envelope.h"
#include "compensation/pin_kinematics.h"
#include "simulator/fine_grid.h"
#include "simulator/seeded_random.h"

namespace gaugeloop {
namespace {

using fine_grid::kFineGridRows;
using fine_grid::kFineGridStepDeg;

Status named(const Status& s, const char* slide) {
  if (s) return s;
  return make_error(s.error().code, std::string(slide) + " slide: " + s.error().message);
}

Result<std::vector<double>> read_slide(const std::filesystem::path& program, const char* expected_axis) {
  Result<ProgramSlidePath> slide = slide_path_from_program(program);
  if (!slide) return slide.error();
  if (slide->following_axis != expected_axis) {
    return make_error(ErrorCode::kInvalidInput, "virtual grinder: " + program.string() + " holds a table of " +
                                                    slide->following_axis + " against C where the table of " +
                                                    expected_axis + " is expected; push the " + expected_axis +
                                                    " table there");
  }
  return std::move(slide->position_mm);
}

}  // namespace

Status validate(const PinMachineErrorModel& model) {
  if (Status s = named(validate(model.x), "X"); !s) return s;
  return named(validate(model.y), "Y");
}

PinMachineErrorModel vibration_only(const PinMachineErrorModel& model) {
  return {vibration_only(model.x), vibration_only(model.y)};
}

Result<PinCommandedPath> pin_commanded_path_from_design(const PinGeometry& pin) {
  if (Status s = validate(pin); !s) return s.error();
  PinCommandedPath path;
  path.c_step_deg = kFineGridStepDeg;
  path.source = "design";
  path.x_mm.resize(kFineGridRows);
  path.y_mm.resize(kFineGridRows);
  for (int k = 0; k < kFineGridRows; ++k) {
    const PinPose pose = design_pin_pose(pin, k * kFineGridStepDeg);
    path.x_mm[static_cast<size_t>(k)] = pose.x_mm;
    path.y_mm[static_cast<size_t>(k)] = pose.y_mm;
  }
  return path;
}

Result<PinCommandedPath> pin_commanded_path_from_programs(const PinGeometry& pin,
                                                          const std::filesystem::path& x_program,
                                                          const std::filesystem::path& y_program) {
  if (Status s = validate(pin); !s) return s.error();
  Result<std::vector<double>> x = read_slide(x_program, "X");
  if (!x) return x.error();
  PinCommandedPath path;
  path.c_step_deg = kFineGridStepDeg;
  path.x_mm = std::move(*x);
  path.source = x_program.string();
  if (pin.mode == PinMode::kCXY) {
    Result<std::vector<double>> y = read_slide(y_program, "Y");
    if (!y) return y.error();
    path.y_mm = std::move(*y);
    path.source += " and " + y_program.string();
  } else {
    path.y_mm.assign(kFineGridRows, 0.0);
  }
  return path;
}

Result<GroundPin> grind_pin(const PinGeometry& pin, const PinCommandedPath& commanded,
                            const PinMachineErrorModel& model, int part_index) {
  if (Status s = validate(model); !s) return s.error();
  if (Status s = validate(pin); !s) return s.error();
  Result<FollowedSlide> x = follow_slide(commanded.x_mm, commanded.c_step_deg, model.x, part_index, commanded.source);
  if (!x) return named(x.error(), "X").error();
  GroundPin ground;
  ground.part_index = part_index;
  ground.followed_x_mm = std::move(x->followed_mm);
  ground.largest_servo_error_um = x->largest_servo_error_um;
  if (pin.mode == PinMode::kCXY) {
    Result<FollowedSlide> y = follow_slide(commanded.y_mm, commanded.c_step_deg, model.y, part_index, commanded.source);
    if (!y) return named(y.error(), "Y").error();
    ground.followed_y_mm = std::move(y->followed_mm);
    ground.largest_servo_error_um = std::max(ground.largest_servo_error_um, y->largest_servo_error_um);
  } else {
    // A C-X machine has no Y slide: the wheel centre stays on the X axis.
    ground.followed_y_mm.assign(ground.followed_x_mm.size(), 0.0);
  }
  Result<DegreeTable> radius =
      ground_pin_radius_error_mm(pin, commanded.c_step_deg, ground.followed_x_mm, ground.followed_y_mm);
  if (!radius) return radius.error();
  ground.radius_error_mm = *radius;
  // In C-X the gauge's pin degree runs unevenly with C, so it is read where it falls rather
  // than interpolated from the whole pin degrees.
  std::vector<double> psi_deg(ground.gauge_reading_mm.size());
  for (size_t c = 0; c < psi_deg.size(); ++c) psi_deg[c] = gauge_psi_deg(pin, static_cast<double>(c));
  Result<std::vector<double>> reading =
      ground_pin_radius_error_at_mm(pin, commanded.c_step_deg, ground.followed_x_mm, ground.followed_y_mm, psi_deg);
  if (!reading) return reading.error();
  std::copy(reading->begin(), reading->end(), ground.gauge_reading_mm.begin());
  return ground;
}

TruePinError true_pin_error(const DegreeTable& radius_error_mm) {
  TruePinError e;
  for (size_t d = 0; d < radius_error_mm.size(); ++d) e.error_um[d] = radius_error_mm[d] * 1000.0;
  const DegreeFigures figures = degree_figures(e.error_um);
  e.max_abs_um = figures.max_abs;
  e.rms_um = figures.rms;
  // Roundness as the gauge's analysis gives it: after the least-squares circle.
  const LeastSquaresCircle circle = fit_least_squares_circle(e.error_um);
  DegreeTable residual{};
  for (size_t d = 0; d < residual.size(); ++d) residual[d] = e.error_um[d] - circle.at_um(d);
  e.roundness_um = degree_figures(residual).peak_to_valley;
  return e;
}

}  // namespace gaugeloop
