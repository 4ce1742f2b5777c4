// The options shared by demo, measure and nc new, and the job settings they make.
#include "cli/measure_options.h"

#include <chrono>
#include <utility>

#include "cli/embedded_defaults.h"
#include "cli/pin_loop.h"
#include "core/text_file.h"
#include "core/utc_time.h"

namespace gaugeloop {
namespace {

Result<std::string> load_template(const std::string& path, std::string& name) {
  if (path.empty()) {
    name = "embedded:cam_table.spf";
    return std::string(embedded::kNcTemplate);
  }
  Result<std::string> text = read_regular_file(path, "NC template");
  if (!text) {
    Error e = text.error();
    e.message += " (--template)";
    return e;
  }
  name = path;
  return std::string(without_utf8_bom(*text));
}

}  // namespace

Status check_identity_options(const MeasureOptions& o) {
  if (Status s = check_run_identity("--serial", o.serial); !s) return s;
  if (Status s = check_run_identity("--operator", o.operator_name); !s) return s;
  if (Status s = check_run_identity("--gauge-id", o.gauge_id); !s) return s;
  if (o.gauge_id.size() > 40) {
    return make_error(ErrorCode::kInvalidInput, "--gauge-id: at most 40 characters, the gauge's inventory number");
  }
  if (!o.gauge_calibration_date.empty() && !is_past_calendar_date(o.gauge_calibration_date)) {
    return make_error(ErrorCode::kInvalidInput, "--gauge-calibrated " + o.gauge_calibration_date +
                                                    ": not a past day as YYYY-MM-DD; give the date on the gauge's "
                                                    "calibration certificate");
  }
  if (Result<std::optional<PartTemperature>> t = part_temperature_option(o); !t) return t.error();
  return {};
}

Result<std::optional<PartTemperature>> part_temperature_option(const MeasureOptions& o) {
  if (!o.part_temperature_c) return std::optional<PartTemperature>();
  Result<double> c = checked_part_temperature_c(*o.part_temperature_c, "--part-temperature-c");
  if (!c) return c.error();
  return std::optional<PartTemperature>(PartTemperature{*c, PartTemperatureSource::kOperator});
}

void add_program_options(CLI::App& cmd, MeasureOptions& o) {
  add_data_dir_option(cmd, o.paths);
  cmd.add_option("--nc-dir", o.paths.nc_dir, "Directory the curve-table program is written to [<data-dir>/nc]");
  cmd.add_option("--template", o.template_path, "NC template with {{placeholders}} [built-in Sinumerik 840D table]");
  cmd.add_option("--main-template", o.main_template_path,
                 "Main program template, written beside the table as <program>_MAIN.MPF coupling it "
                 "[built-in Sinumerik 840D main program]");
  cmd.add_option(
         "--table", o.table,
         "Curve table: auto (fewest blocks within --command-error-um; the next keeps the points of the table in "
         "force), linear, spline or poly (at --table-step-deg; poly is never chosen by auto), adaptive-linear, "
         "adaptive-spline; see docs/nc_output.md")
      ->check(CLI::IsMember(table_kind_names()))
      ->capture_default_str();
  cmd.add_option("--table-step-deg", o.table_step_deg, "C step of a linear, spline or poly table, degrees")
      ->capture_default_str();
  cmd.add_option("--command-error-um", o.command_error_um,
                 "Largest command position error (NC interpolation against the exact path) auto and adaptive "
                 "tables may have [0.5 for a lobe, 0.1 for a crankpin]")
      ->check(CLI::Range(0.01, 100.0));
  cmd.add_option("--int-incr-per-mm", o.int_incr_per_mm,
                 "The control's X resolution, MD10200 $MN_INT_INCR_PER_MM: table X is rounded to 1/N mm and its "
                 "command error includes the rounding (docs/nc_output.md)")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  cmd.add_flag("--archive-header", o.archive_header,
               "Start the table and main program with the archive header (%_N_<name>_SPF, ;$PATH=...) so the "
               "HMI loads them as they are");
  cmd.add_option("--machine", o.machine, "Machine name stored with the run")->capture_default_str();
}

void add_measure_options(CLI::App& cmd, MeasureOptions& o) {
  add_program_options(cmd, o);
  cmd.add_option("--revolutions", o.revolutions, "Complete revolutions to average (at least 3)")
      ->capture_default_str()
      ->check(CLI::Range(3, 100));
  cmd.add_flag("--require-approval", o.require_approval,
               "Keep each new table as pending until `gaugeloop nc approve ID` writes it");
  cmd.add_option("--note", o.note, "Operator note stored with the run");
  cmd.add_option("--response-timeout-ms", o.response_timeout_ms, "Gauge response timeout")
      ->capture_default_str()
      ->check(CLI::Range(10, 10000));
  cmd.add_option("--run-timeout-s", o.run_timeout_s,
                 "Longest a run may take; 0: (revolutions + 3 spare + 2) revolutions at the spindle speed seen, "
                 "at least 10 s")
      ->capture_default_str()
      ->check(CLI::Range(0, 86400));
  cmd.add_option("--mode", o.mode,
                 "latched: drain the amplifier's per-degree latch buffer; live: poll the reading and interpolate "
                 "(amplifiers without a latch input, slow spindles)")
      ->check(CLI::IsMember({"latched", "live"}))
      ->capture_default_str();
}

void set_speed_program(JobSettings& js, std::optional<WorkSpeedSettings> speed, const MeasureOptions& o) {
  js.speed = std::move(speed);
  js.nc_speed_template = js.speed ? std::string(embedded::kNcSpeedTemplate) : std::string();
  js.nc_speed_template_name = js.speed ? "embedded:cam_speed.spf" : "";
  if (o.main_template_path.empty() && js.layer_design_table_number != 0) {
    js.nc_main_template = std::string(embedded::kNcMainLayerTemplate);
    js.nc_main_template_name = "embedded:cam_main_layer.mpf";
  } else if (o.main_template_path.empty()) {
    js.nc_main_template = std::string(js.speed ? embedded::kNcMainSpeedTemplate : embedded::kNcMainTemplate);
    js.nc_main_template_name = js.speed ? "embedded:cam_main_speed.mpf" : "embedded:cam_main.mpf";
  }
}

Result<JobSettings> job_settings_for(const LoadedPart& lp, const MeasureOptions& o, bool build_on_table_in_force) {
  if (Status ids = check_identity_options(o); !ids) return ids.error();
  std::string template_name;
  Result<std::string> tmpl = load_template(o.template_path, template_name);
  if (!tmpl) return tmpl.error();
  JobSettings js;
  js.part = lp.file.part;
  js.design = lp.design;
  js.nc_program = lp.file.nc_program;
  js.poller.revolutions = o.revolutions;
  js.poller.mode = o.mode == "live" ? SamplingMode::kLive : SamplingMode::kLatched;
  js.poller.run_timeout = std::chrono::seconds(o.run_timeout_s);
  js.db_path = o.paths.db();
  js.nc_dir = o.paths.nc();
  js.nc_template = std::move(*tmpl);
  js.nc_template_name = template_name;
  Result<std::string> main_tmpl = load_main_template(o.main_template_path, js.nc_main_template_name);
  if (!main_tmpl) return main_tmpl.error();
  js.nc_main_template = std::move(*main_tmpl);
  js.layer_design_table_number = lp.file.layer_design_table_number;
  set_speed_program(js, lp.file.speed, o);
  js.cycle = lp.file.grinding;
  if (lp.file.pin) set_pin_job(js, *lp.file.pin, /*main_template_given=*/!o.main_template_path.empty());
  js.table_step_deg = o.table_step_deg;
  js.table_kind = table_kind_named(o.table);
  // Without the option: TableChoiceSettings' 0.5 um for a lobe, set_pin_job's for a pin.
  js.table_choice.bound_um = o.command_error_um.value_or(js.table_choice.bound_um);
  js.table_format.x_increments_per_mm = o.int_incr_per_mm;
  js.nc_archive_header = o.archive_header;
  js.require_approval = o.require_approval;
  js.machine = o.machine;
  js.note = o.note;
  js.serial = o.serial;
  js.operator_name = o.operator_name;
  js.gauge_id = o.gauge_id;
  js.gauge_calibration_date = o.gauge_calibration_date;
  Result<std::optional<PartTemperature>> temperature = part_temperature_option(o);
  if (!temperature) return temperature.error();
  js.part_temperature = *temperature;
  js.build_on_table_in_force = build_on_table_in_force;
  js.ground_with_version = o.ground_with;
  js.ground_with_source = "option";
  js.inspect = o.inspect;
  return js;
}

}  // namespace gaugeloop
