// demo, sim and measure: the commands that talk to a gauge (or run the simulated one).
#include <signal.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

#include "acquisition/modbus_gauge.h"
#include "acquisition/tcp_endpoint.h"
#include "cli/cli_common.h"
#include "cli/embedded_defaults.h"
#include "cli/gear_loop.h"
#include "cli/grinding_loop.h"
#include "cli/measure_options.h"
#include "cli/pin_loop.h"
#include "compensation/periodic_spline.h"
#include "compensation/pin_kinematics.h"
#include "compensation/pin_path.h"
#include "compensation/wheel_path.h"
#include "compensation/work_speed.h"
#include "config/gauge_config.h"
#include "config/gear_file.h"
#include "config/service_config.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "core/text_file.h"
#include "core/verdict_text.h"
#include "job/measure_job.h"
#include "report/cam_report.h"
#include "report/judged_error.h"
#include "report/svg_plot.h"
#include "simulator/gauge_simulator.h"
#include "simulator/surface_roughness.h"
#include "simulator/virtual_grinder.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

// The run's verdict_summary and where its characteristics are listed.
std::string tolerance_text(const JobReport& r) {
  return verdict_summary(r.tolerance_verdict, r.characteristics) + "; `gaugeloop runs show " +
         std::to_string(r.run_id) + "` lists them";
}

// The curve the verdicts judged, when it is not the raw error above, with its own figures: as
// `runs show` says it, from the run as stored.
void print_judged_line(const JobReport& r) {
  if (r.run_id <= 0 || r.characteristics.empty()) return;
  Result<RunStore> store = RunStore::open_read_only(r.db_path);
  Result<StoredRun> run = store ? store->load_run(r.run_id) : Result<StoredRun>(store.error());
  if (!run) return;  // the run is stored; `runs show` names what could not be read
  const JudgedError judged = judged_error(*run);
  if (!judged.raw_error_um) return;
  std::printf("  judged            %s: max %.2f um at cam %d deg, RMS %.2f um, peak to valley %.2f um\n",
              judged.name.c_str(), judged.max_abs_um, judged.max_abs_at_deg, judged.rms_um, judged.peak_to_valley_um);
}

void print_report(const JobReport& r, const Part& part, const std::string& machine) {
  const auto& a = r.analysis;
  const int revs = static_cast<int>(r.measured.revolutions.size());
  std::printf("run %lld: %s lobe %d on %s\n", static_cast<long long>(r.run_id), part.name.c_str(), part.lobe,
              machine.c_str());
  std::printf("  revolutions       %d (%lld discarded, %lld reconnects, %lld polls)\n", revs,
              static_cast<long long>(r.measured.discarded_revolutions), static_cast<long long>(r.measured.reconnects),
              static_cast<long long>(r.measured.polls));
  std::printf("  degrees captured  %d of %d\n", revs * kDegreesPerRevolution, revs * kDegreesPerRevolution);
  std::printf("  max lift error    %.2f um (raw: at nominal timing)\n", a.max_abs_error_um);
  std::printf("  RMS lift error    %.2f um (raw)\n", a.rms_error_um);
  std::printf("  peak to valley    %.2f um (raw)\n", a.peak_to_valley_um);
  std::printf("  repeatability     %.2f um (largest per-degree standard deviation)\n", a.repeatability_um);
  std::printf("  phase             %+.3f deg (timing; corrected through the lift)\n", a.phase_error_deg);
  std::printf("  runout            %.2f um (base circle, dial: total indicator reading)\n", a.dial_runout_um);
  std::printf("  eccentricity      %.2f um (base circle's first harmonic, as the runout of a pure eccentric)\n",
              a.base_circle_runout_um);
  std::printf("  tolerances        %s\n", tolerance_text(r).c_str());
  print_judged_line(r);
  if (!r.ground_with_source.empty()) {
    const std::string table =
        r.ground_with_version ? "table version " + std::to_string(*r.ground_with_version) : "the design (no table)";
    const std::string who = r.ground_with_source == "plc"      ? "said by the PLC"
                            : r.ground_with_source == "option" ? "said by --ground-with"
                            : r.ground_with_version            ? "assumed: the table in force"
                                                               : "assumed: no table pushed yet";
    std::printf("  ground with       %s (%s)\n", table.c_str(), who.c_str());
    if (!r.ground_with_evidence.empty()) std::printf("                    %s\n", r.ground_with_evidence.c_str());
  }
  if (r.inspection) {
    std::printf("  correction        inspection only: the correction in force stands\n");
  } else if (r.correction_in_force_run) {
    std::printf("  correction        %.2f um max, built on run %lld's (the table that ground the part)\n",
                r.correction_max_um, static_cast<long long>(*r.correction_in_force_run));
  } else {
    std::printf("  correction        %.2f um max, from the design\n", r.correction_max_um);
  }
  if (!r.interpolation.empty()) {
    std::printf("  curve table       %d blocks, %s, command position error %.3f um\n", r.table_blocks,
                r.table_writer.c_str(), r.command_error_um);
  }
  if (r.pushed()) {
    std::printf("  NC file           %s (table version %d)\n", r.nc_file.string().c_str(), r.table_version);
  } else if (r.inspection) {
    std::printf("  NC file           untouched (inspection)\n");
  } else {
    std::printf("  NC file           not written (compensation: %s); the table in force stays\n",
                std::string(compensation_verdict_name(r.verdict)).c_str());
    std::printf("  why               %s\n", r.not_pushed_reason.c_str());
    if (r.pending_id) {
      std::printf("  pending table     %lld: `gaugeloop nc approve %lld` writes it\n",
                  static_cast<long long>(*r.pending_id), static_cast<long long>(*r.pending_id));
    }
  }
  std::printf("  database          %s\n", r.db_path.string().c_str());
  if (!r.history_warning.empty()) std::fprintf(stderr, "gaugeloop: warning: %s\n", r.history_warning.c_str());
}

int run_job(GaugeClient& gauge, const LoadedPart& lp, const MeasureOptions& o, bool build_on_table_in_force) {
  Result<JobSettings> settings = job_settings_for(lp, o, build_on_table_in_force);
  if (!settings) return report_error(settings.error());
  const JobSettings& js = *settings;
  Result<JobReport> report = run_measure_job(gauge, js);
  if (!report) return report_error(report.error());
  print_report(*report, js.part, js.machine);
  return report->pushed() || report->inspection ? kExitOk : kExitNotPushed;
}

// The report of the demo's last run (a lobe's or a pin's), as a quality engineer files it:
// <data-dir>/report.pdf.
// A report that cannot be written is said, and the demo's outcome stands.
void write_demo_report(const MeasureOptions& o, std::int64_t run_id) {
  const std::filesystem::path pdf = std::filesystem::path(o.paths.data_dir) / "report.pdf";
  Result<RunStore> store = open_history_read_only(o.paths);
  Result<StoredRun> run = store ? store->load_run(run_id) : Result<StoredRun>(store.error());
  Status written = run ? write_cam_report(*run, pdf) : Status(run.error());
  if (!written) {
    std::printf("report: not written: %s\n", written.error().message.c_str());
    return;
  }
  std::printf("report: %s (run %lld; `gaugeloop runs report ID --out F.pdf|.svg|.png` for any run)\n",
              pdf.string().c_str(), static_cast<long long>(run_id));
}

