// The closed loop on the virtual grinder: grind -> measure -> compensate -> push, part after
// part (docs/virtual_grinder.md). Each part is ground from the table in force (the pushed NC
// program, read back), served by a fresh gauge simulator on loopback and measured by the
// product's own job (run_measure_job: poller, analysis, compensation, curve table, database).
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "job/measure_job.h"
#include "job/nc_new.h"
#include "simulator/gauge_simulator.h"
#include "simulator/virtual_grinder.h"

namespace gaugeloop {

struct LoopSettings {
  // The part, design, measurement, compensation, NC output and database, as for one run.
  // build_on_table_in_force is decided by the loop: the first part is corrected from the
  // design, every later one builds on the correction of the table it was ground with.
  JobSettings job;
  MachineErrorModel machine;
  // The gauge: speed, time scale, noise. Its seed is advanced per part; ground_reading_mm
  // is set to each part ground.
  SimulatorSettings gauge;
  std::chrono::milliseconds response_timeout{200};
  int iterations = 3;  // compensation steps; iterations + 1 parts are ground and measured
  // Part 0 is ground from the first program written from the drawing (write_new_program,
  // replacing any history of the program, as a shop starting the part again would), read
  // back from the NC directory as every later part's is. `on_new_program` (may be empty)
  // sees it; `part_file` names the drawing in the history.
  std::function<void(const NewProgramReport&)> on_new_program;
  std::string part_file;
};

// One part of the loop.
struct LoopIteration {
  int iteration = 0;        // 0: the first part, ground before any compensation
  std::string ground_from;  // the NC file with its table version ("new": written from the drawing)
  JobReport job;            // the measurement and what became of its table
  TrueLiftError part;       // the part as ground (no gauge noise)
  TrueLiftError floor;      // the same part ground from a perfect table: vibration only
  // What the loop has left to correct: part - floor, the same vibration taken out, um.
  double residual_max_um = 0.0;
  double residual_rms_um = 0.0;
  double largest_servo_error_um = 0.0;
};

// One ground part measured as the loop measures it: a fresh gauge simulator on loopback
// (a free port, `gauge` as given, serving `gauge.ground_reading_mm` for `part` and `design`),
// the product's gauge client with `response_timeout`, and run_measure_job with `job`; the
// simulator is stopped before returning. Errors: the simulator's and the job's.
Result<JobReport> measure_on_gauge_simulator(const Part& part, const LiftTable& design, SimulatorSettings gauge,
                                             std::chrono::milliseconds response_timeout, const JobSettings& job);

// A loop's first program: written from the drawing of `job`'s part into its NC directory
// (write_new_program, replacing any history: the loop starts the part again), shown to `seen`
// (may be empty). Its NC file and version are what part 0 is ground from.
Result<NewProgramReport> write_first_program(const JobSettings& job, const std::string& part_file,
                                             const std::function<void(const NewProgramReport&)>& seen);

// Runs the loop; `on_part` (may be empty) sees each iteration as it ends. A held or refused
// correction does not stop the loop: the next part is ground with the table in force, as on
// the shop floor. Errors: those of the machine model, the grinder or the job (the iterations
// done so far are lost to the caller but stored in the database).
Result<std::vector<LoopIteration>> run_grinding_loop(const LoopSettings& settings,
                                                     const std::function<void(const LoopIteration&)>& on_part);

}  // namespace gaugeloop
