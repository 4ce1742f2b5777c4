// The closed loop for a crankpin on the virtual grinder: grind -> measure -> compensate ->
// push, pin after pin (docs/crankpins.md). Each pin is ground from the tables in force (the
// pushed X and, in C-X-Y, Y programs, read back), served by a fresh gauge simulator on
// loopback that reads it as the gauge riding on the pin does, and measured by the product's
// own job (run_measure_job with JobSettings::pin).
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "job/measure_job.h"
#include "job/nc_new.h"
#include "simulator/gauge_simulator.h"
#include "simulator/pin_grinder.h"

namespace gaugeloop {

// A crankpin's job settings on top of `js` (which has the part, the database, the X table's
// template and the speed program if any): the pin, the Y table's template in C-X-Y (the
// embedded examples/sinumerik/pin_y_table.spf), the main program coupling what the mode moves
// (embedded pin_main_cx.mpf or pin_main.mpf, unless a main template was given or a speed
// program's main program is set), the command position error bound of a pin's tables
// (kPinCommandErrorBoundUm), and the limits of a crankpin grinder's slides: X over the
// stroke and Y over the throw with 5 mm of margin, 600 mm/s and 30000 mm/s^2 (linear-motor
// slides, as such machines have; the pin's X swings 2R every turn), at the job's work speed.
void set_pin_job(JobSettings& js, const PinGeometry& pin, bool main_template_given);

// What the gauge simulator is given to serve a pin's reading per machine degree
// (SimulatorSettings::ground_reading_mm, with gauge_offset_mm 0: a pin gauge is mastered): a
// part whose cam frame is the machine frame (no offsets, positive sense) and a design of no
// lift, so machine degree C is served as reading C.
struct PinGaugeFrame {
  Part part;
  LiftTable design;
};
PinGaugeFrame pin_gauge_frame(const JobSettings& job);

struct PinLoopSettings {
  JobSettings job;  // job.pin set; build_on_table_in_force is decided by the loop
  PinMachineErrorModel machine;
  // The gauge: speed, time scale, noise. Its seed is advanced per pin, it serves each pin
  // ground, and its offset is 0: a pin gauge is mastered, its reading absolute.
  SimulatorSettings gauge;
  std::chrono::milliseconds response_timeout{200};
  int iterations = 3;  // compensation steps; iterations + 1 pins are ground and measured
  // Pin 0 is ground from the first program written from the drawing, as the lobe's loop
  // (LoopSettings::on_new_program).
  std::function<void(const NewProgramReport&)> on_new_program;
  std::string part_file;
};

struct PinLoopIteration {
  int iteration = 0;
  std::string ground_from;  // the NC file with its table version ("new": written from the drawing)
  JobReport job;
  TruePinError part;             // the pin as ground (no gauge noise)
  TruePinError floor;            // the same pin ground from a perfect path: vibration only
  double residual_max_um = 0.0;  // part - floor, the same vibration taken out
  double largest_servo_error_um = 0.0;
};

// Runs the loop; `on_part` (may be empty) sees each pin as it ends. A held or refused
// correction does not stop it. Errors: the machine model's, the grinder's, the job's, and
// kInvalidInput without job.pin.
Result<std::vector<PinLoopIteration>> run_pin_grinding_loop(
    const PinLoopSettings& settings, const std::function<void(const PinLoopIteration&)>& on_part);

}  // namespace gaugeloop