// The loop's first step: the program written from the drawing that part 0 is ground from.
void print_new_program(const NewProgramReport& r) {
  const BuiltTable& b = r.preview.built;
  const std::string layer = r.design_file.empty()
                                ? std::string()
                                : r.design_file.filename().string() + " (the design table) and the correction layer ";
  std::printf("new program: %s%s v%d from the drawing, %d blocks (%s), seam C%.3f, command position error %.3f um",
              layer.c_str(), r.nc_file.filename().string().c_str(), r.table_version, b.table.block_count(),
              std::string(interpolation_name(b.table.interpolation)).c_str(), b.table.points.front().c_deg,
              b.table.error.max_abs_um);
  if (b.y_table) {
    std::printf("; Y %d blocks, seam C%.3f, %.3f um", b.y_table->block_count(), b.y_table->points.front().c_deg,
                b.y_table->error.max_abs_um);
  }
  std::printf("; %d turns from %.3f mm of stock and air gap; read back from %s\n", r.preview.infeed.turns(),
              r.preview.infeed.start_offset_mm, r.nc_file.parent_path().string().c_str());
  std::fflush(stdout);
}

// demo --iterations: the loop on the virtual grinder (docs/virtual_grinder.md).
struct LoopOptions {
  int iterations = 0;     // 0: one run on the simulator's built-in form error
  std::string plot_path;  // empty: <data-dir>/loop.svg
  MachineErrorModel machine;
  // --speed-program: the variable-speed camshaft paper's comparison, the loop ground twice: at
  // one grinding-point speed all round (the paper's baseline, 8000 mm/min unset), then with
  // the rise and return slowed to the flank speed (2000 unset), base circle and nose left at
  // the first. The part file's [speed] with hold = "flanks" gives both speeds; the flags
  // override it. base_speed_rpm: the most C turns (the part file's, else 120).
  bool speed_program = false;
  std::optional<double> grinding_point_speed_mm_per_min;
  std::optional<double> flank_speed_mm_per_min;
  std::optional<double> base_speed_rpm;
};

int cmd_pin_demo_loop(const MeasureOptions& o, const LoadedPart& lp, const SimulatorSettings& sim_settings,
                      const LoopOptions& lo);

// demo --part <gear>: the gear's loop on the virtual gear grinder (docs/gears.md); -1: not a gear.
int gear_demo_if_gear(const MeasureOptions& o, const LoopOptions& lo) {
  if (o.part_path.empty()) return -1;
  Result<bool> gear = is_gear_part_file(o.part_path);
  if (!gear) return report_error(gear.error());
  if (!*gear) return -1;
  GearDemoOptions g;
  g.paths = o.paths;
  g.part_path = o.part_path;
  g.iterations = lo.iterations > 0 ? lo.iterations : 2;
  g.machine_seed = lo.machine.seed;
  g.z_increments_per_mm = o.int_incr_per_mm;
  return run_gear_demo(g);
}

int cmd_demo(const MeasureOptions& o, const SimulatorSettings& sim_settings, const LoopOptions& lo) {
  if (const int gear = gear_demo_if_gear(o, lo); gear >= 0) return gear;
  Result<LoadedPart> lp = load_part(o.part_path);
  if (!lp) return report_error(lp.error());
  // A pin is always ground on the virtual grinder: the simulator has no built-in pin.
  if (lp->file.pin) return cmd_pin_demo_loop(o, *lp, sim_settings, lo);
  // A correction layer is added to the design table on the control: written from the drawing
  // first when it is not there yet, as the loop's first program is.
  if (lp->file.layer_design_table_number != 0) {
    Result<JobSettings> job = job_settings_for(*lp, o, /*build_on_table_in_force=*/false);
    if (!job) return report_error(job.error());
    if (!std::filesystem::exists(design_program_path(job->nc_dir / (job->nc_program + ".SPF")))) {
      Result<NewProgramReport> first = write_first_program(*job, o.part_path, print_new_program);
      if (!first) return report_error(first.error());
    }
  }
  auto sim = GaugeSimulator::start(lp->file.part, lp->design, sim_settings);
  if (!sim) return report_error(sim.error());
  std::printf(
      "simulator: %s lobe %d turning at %.0f rpm on 127.0.0.1:%d (form error %.1f um peak, noise %.1f um RMS, seed "
      "%llu)\n",
      lp->file.part.name.c_str(), lp->file.part.lobe, sim_settings.speed_rpm, (*sim)->port(),
      sim_settings.lobe_error_peak_um, sim_settings.noise_rms_um, static_cast<unsigned long long>(sim_settings.seed));
  std::printf("measuring %d revolutions in %s mode...\n", o.revolutions, o.mode.c_str());
  std::fflush(stdout);
  ModbusSettings ms;
  ms.port = (*sim)->port();
  ms.response_timeout = std::chrono::milliseconds(o.response_timeout_ms);
  ModbusGauge gauge(ms);
  const int status = run_job(gauge, *lp, o, /*build_on_table_in_force=*/false);
  if (status == kExitOk || status == kExitNotPushed) {
    if (Result<RunStore> store = open_history_read_only(o.paths)) {
      RunQuery newest;
      newest.limit = 1;
      if (Result<std::vector<RunSummary>> runs = store->list_runs(newest); runs && !runs->empty()) {
        write_demo_report(o, runs->front().id);
      }
    }
  }
  return status;
}

// One arm of the demo's speed comparison: the program for the part within the job's slide
// limits, and the surface it leaves.
struct DemoSpeedArm {
  WorkSpeedSettings settings;
  WorkSpeedPlan plan;
  SurfaceFinish finish;
  // The grinding-point speed over the flanks (the rows of the flank figure), mm/min: the
  // roughness model is calibrated from 2000 to 8000 mm/min only.
  double flank_speed_min_mm_per_min = 0.0;
  double flank_speed_max_mm_per_min = 0.0;
};

