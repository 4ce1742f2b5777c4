// The closed loop for a crankpin on the virtual grinder, pin by pin.
#include "cli/pin_loop.h"

#include <algorithm>
#include <cmath>

#include "cli/embedded_defaults.h"
#include "cli/grinding_loop.h"
#include "job/pin_files.h"

namespace gaugeloop {

PinGaugeFrame pin_gauge_frame(const JobSettings& job) {
  PinGaugeFrame f;
  f.part.name = job.part.name;
  f.part.lobe = job.part.lobe;
  f.part.base_circle_radius_mm = job.pin->pin_radius_mm;
  f.part.wheel_radius_mm = job.pin->wheel_radius_mm;
  f.design.source = "round pin";
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    f.design.angle_deg.push_back(d);
    f.design.lift_mm.push_back(0.0);
  }
  return f;
}

void set_pin_job(JobSettings& js, const PinGeometry& pin, bool main_template_given) {
  js.pin = pin;
  const bool with_y = pin.mode == PinMode::kCXY;
  js.nc_y_template = with_y ? std::string(embedded::kPinYTableTemplate) : std::string();
  js.nc_y_template_name = with_y ? "embedded:pin_y_table.spf" : "";
  if (!main_template_given && !js.speed) {
    js.nc_main_template = std::string(with_y ? embedded::kPinMainTemplate : embedded::kPinMainCxTemplate);
    js.nc_main_template_name = with_y ? "embedded:pin_main.mpf" : "embedded:pin_main_cx.mpf";
  }
  js.table_choice.bound_um = kPinCommandErrorBoundUm;
  const double rpm = js.axis_limits.speed_rpm;
  js.axis_limits = AxisLimits{-1.0, 2.0 * pin.throw_mm + 5.0, 600.0, 30000.0, rpm};
  js.y_axis_limits = AxisLimits{-pin.throw_mm - 5.0, pin.throw_mm + 5.0, 600.0, 30000.0, rpm, 'Y'};
}

Result<std::vector<PinLoopIteration>> run_pin_grinding_loop(
    const PinLoopSettings& settings, const std::function<void(const PinLoopIteration&)>& on_part) {
  if (!settings.job.pin) return make_error(ErrorCode::kInvalidInput, "the pin loop needs a pin part");
  if (Status s = validate(settings.machine); !s) return s.error();
  if (settings.iterations < 0 || settings.iterations > 100) {
    return make_error(ErrorCode::kInvalidInput,
                      "iterations must be in [0, 100], got " + std::to_string(settings.iterations));
  }
  const PinGeometry& pin = *settings.job.pin;
  Result<PinCommandedPath> design_path = pin_commanded_path_from_design(pin);
  if (!design_path) return design_path.error();
  const PinMachineErrorModel floor_model = vibration_only(settings.machine);
  const PinGaugeFrame frame = pin_gauge_frame(settings.job);

  Result<NewProgramReport> first = write_first_program(settings.job, settings.part_file, settings.on_new_program);
  if (!first) return first.error();
  std::vector<PinLoopIteration> done;
  std::filesystem::path table_in_force = first->nc_file;  // the X table program last pushed by this loop
  int version_in_force = first->table_version;
  for (int i = 0; i <= settings.iterations; ++i) {
    PinLoopIteration it;
    it.iteration = i;
    Result<PinCommandedPath> commanded =
        pin_commanded_path_from_programs(pin, table_in_force, y_table_program_path(table_in_force));
    if (!commanded) return commanded.error();
    it.ground_from =
        table_in_force.filename().string() + " v" + std::to_string(version_in_force) + (i == 0 ? " new" : "");
    Result<GroundPin> ground = grind_pin(pin, *commanded, settings.machine, i);
    if (!ground) return ground.error();
    Result<GroundPin> floor = grind_pin(pin, *design_path, floor_model, i);
    if (!floor) return floor.error();
    it.part = true_pin_error(ground->radius_error_mm);
    it.floor = true_pin_error(floor->radius_error_mm);
    it.largest_servo_error_um = ground->largest_servo_error_um;
    for (std::size_t d = 0; d < it.part.error_um.size(); ++d) {
      it.residual_max_um = std::max(it.residual_max_um, std::abs(it.part.error_um[d] - it.floor.error_um[d]));
    }

    SimulatorSettings gauge = settings.gauge;
    gauge.seed = settings.gauge.seed + static_cast<std::uint64_t>(i);
    gauge.gauge_offset_mm = 0.0;
    gauge.ground_reading_mm = ground->gauge_reading_mm;
    JobSettings job = settings.job;
    job.build_on_table_in_force = true;
    if (job.note.empty()) job.note = "virtual grinder pin " + std::to_string(i) + ", ground from " + it.ground_from;
    Result<JobReport> report =
        measure_on_gauge_simulator(frame.part, frame.design, gauge, settings.response_timeout, job);
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
