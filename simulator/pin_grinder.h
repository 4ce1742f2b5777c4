// The virtual grinder for crankpins: grinds the next pin from the curve tables in force (X,
// and Y in C-X-Y) through machine errors on both slides, and gives what the gauge riding on
// the pin reads (docs/crankpins.md, docs/virtual_grinder.md).
//
// What happens to a pin:
//  1. The commanded path X(C), Y(C) is what the NC interpolates from the tables in force
//     (read back from the pushed programs, as commanded_path_from_program reads a lobe's
//     table), every 0.1 deg of C; or the exact design path.
//  2. Each slide follows its command with the errors of its own MachineErrorModel (servo
//     lag in time at the work speed or under a speed program, geometric error with C, drift,
//     vibration), exactly as the lobe's grinder applies them to X.
//  3. The pin is the envelope of the wheel along the followed path
//     (ground_pin_radius_error_mm), and the gauge reads it at gauge_psi_deg of every whole
//     machine degree.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "core/pin.h"
#include "core/result.h"
#include "core/run.h"
#include "simulator/virtual_grinder.h"

namespace gaugeloop {

// The machine's errors for a pin. x: the infeed, as for a lobe. y: the vertical slide of a
// C-X-Y machine (not used in C-X). An error of Y moves the wheel along the pin's tangent, so
// it changes the pin's radius only to second order (dY^2 / (2 (r + rw))): docs/crankpins.md.
struct PinMachineErrorModel {
  MachineErrorModel x;
  MachineErrorModel y;
};

// Checks both models; the message names the slide and the term.
Status validate(const PinMachineErrorModel& model);

// vibration_only of both slides: the floor of the machine.
PinMachineErrorModel vibration_only(const PinMachineErrorModel& model);

// The commanded path on the machine's C grid: x_mm[k], y_mm[k] at C = k * c_step_deg (y all 0
// in C-X).
struct PinCommandedPath {
  double c_step_deg = 0.1;
  std::vector<double> x_mm;
  std::vector<double> y_mm;
  std::string source;  // "design" or the NC files, for messages
};

// The exact design path. Errors: as validate(PinGeometry).
Result<PinCommandedPath> pin_commanded_path_from_design(const PinGeometry& pin);

// What the NC makes of the tables in `x_program` (CTABDEF(X,C,..)) and, in C-X-Y,
// `y_program` (CTABDEF(Y,C,..); ignored in C-X). Errors: as commanded_path_from_program,
// naming the file; kInvalidInput when a table's following axis is not the one expected.
Result<PinCommandedPath> pin_commanded_path_from_programs(const PinGeometry& pin,
                                                          const std::filesystem::path& x_program,
                                                          const std::filesystem::path& y_program);

// A pin ground on the virtual machine.
struct GroundPin {
  int part_index = 0;
  DegreeTable radius_error_mm{};  // per whole pin-frame degree: the pin as ground, no gauge noise
  // What the gauge reads at every whole machine degree C (index = C): radius_error at
  // gauge_psi_deg(pin, C), evaluated there, not interpolated from the whole pin degrees.
  DegreeTable gauge_reading_mm{};
  std::vector<double> followed_x_mm;  // on the commanded grid
  std::vector<double> followed_y_mm;
  double largest_servo_error_um = 0.0;  // largest |followed - commanded| from the servos alone, either slide
};

// Grinds pin number `part_index` (drift and vibration seed follow it, as for grind_part).
// Errors: kInvalidInput for a bad model or path; as ground_pin_radius_error_mm.
Result<GroundPin> grind_pin(const PinGeometry& pin, const PinCommandedPath& commanded,
                            const PinMachineErrorModel& model, int part_index);

// The figures of a pin as ground, from its radius error (no gauge noise): largest |error|,
// RMS, and roundness (peak to valley after the least-squares circle), um.
struct TruePinError {
  DegreeTable error_um{};
  double max_abs_um = 0.0;
  double rms_um = 0.0;
  double roundness_um = 0.0;
};
TruePinError true_pin_error(const DegreeTable& radius_error_mm);

}  // namespace gaugeloop