// The paper's baseline (one grinding-point speed all round) and its program (the flanks
// slowed), on the design path of `lp` at 0.5 deg.
Result<std::array<DemoSpeedArm, 2>> demo_speed_arms(const LoadedPart& lp, const JobSettings& job,
                                                    const LoopOptions& lo) {
  Result<PeriodicSpline> lift = PeriodicSpline::fit(lp.design.angle_deg, lp.design.lift_mm);
  if (!lift) return lift.error();
  Result<MachinePath> path = compute_machine_path(*lift, lp.file.part, 0.5);
  if (!path) return path.error();
  WorkSpeedSettings ws;
  ws.hold = SpeedHold::kFlanks;
  ws.base_speed_rpm = 120.0;
  if (lp.file.speed && lp.file.speed->hold == SpeedHold::kFlanks) ws = *lp.file.speed;
  if (lo.base_speed_rpm) ws.base_speed_rpm = *lo.base_speed_rpm;
  if (lo.grinding_point_speed_mm_per_min) ws.grinding_point_speed_mm_per_min = *lo.grinding_point_speed_mm_per_min;
  if (lo.flank_speed_mm_per_min) ws.flank_speed_mm_per_min = *lo.flank_speed_mm_per_min;
  ws.x_velocity_max_mm_per_s = job.axis_limits.x_velocity_max_mm_per_s;
  ws.x_acceleration_max_mm_per_s2 = job.axis_limits.x_acceleration_max_mm_per_s2;
  WorkSpeedSettings baseline = ws;
  baseline.flank_speed_mm_per_min = ws.grinding_point_speed_mm_per_min;
  const double x_max = *std::max_element(path->x_mm.begin(), path->x_mm.end());
  const RoughnessModel roughness = paper_roughness_model();
  std::array<DemoSpeedArm, 2> arms;
  for (int i = 0; i < 2; ++i) {
    DemoSpeedArm& arm = arms[static_cast<std::size_t>(i)];
    arm.settings = i == 0 ? baseline : ws;
    Result<WorkSpeedPlan> plan = plan_work_speed(*path, lp.file.part, arm.settings);
    if (!plan) return plan.error();
    arm.plan = std::move(*plan);
    arm.finish = surface_finish(*path, arm.plan.grinding_point_speed_mm_per_min, roughness);
    arm.flank_speed_min_mm_per_min = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < path->x_mm.size(); ++k) {
      if (!is_flank_row(path->x_mm[k], x_max)) continue;
      const double v = arm.plan.grinding_point_speed_mm_per_min[k];
      arm.flank_speed_min_mm_per_min = std::min(arm.flank_speed_min_mm_per_min, v);
      arm.flank_speed_max_mm_per_min = std::max(arm.flank_speed_max_mm_per_min, v);
    }
  }
  return arms;
}

// demo --part <pin> [--iterations N]: the pin loop on the virtual grinder (docs/crankpins.md).
int cmd_pin_demo_loop(const MeasureOptions& o, const LoadedPart& lp, const SimulatorSettings& sim_settings,
                      const LoopOptions& lo) {
  Result<JobSettings> job = job_settings_for(lp, o, /*build_on_table_in_force=*/false);
  if (!job) return report_error(job.error());
  const PinGeometry& pin = *lp.file.pin;
  PinLoopSettings ls;
  ls.job = std::move(*job);
  ls.job.axis_limits.speed_rpm = lo.machine.work_speed_rpm;
  ls.job.y_axis_limits.speed_rpm = lo.machine.work_speed_rpm;
  ls.machine.x = lo.machine;
  ls.machine.y = lo.machine;  // the same slide: a C-X-Y machine's Y is built like its X
  ls.gauge = sim_settings;
  ls.response_timeout = std::chrono::milliseconds(o.response_timeout_ms);
  ls.iterations = lo.iterations;
  ls.part_file = o.part_path;
  const MachineErrorModel& m = lo.machine;
  std::optional<WorkSpeedPlan> speed;
  if (ls.job.speed) {
    // The grinder turns C at the program planned on the design path, as the control would
    // run the speed subprogram pushed with the first table.
    Result<PinPath> path = compute_pin_path(pin, 0.5);
    if (!path) return report_error(path.error());
    WorkSpeedSettings ws = *ls.job.speed;
    ws.x_velocity_max_mm_per_s = ls.job.axis_limits.x_velocity_max_mm_per_s;
    ws.x_acceleration_max_mm_per_s2 = ls.job.axis_limits.x_acceleration_max_mm_per_s2;
    Result<WorkSpeedPlan> plan = plan_pin_work_speed(*path, pin, ws);
    if (!plan) return report_error(plan.error());
    ls.machine.x.speed_program = plan->program;
    ls.machine.y.speed_program = plan->program;
    speed = std::move(*plan);
  }
  std::printf(
      "virtual grinder: %s pin %d, %s, throw %.1f mm, pin radius %.1f mm, wheel %.0f mm, at %.0f rpm; servo %.0f Hz "
      "(damping %.2f, feed-forward %.3f) on %s, geometric %.1f + %.1f um, drift %.2f um/part, vibration %.2f um "
      "RMS (harmonics %d..%d), seed %llu\n",
      lp.file.part.name.c_str(), lp.file.part.lobe, pin.mode == PinMode::kCXY ? "C-X-Y" : "C-X", pin.throw_mm,
      pin.pin_radius_mm, pin.wheel_radius_mm, m.work_speed_rpm, m.servo_bandwidth_hz, m.servo_damping,
      m.velocity_feed_forward, pin.mode == PinMode::kCXY ? "X and Y" : "X", m.geometric_once_um, m.geometric_twice_um,
      m.drift_um_per_part, m.vibration_rms_um, m.vibration_min_harmonic, m.vibration_max_harmonic,
      static_cast<unsigned long long>(m.seed));
  std::printf(
      "gauge: riding on the pin, %.0f pin degrees from the grinding point; simulator at %.0f rpm x %.0f, noise "
      "%.1f um RMS (seed %llu), %d revolutions %s; database %s\n\n",
      pin.gauge_offset_deg, sim_settings.speed_rpm, sim_settings.time_scale, sim_settings.noise_rms_um,
      static_cast<unsigned long long>(sim_settings.seed), o.revolutions, o.mode.c_str(),
      ls.job.db_path.string().c_str());
  const bool with_y = pin.mode == PinMode::kCXY;
  ls.on_new_program = [](const NewProgramReport& r) {
    print_new_program(r);
    std::printf(
        "part  ground from                   run  max um  round um  diam um  stroke um  index deg  verdict | true max  "
        "true round  floor  left  table\n");
  };
  auto print_part = [with_y](const PinLoopIteration& it) {
    const JobReport& r = it.job;
    auto figure = [&r](const std::string& key) {
      for (const Characteristic& c : r.characteristics) {
        if (c.key == key) return c.value;
      }
      return 0.0;
    };
    std::string table =
        r.pushed() ? "v" + std::to_string(r.table_version) + ", X " + std::to_string(r.table_blocks) + " blocks " +
                         format_fixed(r.command_error_um, 3) + " um"
                   : "not pushed (" + std::string(compensation_verdict_name(r.verdict)) + "): " + r.not_pushed_reason;
    if (r.pushed() && with_y) {
      table += ", Y " + std::to_string(r.y_table_blocks) + " blocks " + format_fixed(r.y_command_error_um, 3) + " um";
    }
    if (r.pushed()) table += ", harmonics 0.." + std::to_string(r.harmonics_fed_back);
    // Signed figures through format_signed_fixed: never "-0.0000" for a value that rounds to zero.
    std::printf("%4d  %-27s %5lld  %6.2f  %8.2f  %7s  %9s  %9s  %-7s | %8.2f  %10.2f  %5.2f  %4.2f  %s\n", it.iteration,
                it.ground_from.c_str(), static_cast<long long>(r.run_id), r.analysis.max_abs_error_um,
                figure("roundness"), format_signed_fixed(figure("diameter_error"), 2).c_str(),
                format_signed_fixed(figure("stroke_error"), 2).c_str(),
                format_signed_fixed(figure("index_error"), 4).c_str(),
                std::string(verdict_name(r.tolerance_verdict)).c_str(), it.part.max_abs_um, it.part.roundness_um,
                it.floor.max_abs_um, it.residual_max_um, table.c_str());
    std::fflush(stdout);
  };
  Result<std::vector<PinLoopIteration>> loop = run_pin_grinding_loop(ls, print_part);
  if (!loop) return report_error(loop.error());
  const PinLoopIteration& first = loop->front();
  const PinLoopIteration& last = loop->back();
  std::printf(
      "\nlargest radius error %.2f um as ground before compensation, %.2f um after %d (roundness %.2f um); floor "
      "%.2f um (a perfect path under the same vibration)",
      first.part.max_abs_um, last.part.max_abs_um, last.iteration, last.part.roundness_um, last.floor.max_abs_um);
  // Without vibration there is no floor to compare with.
  if (last.floor.max_abs_um >= 0.01)
    std::printf(": %.2f times the floor", last.part.max_abs_um / last.floor.max_abs_um);
  std::printf("\n");
  if (speed) {
    const auto [low, high] = std::minmax_element(speed->grinding_point_speed_mm_per_min.begin(),
                                                 speed->grinding_point_speed_mm_per_min.end());
    std::printf(
        "speed program: grinding point %.0f to %.0f mm/min over a turn (%.3f to 1); one turn %.3f s against %.3f s at "
        "%.0f rpm\n",
        *low, *high, *high / *low, speed->cycle_time_s, speed->constant_cycle_time_s, ls.job.speed->base_speed_rpm);
  }
  if (!with_y) {
    const double fastest = pin_grinding_point_speed_mm_per_min(pin, -pin.pin_angle_deg, m.work_speed_rpm);
    const double slowest = pin_grinding_point_speed_mm_per_min(pin, 180.0 - pin.pin_angle_deg, m.work_speed_rpm);
    std::printf(
        "grinding-point speed at %.0f rpm: %.0f to %.0f mm/min over a turn, %.3f to 1 (C-X; a speed program holds it: "
        "[speed] in the part file)\n",
        m.work_speed_rpm, slowest, fastest, fastest / slowest);
  }
  write_demo_report(o, last.job.run_id);
  return std::all_of(loop->begin(), loop->end(), [](const PinLoopIteration& it) { return it.job.pushed(); })
             ? kExitOk
             : kExitNotPushed;
}

