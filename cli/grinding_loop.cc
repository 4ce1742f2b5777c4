// The closed loop on the virtual grinder, part by part.
#include "cli/grinding_loop.h"

#include <algorithm>
#include <cmath>

#include "acquisition/modbus_gauge.h"
#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "job/program_set.h"

namespace gaugeloop {

Result<JobReport> measure_on_gauge_simulator(const Part& part, const LiftTable& design, SimulatorSettings gauge,
                                             std::chrono::milliseconds response_timeout, const JobSettings& job) {
  gauge.port = 0;
  Result<std::unique_ptr<GaugeSimulator>> sim = GaugeSimulator::start(part, design, gauge);
  if (!sim) return sim.error();
  ModbusSettings link;
  link.port = (*sim)->port();
  link.response_timeout = response_timeout;
  ModbusGauge client(link);
  Result<JobReport> report = run_measure_job(client, job);
  (*sim)->stop();
  return report;
}

Result<NewProgramReport> write_first_program(const JobSettings& job, const std::string& part_file,
                                             const std::function<void(const NewProgramReport&)>& seen) {
  NewProgramOptions options;
  options.replace = true;
  options.by = "the grinding loop";
  options.from_file = part_file.empty() ? std::string("the built-in sample") : part_file;
  Result<NewProgramReport> first = write_new_program(job, options);
  if (!first) return in_step("the first program", first.error());
  if (seen) seen(*first);
  return first;
}

Result<std::vector<LoopIteration>> run_grinding_loop(const LoopSettings& settings,
                                                     const std::function<void(const LoopIteration&)>& on_part) {
  if (Status s = validate(settings.machine); !s) return s.error();
  if (settings.iterations < 0 || settings.iterations > 100) {
    return make_error(ErrorCode::kInvalidInput,
                      "iterations must be in [0, 100], got " + std::to_string(settings.iterations));
  }
  const Part& part = settings.job.part;
  Result<PeriodicSpline> design_lift = PeriodicSpline::fit(settings.job.design.angle_deg, settings.job.design.lift_mm);
  if (!design_lift) return design_lift.error();
  Result<DegreeTable> design_reading = flat_probe_reading(*design_lift, part);
  if (!design_reading) return design_reading.error();
  Result<CommandedPath> design_path = commanded_path_from_design(part, settings.job.design);
  if (!design_path) return design_path.error();
  const MachineErrorModel floor_model = vibration_only(settings.machine);
  const double window_centre = settings.job.analysis.base_circle_center_deg;
  const double window_half = settings.job.analysis.base_circle_half_width_deg;

  Result<NewProgramReport> first = write_first_program(settings.job, settings.part_file, settings.on_new_program);
  if (!first) return first.error();
  std::vector<LoopIteration> done;
  std::filesystem::path table_in_force = first->nc_file;  // the NC file last pushed by this loop
  int version_in_force = first->table_version;
  for (int i = 0; i <= settings.iterations; ++i) {
    LoopIteration it;
    it.iteration = i;
    Result<CommandedPath> commanded = commanded_path_from_program(table_in_force);
    if (!commanded) return commanded.error();
    it.ground_from =
        table_in_force.filename().string() + " v" + std::to_string(version_in_force) + (i == 0 ? " new" : "");
    Result<GroundPart> ground = grind_part(part, *commanded, settings.machine, i);
    if (!ground) return ground.error();
    Result<GroundPart> floor = grind_part(part, *design_path, floor_model, i);
    if (!floor) return floor.error();
    it.part = true_lift_error(ground->reading_mm, *design_reading, window_centre, window_half);
    it.floor = true_lift_error(floor->reading_mm, *design_reading, window_centre, window_half);
    it.largest_servo_error_um = ground->largest_servo_error_um;
    double sum_sq = 0.0;
    for (size_t d = 0; d < it.part.error_um.size(); ++d) {
      const double r = it.part.error_um[d] - it.floor.error_um[d];
      it.residual_max_um = std::max(it.residual_max_um, std::abs(r));
      sum_sq += r * r;
    }
    it.residual_rms_um = std::sqrt(sum_sq / static_cast<double>(it.part.error_um.size()));

    SimulatorSettings gauge = settings.gauge;
    gauge.seed = settings.gauge.seed + static_cast<std::uint64_t>(i);
    gauge.ground_reading_mm = ground->reading_mm;
    JobSettings job = settings.job;
    job.build_on_table_in_force = true;
    if (job.note.empty()) job.note = "virtual grinder part " + std::to_string(i) + ", ground from " + it.ground_from;
    Result<JobReport> report =
        measure_on_gauge_simulator(part, settings.job.design, gauge, settings.response_timeout, job);
    if (!report) return report.error();
    it.job = std::move(*report);
    if (it.job.pushed()) {
      table_in_force = it.job.nc_file;
      version_in_force = it.job.table_version;
    }
    if (on_part) on_part(it);
    done.push_back(std::move(it));
  }
  return done;
}

}  // namespace gaugeloop
