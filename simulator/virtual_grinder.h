// The virtual grinder: grinds the next part from the curve table in force, through a machine
// error model, so the loop measure -> compensate -> push -> grind can be closed without a
// grinder (docs/virtual_grinder.md).
//
// What happens to a part:
//  1. The commanded wheel path X(C) is what the NC interpolates from the table in force (read
//     back from the pushed program, nc_out's model of G1 and CSPLINE), sampled every 0.1 deg
//     of C; the very first part of a loop may be ground from the exact design path instead.
//  2. The path actually followed is the commanded one plus the machine's errors (the model
//     below, every term settable).
//  3. The lobe is the envelope of the wheel (radius part.wheel_radius_mm) along the followed
//     path (compensation's ground_lobe_reading), given as what the flat gauge probe reads at
//     each whole cam degree. The gauge simulator then serves that lobe.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/lift_table.h"
#include "core/part.h"
#include "core/result.h"
#include "core/run.h"
#include "core/work_speed.h"

namespace gaugeloop {

// The errors of the machine, as errors of the infeed X (um) against the commanded path.
// Frame: machine frame, C in degrees. The defaults give about 16 um largest lift error on the
// sample intake lobe ground from its design table (docs/virtual_grinder.md has the figures).
struct MachineErrorModel {
  // The work spindle speed while grinding: the servo error follows X's velocity and
  // acceleration in time, so it grows with the speed.
  double work_speed_rpm = 60.0;
  // A work speed program instead (compensation's plan_work_speed): C turns at the program's
  // speed at each C position and work_speed_rpm is not used. The servo then acts in time: the
  // commanded X(C) is resampled onto a uniform grid of time over the turn (the turn's period
  // from dt = dC / omega), the response below is applied per harmonic of that period, and the
  // error is mapped back to the C grid. So the servo error follows the speed: a slow flank
  // lags less, and a faster base circle costs little since X barely moves there. A constant
  // program grinds the same part as work_speed_rpm at that speed. Speeds in [1, 1000] rpm,
  // c_step_deg dividing 360; the program is interpolated linearly between its rows. The other
  // terms stay functions of C.
  std::optional<WorkSpeedProgram> speed_program;
  // Servo lag of the infeed axis: a position loop of natural frequency servo_bandwidth_hz and
  // damping servo_damping with velocity feed-forward: actual/commanded =
  // (w^2 + 2 z w f s) / (s^2 + 2 z w s + w^2), w = 2 pi servo_bandwidth_hz, f the feed-forward
  // fraction. At low frequency the error is (1 - f) 2z/w * velocity + acceleration / w^2: with
  // most of the velocity fed forward it is largest where X reverses (the nose), where the
  // acceleration is. Periodic steady state, computed per harmonic of the turn (exact for the
  // sampled path). servo_bandwidth_hz = 0: an ideal axis, no lag.
  double servo_bandwidth_hz = 42.0;
  double servo_damping = 0.7;
  double velocity_feed_forward = 0.995;
  // Geometric error repeating with C (work spindle runout, a bent or tilted work-head):
  // geometric_once_um * cos(C + phase) + geometric_twice_um * cos(2 C + phase).
  double geometric_once_um = 1.5;
  double geometric_once_phase_deg = 30.0;
  double geometric_twice_um = 1.0;
  double geometric_twice_phase_deg = 75.0;
  // Slow drift (wheel wear and the infeed's thermal growth): an infeed scale error that grows
  // by drift_um_per_part at the largest X with every part ground: part i's X error is
  // drift_um_per_part * i * X / X_max.
  double drift_um_per_part = 0.1;
  // Random vibration: RMS of a seeded random sum of the harmonics vibration_min_harmonic ..
  // vibration_max_harmonic of the turn, with random amplitude and phase, new for every part
  // (wheel-spindle unbalance, chatter: well above what compensation feeds back).
  double vibration_rms_um = 0.5;
  int vibration_min_harmonic = 40;
  int vibration_max_harmonic = 150;
  std::uint64_t seed = 1;
};

// Checks the model; the message names the term and the range allowed.
Status validate(const MachineErrorModel& model);

// The same model without its systematic terms (ideal servo, no geometric error, no drift):
// what a perfect table ground on this machine still shows, its floor.
MachineErrorModel vibration_only(const MachineErrorModel& model);

// One slide following its command through the model: the servo (in time, at the work speed or
// under the speed program), the geometric error with C, the drift of part `part_index` (a scale
// error of the slide, drift_um_per_part * i at its largest commanded position) and that part's
// vibration. The lobe's X and the pin's X and Y all go through this one function, so a slide
// errs the same way whatever it grinds. `commanded_mm` holds 3600 rows at C = k * 0.1 deg;
// the slide's positions in mm. Two slides given the same seed vibrate alike.
// Errors: kInvalidInput for a bad model, another grid (the message names `source`) or a
// negative part index.
struct FollowedSlide {
  std::vector<double> followed_mm;      // on the commanded grid
  double largest_servo_error_um = 0.0;  // largest |followed - commanded| from the servo alone
};
Result<FollowedSlide> follow_slide(const std::vector<double>& commanded_mm, double c_step_deg,
                                   const MachineErrorModel& model, int part_index, std::string_view source);

// A table program read back as the NC runs it: the table's following axis (CTABDEF's first
// argument, e.g. "X") and the position it interpolates at C = k * 0.1 deg, 3600 rows. A
// correction layer (its header names its design table, nc_out/table_layer.h) is added to the
// design table beside it, as the gearbox adds them with SIM1 following C 1:1. Errors: as
// commanded_path_from_program, and the design table's (read_design_table).
struct ProgramSlidePath {
  std::string following_axis;
  std::vector<double> position_mm;
};
Result<ProgramSlidePath> slide_path_from_program(const std::filesystem::path& nc_file);

// The commanded wheel path on the machine's C grid: x_mm[k] at C = k * c_step_deg.
struct CommandedPath {
  double c_step_deg = 0.1;
  std::vector<double> x_mm;
  std::string source;  // "design" or the NC file, for messages
};

// What the NC makes of the table in `nc_file` (the one CTABDEF in it, G1 or CSPLINE with
// natural ends, as nc_out reads it back). The machine runs what is on the control, so a
// hand-edited table is ground as it is. Errors: kNotFound (no file), kInvalidInput (the
// parser's message, with the line).
Result<CommandedPath> commanded_path_from_program(const std::filesystem::path& nc_file);

// The exact wheel path of the design lift (a perfect table). Errors: as compute_machine_path.
Result<CommandedPath> commanded_path_from_design(const Part& part, const LiftTable& design);

// A part ground on the virtual machine.
struct GroundPart {
  int part_index = 0;
  // What the flat gauge probe reads on the ground lobe at each whole cam degree, mm; 0 on
  // the nominal base circle (cam frame: index = cam degree, 0 at the nose).
  DegreeTable reading_mm{};
  std::vector<double> followed_x_mm;    // the path actually followed, on the commanded grid
  double largest_servo_error_um = 0.0;  // largest |followed - commanded| from the servo alone
};

// Grinds part number `part_index` (0 for the first of a loop; the drift and the vibration's
// seed follow it) from `commanded`. Errors: kInvalidInput for a bad model or path; as
// ground_lobe_reading.
Result<GroundPart> grind_part(const Part& part, const CommandedPath& commanded, const MachineErrorModel& model,
                              int part_index);

// The true lift error of a ground lobe against the design reading, zeroed as the analysis
// zeroes a measurement: minus its mean over the base-circle window centre +- half width
// (whole cam degrees). No gauge noise: what the part is, not what was measured.
struct TrueLiftError {
  DegreeTable error_um{};
  double max_abs_um = 0.0;
  double rms_um = 0.0;
};
TrueLiftError true_lift_error(const DegreeTable& reading_mm, const DegreeTable& design_reading_mm,
                              double base_circle_center_deg = 180.0, double base_circle_half_width_deg = 30.0);

}  // namespace gaugeloop