int cmd_demo_loop(const MeasureOptions& o, const SimulatorSettings& sim_settings, const LoopOptions& lo) {
  if (const int gear = gear_demo_if_gear(o, lo); gear >= 0) return gear;
  Result<LoadedPart> lp = load_part(o.part_path);
  if (!lp) return report_error(lp.error());
  if (lp->file.pin) return cmd_pin_demo_loop(o, *lp, sim_settings, lo);
  Result<JobSettings> job = job_settings_for(*lp, o, /*build_on_table_in_force=*/false);
  if (!job) return report_error(job.error());
  LoopSettings ls;
  ls.job = std::move(*job);
  // The grinder grinds at one speed unless --speed-program: so does the table program.
  set_speed_program(ls.job, std::nullopt, o);
  ls.machine = lo.machine;
  ls.gauge = sim_settings;
  ls.response_timeout = std::chrono::milliseconds(o.response_timeout_ms);
  ls.iterations = lo.iterations;
  ls.part_file = o.part_path;
  const MachineErrorModel& m = lo.machine;
  std::printf(
      "virtual grinder: %s lobe %d at %.0f rpm; servo %.0f Hz (damping %.2f, feed-forward %.3f), geometric "
      "%.1f + %.1f um, drift %.2f um/part, vibration %.2f um RMS (harmonics %d..%d), seed %llu\n",
      lp->file.part.name.c_str(), lp->file.part.lobe, m.work_speed_rpm, m.servo_bandwidth_hz, m.servo_damping,
      m.velocity_feed_forward, m.geometric_once_um, m.geometric_twice_um, m.drift_um_per_part, m.vibration_rms_um,
      m.vibration_min_harmonic, m.vibration_max_harmonic, static_cast<unsigned long long>(m.seed));
  std::printf("gauge: simulator at %.0f rpm x %.0f, noise %.1f um RMS (seed %llu), %d revolutions %s; database %s\n\n",
              sim_settings.speed_rpm, sim_settings.time_scale, sim_settings.noise_rms_um,
              static_cast<unsigned long long>(sim_settings.seed), o.revolutions, o.mode.c_str(),
              ls.job.db_path.string().c_str());
  auto print_part = [](const LoopIteration& it) {
    const LobeAnalysis& a = it.job.analysis;
    const std::string table =
        it.job.pushed() ? "v" + std::to_string(it.job.table_version) + ", " + std::to_string(it.job.table_blocks) +
                              " blocks, harmonics 0.." + std::to_string(it.job.harmonics_fed_back)
                        : "not pushed (" + std::string(compensation_verdict_name(it.job.verdict)) +
                              "): " + it.job.not_pushed_reason;
    std::printf("%4d  %-26s %5lld  %10.2f  %10.2f  %+9.4f  %9.2f  %-7s | %8.2f  %5.2f  %s\n", it.iteration,
                it.ground_from.c_str(), static_cast<long long>(it.job.run_id), a.max_abs_error_um, a.rms_error_um,
                a.phase_error_deg, a.dial_runout_um, std::string(verdict_name(it.job.tolerance_verdict)).c_str(),
                it.part.max_abs_um, it.floor.max_abs_um, table.c_str());
    std::fflush(stdout);
  };
  const char* header =
      "part  ground from                  run  raw max um  raw RMS um  phase deg  runout um  verdict | true max  floor "
      " "
      "table\n";
  ls.on_new_program = [header](const NewProgramReport& r) {
    print_new_program(r);
    std::printf("%s", header);
  };
  std::optional<std::array<DemoSpeedArm, 2>> speed;
  std::optional<LoopIteration> baseline_last;
  if (lo.speed_program) {
    Result<std::array<DemoSpeedArm, 2>> planned = demo_speed_arms(*lp, ls.job, lo);
    if (!planned) return report_error(planned.error());
    speed = std::move(*planned);
    const WorkSpeedSettings& b = (*speed)[0].settings;
    std::printf("at one grinding-point speed, %.0f mm/min all round (C at most %.0f rpm):\n",
                b.grinding_point_speed_mm_per_min, b.base_speed_rpm);
    std::fflush(stdout);
    // Every table of both arms goes to the control with its speed subprogram beside it.
    ls.machine.speed_program = (*speed)[0].plan.program;
    set_speed_program(ls.job, b, o);
    Result<std::vector<LoopIteration>> baseline = run_grinding_loop(ls, print_part);
    if (!baseline) return report_error(baseline.error());
    baseline_last = baseline->back();
    const WorkSpeedSettings& w = (*speed)[1].settings;
    ls.machine.speed_program = (*speed)[1].plan.program;
    set_speed_program(ls.job, w, o);
    std::printf("\nwith the rise and return at %.0f mm/min, base circle and nose at %.0f mm/min:\n",
                w.flank_speed_mm_per_min, w.grinding_point_speed_mm_per_min);
  }
  std::fflush(stdout);
  Result<std::vector<LoopIteration>> loop = run_grinding_loop(ls, print_part);
  if (!loop) return report_error(loop.error());
  const LoopIteration& first = loop->front();
  const LoopIteration& last = loop->back();
  std::printf("\nraw max lift error %.2f um before compensation", first.job.analysis.max_abs_error_um);
  if (loop->size() > 1)
    std::printf(", %.2f um after 1 iteration (published cam-grinding result: 2.6 um)",
                (*loop)[1].job.analysis.max_abs_error_um);
  std::printf(
      ", %.2f um after %d; the part as ground: %.2f um, floor %.2f um (a perfect table under the same "
      "vibration)\n",
      last.job.analysis.max_abs_error_um, last.iteration, last.part.max_abs_um, last.floor.max_abs_um);
  if (speed) {
    const DemoSpeedArm& base = (*speed)[0];
    const DemoSpeedArm& slow = (*speed)[1];
    const std::string against =
        "at a constant " + format_fixed(base.settings.grinding_point_speed_mm_per_min, 0) + " mm/min";
    std::printf("speed program: cycle time %.3f s against %.3f s %s\n", slow.plan.cycle_time_s, base.plan.cycle_time_s,
                against.c_str());
    std::printf(
        "speed program: flank Ra %.2f um against %.2f um %s (the largest on the flanks; flanks ground at %.0f..%.0f "
        "against %.0f..%.0f mm/min)\n",
        slow.finish.flank_ra_um, base.finish.flank_ra_um, against.c_str(), slow.flank_speed_min_mm_per_min,
        slow.flank_speed_max_mm_per_min, base.flank_speed_min_mm_per_min, base.flank_speed_max_mm_per_min);
    // The flank figure is the largest Ra on the flanks, at the fastest flank row: the model's
    // range matters there.
    auto fitted = [](double v) { return v >= 2000.0 - 0.5 && v <= 8000.0 + 0.5; };
    const bool calibrated = fitted(slow.flank_speed_max_mm_per_min) && fitted(base.flank_speed_max_mm_per_min);
    std::printf(
        "speed program: Ra is a model, not a measurement: a power law in h_eq fitted to the paper's two points "
        "(8000 mm/min: 3.2 um, 2000 mm/min: 0.775 um); the flank figures are taken at %.0f and %.0f mm/min, %s\n",
        slow.flank_speed_max_mm_per_min, base.flank_speed_max_mm_per_min,
        calibrated ? "within the 2000..8000 mm/min it was fitted on"
                   : "outside the 2000..8000 mm/min it was fitted on: "
                     "an extrapolation");
    std::printf("speed program: form error %.2f um against %.2f um %s (true max of the last part; floor %.2f um)\n",
                last.part.max_abs_um, baseline_last->part.max_abs_um, against.c_str(), last.floor.max_abs_um);
  }

  LoopPlot plot;
  plot.title = "Grinding loop \u00b7 " + lp->file.part.name + " lobe " + std::to_string(lp->file.part.lobe) +
               " \u00b7 virtual grinder";
  plot.subtitle = std::to_string(loop->size()) + " parts, measured through the gauge simulator; runs " +
                  std::to_string(first.job.run_id) + " to " + std::to_string(last.job.run_id) + " in " +
                  ls.job.db_path.string();
  for (const LoopIteration& it : *loop) {
    LoopPlotPart part;
    part.label = "part " + std::to_string(it.iteration);
    part.error_um = it.job.analysis.error_um;
    part.measured_max_um = it.job.analysis.max_abs_error_um;
    part.true_max_um = it.part.max_abs_um;
    part.floor_max_um = it.floor.max_abs_um;
    plot.parts.push_back(std::move(part));
  }
  char footer[256];
  std::snprintf(
      footer, sizeof footer,
      "servo %.0f Hz, feed-forward %.3f, geometric %.1f + %.1f um, drift %.2f um/part, vibration %.2f um RMS, "
      "seed %llu \u00b7 gaugeloop %s",
      m.servo_bandwidth_hz, m.velocity_feed_forward, m.geometric_once_um, m.geometric_twice_um, m.drift_um_per_part,
      m.vibration_rms_um, static_cast<unsigned long long>(m.seed), GAUGELOOP_VERSION);
  plot.footer = footer;
  const std::filesystem::path svg_path =
      lo.plot_path.empty() ? std::filesystem::path(o.paths.data_dir) / "loop.svg" : std::filesystem::path(lo.plot_path);
  if (Status w = write_file_atomically(svg_path, render_loop_plot_svg(plot)); !w) {
    return report_file_error(w.error());
  }
  std::printf("plot: %s\n", svg_path.string().c_str());
  write_demo_report(o, loop->back().job.run_id);
  return std::all_of(loop->begin(), loop->end(), [](const LoopIteration& it) { return it.job.pushed(); })
             ? kExitOk
             : kExitNotPushed;
}

