// The options shared by `demo`, `measure` and `nc new`: where the files go, the templates,
// the table choice and the control's resolution; and the job settings they make for a part.
#pragma once

#include <CLI/CLI.hpp>
#include <optional>
#include <string>

#include "cli/cli_common.h"
#include "compensation/work_speed.h"
#include "core/result.h"
#include "job/measure_job.h"

namespace gaugeloop {

struct MeasureOptions {
  DataPaths paths;
  std::string part_path;
  std::string template_path;
  std::string main_template_path;
  int revolutions = 3;
  double table_step_deg = 1.0;
  std::string table = "auto";
  std::optional<double> command_error_um;  // empty: 0.5 um for a lobe, kPinCommandErrorBoundUm for a pin
  int int_incr_per_mm = 10000;             // the control's MD10200: X is written on its grid
  bool archive_header = false;             // the programs start with the punched-tape archive header
  bool require_approval = false;
  std::string machine = "grinder-1";
  std::string note;
  int response_timeout_ms = 200;
  int run_timeout_s = 0;                     // 0: from the spindle speed (poller.h, run_timeout_at)
  std::string mode = "latched";              // latched | live
  std::string gauge_config;                  // measure only
  std::optional<int> ground_with;            // measure only: the table version that ground the part
  bool inspect = false;                      // measure only
  std::string serial;                        // measure only: the part's serial number
  std::string operator_name;                 // measure only: who measures
  std::string gauge_id;                      // measure only: the gauge's inventory number
  std::string gauge_calibration_date;        // measure only: YYYY-MM-DD
  std::optional<double> part_temperature_c;  // measure only: the part's temperature, deg C
};

// --serial, --operator, --gauge-id, --gauge-calibrated and --part-temperature-c, checked
// before anything is read, naming the option at fault.
Status check_identity_options(const MeasureOptions& o);

// --part-temperature-c as the run keeps it (rounded to 0.1 deg C, given by the operator);
// empty when not given. kInvalidInput naming the option for a value not finite or out of range.
Result<std::optional<PartTemperature>> part_temperature_option(const MeasureOptions& o);

// The options of what is written to the control: --data-dir, --nc-dir, --template,
// --main-template, --table, --table-step-deg, --command-error-um, --int-incr-per-mm,
// --archive-header, --machine (demo, measure, nc new).
void add_program_options(CLI::App& cmd, MeasureOptions& o);

// add_program_options and the options of a measurement: --revolutions, --require-approval,
// --note, --response-timeout-ms, --run-timeout-s, --mode (demo, measure).
void add_measure_options(CLI::App& cmd, MeasureOptions& o);

// `gaugeloop nc new` under `nc` (cli/commands_new.cc).
void add_nc_new_command(CLI::App& nc, CommandAction& action);

// The job's speed program (empty: one speed) and the templates that go with it, the embedded
// ones unless --main-template names the main program's: with a speed program the main program
// must call the speed subprogram (examples/sinumerik/cam_main_speed.mpf).
void set_speed_program(JobSettings& js, std::optional<WorkSpeedSettings> speed, const MeasureOptions& o);

// The job settings of the options, for `lp`: with the part file's [speed], its speed program.
Result<JobSettings> job_settings_for(const LoadedPart& lp, const MeasureOptions& o, bool build_on_table_in_force);

}  // namespace gaugeloop