int cmd_measure(const MeasureOptions& o, const std::string& gauge_address) {
  ModbusSettings ms;
  ms.response_timeout = std::chrono::milliseconds(o.response_timeout_ms);
  if (!o.gauge_config.empty()) {
    Result<ModbusSettings> from_file = read_gauge_file(o.gauge_config, ms);
    if (!from_file) return report_error(from_file.error());
    ms = std::move(*from_file);
  }
  if (!gauge_address.empty()) {
    Result<TcpEndpoint> endpoint = parse_tcp_endpoint(gauge_address);
    if (!endpoint) return report_error(make_error(ErrorCode::kInvalidInput, "--gauge " + endpoint.error().message));
    ms.host = endpoint->host;
    ms.port = endpoint->port;
  } else if (o.gauge_config.empty()) {
    return report_error(make_error(ErrorCode::kInvalidInput,
                                   "no gauge: give --gauge HOST:PORT or a --gauge-config file with a [link] table"));
  }
  Result<LoadedPart> lp = load_part(o.part_path);
  if (!lp) return report_error(lp.error());
  ModbusGauge gauge(ms);
  return run_job(gauge, *lp, o, /*build_on_table_in_force=*/true);
}

// measure --config: a run by hand as the service makes one, with its gauge, settings,
// database and NC directory, beside it or instead of it.
struct ServiceMeasureOptions {
  std::string config_path;
  std::string part_name;
  int lobe = 0;
};

int cmd_measure_as_service(const ServiceMeasureOptions& so, const MeasureOptions& by_hand) {
  if (Status ids = check_identity_options(by_hand); !ids) return report_error(ids.error());
  Result<ServiceConfig> config = read_service_config(so.config_path);
  if (!config) return report_error(config.error());
  if (so.part_name.empty() || so.lobe == 0) {
    return report_error(make_error(ErrorCode::kInvalidInput, "--config needs --part-name and --lobe: which of " +
                                                                 configured_parts(*config) + " to measure"));
  }
  Result<const ServicePart*> part = find_part(*config, so.part_name, so.lobe);
  if (!part) return report_error(part.error());
  JobSettings js = job_for(*config, **part);
  js.note = by_hand.note;
  js.serial = by_hand.serial;
  js.operator_name = by_hand.operator_name;
  Result<std::optional<PartTemperature>> temperature = part_temperature_option(by_hand);
  if (!temperature) return report_error(temperature.error());
  js.part_temperature = *temperature;
  js.ground_with_version = by_hand.ground_with;
  js.ground_with_source = "option";
  js.inspect = by_hand.inspect;
  ModbusGauge gauge(config->gauge);
  Result<JobReport> report = run_measure_job(gauge, js);
  if (!report) return report_error(report.error());
  print_report(*report, js.part, js.machine);
  return report->pushed() || report->inspection ? kExitOk : kExitNotPushed;
}

// db import-unstored: the runs the database refused, from the measurements kept of them.
struct ImportUnstoredOptions {
  std::vector<std::string> files;
  MeasureOptions by_hand;   // --part, --data-dir, --machine and the program options
  std::string config_path;  // or the service's config: its parts, database and NC directory
};

int cmd_import_unstored(const ImportUnstoredOptions& o) {
  // With --config each run's part is looked up in it; with --part one job serves every file.
  std::optional<ServiceConfig> config;
  std::optional<JobSettings> by_hand;
  if (!o.config_path.empty()) {
    Result<ServiceConfig> read = read_service_config(o.config_path);
    if (!read) return report_error(read.error());
    config = std::move(*read);
  } else if (!o.by_hand.part_path.empty()) {
    Result<LoadedPart> loaded = load_part(o.by_hand.part_path);
    if (!loaded) return report_error(loaded.error());
    Result<JobSettings> js = job_settings_for(*loaded, o.by_hand, /*build_on_table_in_force=*/false);
    if (!js) return report_error(js.error());
    by_hand = std::move(*js);
  } else {
    return report_error(make_error(ErrorCode::kInvalidInput,
                                   "give --part FILE (the part file the runs were measured with, with --data-dir) or "
                                   "--config FILE (the service's)"));
  }
  int status = kExitOk;
  const auto failed = [&status](const Error& e) {
    const int code = report_error(e);
    if (status == kExitOk) status = code;
  };
  for (const std::string& file : o.files) {
    Result<UnstoredRun> kept = read_unstored_run(file);
    if (!kept) {
      failed(kept.error());
      continue;
    }
    std::optional<JobSettings> from_config;
    if (config) {
      Result<const ServicePart*> part = find_part(*config, kept->part, kept->lobe);
      if (!part) {
        failed(part.error());
        continue;
      }
      from_config = job_for(*config, **part);
    }
    Result<JobReport> report = store_unstored_run(*kept, from_config ? *from_config : *by_hand);
    if (!report) {
      failed(report.error());
      continue;
    }
    // Stored: the file goes aside, so that a second import does not store the run twice.
    const std::filesystem::path from(file);
    const std::filesystem::path imported = from.parent_path() / "imported" / from.filename();
    std::error_code ec;
    std::filesystem::create_directories(imported.parent_path(), ec);
    if (!ec) std::filesystem::rename(from, imported, ec);
    std::printf(
        "run %lld stored from %s (measured %s; an inspection: the table in force is unchanged)%s\n",
        static_cast<long long>(report->run_id), file.c_str(), kept->started_utc.c_str(),
        ec ? ("; the file could not be moved aside (" + ec.message() + "): remove it before importing again").c_str()
           : ("; the file is now " + imported.string()).c_str());
  }
  return status;
}

// sim --grind: the machine beside the gauge. Whenever the program in the NC directory
// changes (a new table pushed), the next part is ground from it on the virtual grinder and put
// on the gauge; at the start, from the program found there, or from the design.
struct SimGrind {
  bool enabled = false;
  DataPaths paths;
  MachineErrorModel machine;
};

class SimGrinder {
 public:
  SimGrinder(const LoadedPart& lp, const SimGrind& g, GaugeSimulator& sim)
      : lp_(lp), g_(g), sim_(sim), nc_file_(g.paths.nc() / (lp.file.nc_program + ".SPF")) {}

  // Grinds the next part when the program changed since the last one; returns false on an
  // error (said on stderr; the gauge keeps the part it has).
  bool grind_if_changed() {
    std::string program;
    if (std::filesystem::exists(nc_file_)) {
      Result<std::string> text = read_regular_file(nc_file_, "NC program");
      if (!text) return complain(text.error());
      program = std::move(*text);
    }
    if (parts_ > 0 && program == last_program_) return true;
    Result<CommandedPath> path =
        program.empty() ? commanded_path_from_design(lp_.file.part, lp_.design) : commanded_path_from_program(nc_file_);
    if (!path) return complain(path.error());
    Result<GroundPart> part = grind_part(lp_.file.part, *path, g_.machine, parts_);
    if (!part) return complain(part.error());
    if (Status s = sim_.load_ground_part(part->reading_mm); !s) return complain(s.error());
    last_program_ = std::move(program);
    std::printf("grinder: part %d ground from %s\n", parts_, path->source.c_str());
    std::fflush(stdout);
    ++parts_;
    return true;
  }

 private:
  bool complain(const Error& e) {
    spdlog::error("grinder: {}", e.message);
    return false;
  }

  const LoadedPart& lp_;
  const SimGrind& g_;
  GaugeSimulator& sim_;
  std::filesystem::path nc_file_;
  std::string last_program_;
  int parts_ = 0;
};

int cmd_sim(const std::string& part_path, const SimulatorSettings& settings, const SimGrind& grind) {
  Result<LoadedPart> lp = load_lobe_part(part_path, "gaugeloop sim");
  if (!lp) return report_error(lp.error());
  if (grind.enabled) {
    if (Status v = validate(grind.machine); !v) return report_error(v.error());
  }
  // Block the stop signals before the server thread starts, so only sigwait below sees them.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  auto sim = GaugeSimulator::start(lp->file.part, lp->design, settings);
  if (!sim) return report_error(sim.error());
  std::optional<SimGrinder> grinder;
  if (grind.enabled) {
    grinder.emplace(*lp, grind, **sim);
    if (!grinder->grind_if_changed()) return kExitBadInput;
  }
  if (settings.rtu_device.empty()) {
    // An IPv6 address in brackets, as --gauge takes it back.
    const std::string host = settings.host.find(':') == std::string::npos ? settings.host : "[" + settings.host + "]";
    std::printf("gaugeloop sim: %s lobe %d at %.0f rpm, Modbus TCP on %s:%d (registers: docs/simulator.md)\n",
                lp->file.part.name.c_str(), lp->file.part.lobe, settings.speed_rpm, host.c_str(), (*sim)->port());
    std::printf("port %d\n", (*sim)->port());
  } else {
    std::printf(
        "gaugeloop sim: %s lobe %d at %.0f rpm, Modbus RTU on %s at %d baud, unit %d (registers: "
        "docs/simulator.md)\n",
        lp->file.part.name.c_str(), lp->file.part.lobe, settings.speed_rpm, settings.rtu_device.c_str(),
        settings.rtu_baud, settings.unit_id);
  }
  std::printf("gauge noise %.1f um RMS, seed %llu (--seed repeats it)\n", settings.noise_rms_um,
              static_cast<unsigned long long>(settings.seed));
  std::fflush(stdout);
  int sig = 0;
  if (grinder) {
    // Look at the NC directory five times a second until a stop signal comes.
    const timespec look_again{0, 200'000'000};
    while ((sig = sigtimedwait(&stop_signals, nullptr, &look_again)) < 0) (void)grinder->grind_if_changed();
  } else {
    sigwait(&stop_signals, &sig);
  }
  (*sim)->stop();
  spdlog::info("simulator stopped after {} requests", (*sim)->requests_served());
  return kExitOk;
}

// `seed_help`: where the noise seed comes from when --seed is not given.
void add_simulator_options(CLI::App& cmd, SimulatorSettings& s, const std::string& seed_help) {
  cmd.add_option("--speed-rpm", s.speed_rpm, "Work spindle speed")->capture_default_str();
  cmd.add_option("--lobe-error-um", s.lobe_error_peak_um, "Peak of the repeatable form error of the simulated lobe")
      ->capture_default_str();
  cmd.add_option("--noise-um", s.noise_rms_um, "Gauge noise, RMS")->capture_default_str();
  cmd.add_option("--seed", s.seed, "Seed of the gauge noise " + seed_help);
}

// A fresh noise seed per start unless --seed gave one: real gauge noise does not repeat.
void seed_from_clock_unless_given(const CLI::App& cmd, SimulatorSettings& s) {
  if (cmd.count("--seed") == 0) {
    s.seed = static_cast<std::uint64_t>(std::chrono::steady_clock::now().time_since_epoch().count()) | 1u;
  }
}

void add_demo_command(CLI::App& app, CommandAction& action) {
  auto demo_opts = std::make_shared<MeasureOptions>();
  auto demo_sim = std::make_shared<SimulatorSettings>();
  CLI::App* demo = app.add_subcommand(
      "demo",
      "Start the built-in gauge simulator on a free loopback port, measure the sample intake lobe through it, "
      "store the run and write the corrected curve table. Needs no files.");
  add_measure_options(*demo, *demo_opts);
  demo->add_option("--part", demo_opts->part_path,
                   "Part file to simulate and measure [built-in intake_flat]; a gear part ([gear]) closes the gear's "
                   "loop on the virtual gear grinder (docs/gears.md; --iterations, 2 if 0, and --machine-seed apply)");
  add_simulator_options(*demo, *demo_sim, "[1: the demo repeats; give another for other noise]");
  demo->add_option("--time-scale", demo_sim->time_scale, "Simulated seconds per real second")->capture_default_str();
  auto loop = std::make_shared<LoopOptions>();
  MachineErrorModel& m = loop->machine;
  demo->add_option("--iterations", loop->iterations,
                   "Close the loop on the virtual grinder N times: grind -> measure -> compensate -> push -> grind; "
                   "prints every part and writes an SVG (docs/virtual_grinder.md). 0: one run, no grinding")
      ->capture_default_str()
      ->check(CLI::Range(0, 100));
  demo->add_option("--plot", loop->plot_path, "SVG of every part's error, with --iterations [<data-dir>/loop.svg]");
  demo->add_option("--work-speed-rpm", m.work_speed_rpm, "Grinding: work spindle speed")->capture_default_str();
  demo->add_option("--servo-hz", m.servo_bandwidth_hz, "Grinding: infeed servo bandwidth; lower lags more, 0 none")
      ->capture_default_str();
  demo->add_option("--feed-forward", m.velocity_feed_forward, "Grinding: infeed velocity feed-forward, 0..1")
      ->capture_default_str();
  demo->add_option("--geometric-um", m.geometric_once_um, "Grinding: once-per-turn geometric error of X")
      ->capture_default_str();
  demo->add_option("--geometric-twice-um", m.geometric_twice_um, "Grinding: twice-per-turn geometric error of X")
      ->capture_default_str();
  demo->add_option("--drift-um", m.drift_um_per_part, "Grinding: drift per part at full lift (wear, heat)")
      ->capture_default_str();
  demo->add_option("--vibration-um", m.vibration_rms_um, "Grinding: random vibration, RMS on the ground lift")
      ->capture_default_str();
  demo->add_option("--machine-seed", m.seed, "Grinding: seed of the vibration")->capture_default_str();
  demo->add_flag(
      "--speed-program", loop->speed_program,
      "The variable-speed camshaft paper's comparison: the loop (--iterations, 1 if not given) at one grinding-point "
      "speed all round, then with the rise and return slowed; prints cycle time, flank Ra and form error of both "
      "(docs/variable_speed.md)");
  demo->add_option("--grinding-point-speed-mm-per-min", loop->grinding_point_speed_mm_per_min,
                   "Speed program: grinding-point speed all round, and on base circle and nose [the part file's "
                   "[speed] with hold = \"flanks\", else 8000]")
      ->check(CLI::Range(1.0, 1e5));
  demo->add_option("--flank-speed-mm-per-min", loop->flank_speed_mm_per_min,
                   "Speed program: grinding-point speed on the rise and return [the part file's, else 2000]")
      ->check(CLI::Range(1.0, 1e5));
  demo->add_option("--base-speed-rpm", loop->base_speed_rpm,
                   "Speed program: the most the work spindle turns [the part file's [speed], else 120]")
      ->check(CLI::Range(1.0, 1000.0));
  demo->callback([&action, demo_opts, demo_sim, loop] {
    if (loop->speed_program && loop->iterations == 0) loop->iterations = 1;
    if (loop->iterations > 0) {
      action = [demo_opts, demo_sim, loop] { return cmd_demo_loop(*demo_opts, *demo_sim, *loop); };
      return;
    }
    action = [demo_opts, demo_sim, loop] { return cmd_demo(*demo_opts, *demo_sim, *loop); };
  });
}

void add_sim_command(CLI::App& app, CommandAction& action) {
  auto sim_settings = std::make_shared<SimulatorSettings>();
  auto sim_part = std::make_shared<std::string>();
  CLI::App* sim = app.add_subcommand(
      "sim", "Run the gauge simulator alone as a Modbus TCP server, so any Modbus tool can read it. Stops on Ctrl-C.");
  sim->add_option("--host", sim_settings->host, "Address to listen on")->capture_default_str();
  sim_settings->port = 1502;
  sim->add_option("--port", sim_settings->port, "TCP port; 0 picks a free one")->capture_default_str();
  sim->add_option("--rtu", sim_settings->rtu_device,
                  "Serve Modbus RTU on this serial device instead of TCP (e.g. one end of a socat pty pair)");
  sim->add_option("--baud", sim_settings->rtu_baud, "RTU baud rate; replies keep to its line time")
      ->capture_default_str();
  sim->add_option("--unit-id", sim_settings->unit_id, "RTU unit id the simulator answers to")->capture_default_str();
  sim->add_option("--part", *sim_part, "Part file to simulate [built-in intake_flat]");
  add_simulator_options(*sim, *sim_settings, "[from the clock: real gauge noise does not repeat]");
  sim->add_option("--time-scale", sim_settings->time_scale, "Simulated seconds per real second")->capture_default_str();
  auto fault_specs = std::make_shared<std::vector<std::string>>();
  sim->add_option("--fault", *fault_specs,
                  "Fault KIND@START[+DURATION][:PARAM], START and DURATION in revolutions after the first request; "
                  "repeatable. Kinds: refuse, drop, silent, exception, late, frozen, over-range, under-range, "
                  "probe-missing, jump, drift (docs/simulator.md)");
  auto sim_grind = std::make_shared<SimGrind>();
  sim->add_flag("--grind", sim_grind->enabled,
                "Grind each next part on the virtual grinder from the program in the NC directory whenever it "
                "changes (from the design at first), so measuring the simulator closes the loop "
                "(docs/virtual_grinder.md)");
  sim->add_option("--data-dir", sim_grind->paths.data_dir,
                  "With --grind: where the NC directory is [$GAUGELOOP_DATA_DIR, else gaugeloop-data]")
      ->capture_default_str();
  sim->add_option("--nc-dir", sim_grind->paths.nc_dir, "With --grind: the NC directory [<data-dir>/nc]");
  sim->add_option("--machine-seed", sim_grind->machine.seed, "With --grind: seed of the grinder's vibration")
      ->capture_default_str();
  sim->callback([&action, sim, sim_settings, sim_part, fault_specs, sim_grind] {
    seed_from_clock_unless_given(*sim, *sim_settings);
    for (const std::string& text : *fault_specs) {
      Result<FaultSpec> f = parse_fault_spec(text);
      if (!f) throw CLI::ValidationError("--fault", f.error().message);
      sim_settings->faults.push_back(*f);
    }
    action = [sim_settings, sim_part, sim_grind] { return cmd_sim(*sim_part, *sim_settings, *sim_grind); };
  });
}

void add_measure_command(CLI::App& app, CommandAction& action) {
  auto measure_opts = std::make_shared<MeasureOptions>();
  auto gauge_address = std::make_shared<std::string>();
  CLI::App* measure = app.add_subcommand(
      "measure",
      "Measure one run against a gauge amplifier at HOST:PORT, store it and write the corrected curve table.");
  measure->add_option("--gauge", *gauge_address,
                      "Gauge amplifier, HOST:PORT (Modbus TCP): a name, an IPv4 address or [IPv6]:PORT; overrides "
                      "the config's [link]");
  measure->add_option("--gauge-config", measure_opts->gauge_config,
                      "Gauge config (TOML): link and register map, see docs/gauge.md [the simulator's map]");
  measure->add_option("--part", measure_opts->part_path, "Part file (TOML), see examples/");
  add_measure_options(*measure, *measure_opts);
  measure
      ->add_option("--ground-with", measure_opts->ground_with,
                   "Table version of the NC program that ground the measured part (0: the design). Without it "
                   "the table in force is assumed, and a part that does not show it is not corrected from "
                   "(docs/nc_output.md)")
      ->check(CLI::Range(0, 65534));
  measure->add_flag("--inspect", measure_opts->inspect,
                    "Measure, analyse and store only: the correction in force and the NC program are untouched");
  measure->add_option("--serial", measure_opts->serial,
                      "Serial number of the measured part, stored with the run (free text, at most 64 characters; "
                      "`runs list --serial` finds it)");
  measure->add_option("--operator", measure_opts->operator_name,
                      "Who measures, stored with the run (free text, at most 64 characters)");
  measure->add_option("--gauge-id", measure_opts->gauge_id,
                      "The gauge's inventory number, printed on the run's report (at most 40 characters)");
  measure->add_option("--gauge-calibrated", measure_opts->gauge_calibration_date,
                      "The day of the gauge's last calibration, YYYY-MM-DD, printed on the run's report");
  measure->add_option("--part-temperature-c", measure_opts->part_temperature_c,
                      "The part's temperature at measurement, deg C (-40.0 to 150.0, kept to 0.1), stored with the "
                      "run and printed on its report as given by the operator");
  auto as_service = std::make_shared<ServiceMeasureOptions>();
  CLI::Option* config = measure->add_option(
      "--config", as_service->config_path,
      "The service's config (TOML, docs/service.md): measure as `gaugeloop serve` does, with its gauge, settings, "
      "database and NC directory; with --part-name and --lobe, and only --note, --serial, --operator, "
      "--part-temperature-c, --ground-with, --inspect");
  measure->add_option("--part-name", as_service->part_name, "With --config: the part's name")->needs(config);
  measure->add_option("--lobe", as_service->lobe, "With --config: the lobe number")->needs(config);
  measure->callback([&action, measure, measure_opts, gauge_address, as_service] {
    if (!as_service->config_path.empty()) {
      // The config sets everything else: an option beside it would be silently ignored.
      for (const CLI::Option* o : measure->get_options()) {
        const std::string name = o->get_name();
        if (o->count() == 0 || name == "--config" || name == "--part-name" || name == "--lobe" || name == "--note" ||
            name == "--serial" || name == "--operator" || name == "--part-temperature-c" || name == "--ground-with" ||
            name == "--inspect")
          continue;
        action = [name] {
          return report_error(
              make_error(ErrorCode::kInvalidInput, name + " does not go with --config: the service's config sets it; "
                                                          "change it there, or measure without --config"));
        };
        return;
      }
      action = [as_service, measure_opts] { return cmd_measure_as_service(*as_service, *measure_opts); };
      return;
    }
    if (measure_opts->part_path.empty()) {
      action = [] {
        return report_error(make_error(ErrorCode::kInvalidInput,
                                       "no part: give --part FILE (and --gauge or --gauge-config), or --config FILE "
                                       "--part-name NAME --lobe N to measure as the service does"));
      };
      return;
    }
    action = [measure_opts, gauge_address] { return cmd_measure(*measure_opts, *gauge_address); };
  });
}

}  // namespace

void add_import_unstored_command(CLI::App& db, CommandAction& action) {
  auto o = std::make_shared<ImportUnstoredOptions>();
  CLI::App* cmd = db.add_subcommand(
      "import-unstored",
      "Store the runs the database refused, from the measurements kept in <data-dir>/unstored-runs/: analysed and "
      "judged with the part as measured, stored as inspections (the correction in force and the NC program "
      "untouched); each file stored is moved to unstored-runs/imported/.");
  cmd->add_option("files", o->files, "Kept measurements, e.g. gaugeloop-data/unstored-runs/*.json")
      ->required()
      ->check(CLI::ExistingFile);
  CLI::Option* part = cmd->add_option("--part", o->by_hand.part_path, "The part file the runs were measured with");
  add_program_options(*cmd, o->by_hand);
  cmd->add_option("--config", o->config_path,
                  "The service's config (TOML): its parts (by the files' part and lobe), database and NC directory")
      ->excludes(part);
  cmd->callback([&action, o] { action = [o] { return cmd_import_unstored(*o); }; });
}

void add_measure_commands(CLI::App& app, CommandAction& action) {
  add_demo_command(app, action);
  add_sim_command(app, action);
  add_measure_command(app, action);
}

}  // namespace gaugeloop
