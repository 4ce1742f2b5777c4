// One measurement run, end to end: acquire -> analyse -> correct -> store -> push the table.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "acquisition/gauge_client.h"
#include "acquisition/poller.h"
#include "compensation/analysis.h"
#include "compensation/correction.h"
#include "compensation/work_speed.h"
#include "core/grinding_cycle.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "core/part_temperature.h"
#include "core/pin.h"
#include "core/result.h"
#include "core/run.h"
#include "core/tolerance.h"
#include "job/nc_files.h"
#include "job/nc_push.h"
#include "nc_out/speed_table.h"
#include "nc_out/table_guards.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"

namespace gaugeloop {

// Which curve table to write (nc_out/table_writer.h).
enum class TableKind {
  kAuto,            // the fewest blocks whose command position error keeps table_choice.bound_um
  kLinear,          // G1 at table_step_deg
  kSpline,          // CSPLINE at table_step_deg
  kAdaptiveLinear,  // G1, dense only where X bends
  kAdaptiveSpline,  // CSPLINE, dense only where X bends
  kPoly,            // POLY cubic segments at table_step_deg; asked for, never chosen by auto
};
std::string_view table_kind_name(TableKind kind);  // "auto", "linear", "spline", "adaptive-linear", ...
// Every kind's name, in the order of the enum: what --table and [nc] table take.
std::vector<std::string> table_kind_names();
// The kind named so (table_kind_name), or kAuto for a name that is none.
TableKind table_kind_named(std::string_view name);

// A step of the measuring cycle that went through, in the order they come:
//  - "acquired": the revolutions measured, how long it took, polls, reconnects;
//  - "analysed": largest and RMS lift error, phase, runout, repeatability;
//  - "compensated": the verdict (apply, hold, refuse), the largest correction, the table
//    built (blocks, command position error) or why none;
//  - "stored": the run is in the database (run_id set from here on).
// What becomes of the table (pushed, held, refused) is the job's report, and its event.
struct JobStep {
  std::string code;
  std::string message;  // one line
  std::optional<std::int64_t> run_id;
};

// The command position error a crankpin's tables are chosen to by default, um. A table's
// interpolation error lies at harmonics of its block count, above the band compensation feeds
// back, so the loop cannot remove it: on a pin it lands on the radius whole (C-X-Y) or nearly
// (C-X), beside a vibration floor of 1.3 to 1.9 um. At the lobe's 0.5 um the sample pin came
// within 1.2 times its floor in 15 of 16 runs; at 0.1 um in 16 of 16 (0.92 to 1.14), for 52 to
// 73 blocks in X and 52 in Y instead of 42 and 37 (docs/crankpins.md).
inline constexpr double kPinCommandErrorBoundUm = 0.1;

// A measurement kept in <data-dir>/unstored-runs/ because the database refused its run (the
// JSON run_measure_job writes then), as store_unstored_run takes it back.
struct UnstoredRun {
  std::string machine;
  std::string part;
  int lobe = 0;
  std::string gauge;
  std::string started_utc;
  std::string finished_utc;
  std::string note;
  std::string serial;
  std::string operator_name;
  MeasuredRun measured;  // machine degrees of C, lift in mm, as the gauge gave them
};

// Reads a kept measurement. kNotFound for no file; kInvalidInput naming the file and the key for
// one that is not such a measurement (another JSON, a value of the wrong kind, a revolution
// without 360 finite readings).
Result<UnstoredRun> read_unstored_run(const std::filesystem::path& file);

struct JobSettings {
  Part part;
  // The gauge's identity for the reports (the service's [gauge] id and calibration_date, the
  // CLI's --gauge-id and --gauge-calibrated): its inventory number and the date of its last
  // calibration, YYYY-MM-DD; empty: not given. Kept in the run's settings.
  std::string gauge_id;
  std::string gauge_calibration_date;
  LiftTable design;  // the part's design lift table, already read (unused for a pin)
  // A crankpin instead of a lobe (the part file's [pin], docs/crankpins.md); part then holds
  // the name, the pin number (lobe) and nothing else the job reads. The gauge is read through
  // the pin's kinematics (analyse_pin), judged against pin.tolerances, the correction is split
  // along the grinding normal onto X (and Y), and in C-X-Y the Y table is written beside the X
  // table as <nc_program>_Y.SPF from nc_y_template (job/pin_files.h), its CTABDEF number
  // alternating over y_table_numbers, within y_axis_limits; the main program must couple both.
  std::optional<PinGeometry> pin;
  std::string nc_y_template;
  std::string nc_y_template_name;
  TableNumbers y_table_numbers{3, 4};
  AxisLimits y_axis_limits{-60.0, 60.0, 300.0, 20000.0, 60.0, 'Y'};
  std::string nc_program;  // subprogram name: the file written is <nc_dir>/<nc_program>.SPF
  PollerSettings poller;
  AnalysisSettings analysis;
  CompensationSettings compensation;
  std::filesystem::path db_path;
  std::filesystem::path nc_dir;
  std::string nc_template;       // template text
  std::string nc_template_name;  // for messages
  // The main program's template (nc_out/main_program.h), written after each table as
  // <nc_dir>/<nc_program>_MAIN.MPF coupling the table just written; empty: no main program.
  std::string nc_main_template;
  std::string nc_main_template_name;  // for messages
  TableKind table_kind = TableKind::kAuto;
  double table_step_deg = 1.0;       // C step of a linear or spline table
  TableChoiceSettings table_choice;  // command position error bound (0.5 um), widest segment, CSPLINE allowed
  // How the table's values are written: X rounded to the control's MD10200 resolution
  // ([nc] int_incr_per_mm, 10000 by default), C to 0.001 deg.
  CurveTableFormat table_format;
  // True ([nc] archive_header): the table program starts with the punched-tape archive
  // header (%_N_<nc_program>_SPF, ;$PATH=/_N_SPF_DIR), and so does the main program beside
  // it, so the HMI loads them as they are (nc_out/table_program.h).
  bool nc_archive_header = false;
  // The lobe's work speed program (the part file's [speed]); empty: one speed. With it, every
  // table is written with a speed subprogram <nc_dir>/<nc_program>_SPEED.SPF beside it,
  // planned on the corrected wheel path (plan_work_speed, the slide's limits from
  // axis_limits) and rendered from nc_speed_template; the main program must call it
  // (docs/variable_speed.md, docs/nc_output.md "Variable work speed on the control").
  std::optional<WorkSpeedSettings> speed;
  // The part file's [grinding]: the allowance and the passes the main program feeds the wheel
  // by ({{infeed_blocks}}), at axis_limits.speed_rpm; carried in the table program's header.
  GrindingCycle cycle;
  std::string nc_speed_template;       // template text, required with `speed`
  std::string nc_speed_template_name;  // for messages
  SpeedProfileSettings speed_profile;  // the feed blocks' speed error bound and block time
  // What the infeed axis may do: software limits and the slide's velocity and acceleration
  // at the programmed work speed. Defaults fit the sample lobes at 60 rpm with margin.
  AxisLimits axis_limits{-0.5, 20.0, 300.0, 20000.0, 60.0};
  // True: a table compensation applies is kept as pending until `gaugeloop nc approve`.
  bool require_approval = false;
  // The two CTABDEF numbers the tables alternate between: table version v goes to
  // table_numbers[(v - 1) % 2] (table_number_for_version, nc_out/table_program.h). Distinct, 1..999.
  TableNumbers table_numbers{1, 2};
  // The correction as its own layer (the part file's [correction_layer], docs/nc_output.md,
  // "The correction as a layer"); 0: off, each pushed table is the whole wheel path. Otherwise
  // the design's whole table is the subprogram design_program_name(nc_program) defining this
  // CTABDEF number, written from the drawing (`nc new`) and never by a push, and every pushed
  // table is the correction alone, X from the virtual axis SIM1, written against the design
  // table as the control holds it; the main program must couple both (a lobe's only).
  int layer_design_table_number = 0;
  std::string machine = "grinder-1";
  std::string note;
  // The measured part's serial number and who measured it, stored with the run; empty: not
  // given. Free text, checked before the gauge is read (check_run_identity, storage/run_store.h).
  std::string serial;
  std::string operator_name;
  // The part's temperature at measurement and who gave it (the PLC's word 37, or a person:
  // `measure --part-temperature-c`, the HTTP API's `part_temperature_c`); empty: not given.
  // Kept in the run's settings (part.temperature_c, part.temperature_source) for its reports.
  // Checked before the gauge is read (checked_part_temperature_c).
  std::optional<PartTemperature> part_temperature;
  // True (measuring a part the machine ground): the new correction builds on the correction
  // of the table that ground the part (ground_with), by default the table in force, that of
  // the last run of this machine, part and lobe whose table was pushed.
  // False: correct from the design, as the demo does: its simulator does not grind with
  // the pushed table, so its parts never carry an earlier correction.
  bool build_on_table_in_force = true;
  // Which table version of the NC file ground the measured part, when someone knows: the PLC
  // (source "plc") or the person measuring (`measure --ground-with`, source "option"); 0 is
  // the design (no table). Empty: the table in force is assumed, and the part's own lift
  // error is asked whether it shows that table (docs/nc_output.md, "The part knows its
  // table"). A version never pushed is refused before the gauge is read.
  std::optional<int> ground_with_version;
  std::string ground_with_source = "option";
  // Measure, analyse and store only: the correction in force and the NC program are untouched
  // (`measure --inspect`).
  bool inspect = false;
  // The measurement taken from a kept file instead of the gauge (store_unstored_run): its
  // revolutions, times, gauge, serial, operator and note; null: read the gauge.
  const UnstoredRun* replay = nullptr;
  // Read the whole database (PRAGMA quick_check) before measuring, refusing a damaged one.
  // The service checks once at start (integrity_check) and sets this false: the quick check
  // reads every page, a second or more on a database of years.
  bool check_integrity = true;
  // The NC directory the push writes (empty: the real one); a test's fake fails on demand.
  std::shared_ptr<NcFiles> nc_files;
  // Called as each step of the cycle goes through (JobStep), for a caller that logs and
  // records every step (the service). Failures are not steps: they are the job's error.
  // "stored" comes before the table is pushed: a caller that must name the run even when the
  // push then fails (the PLC's result words) learns its id there.
  std::function<void(const JobStep& step)> on_step;
};

// A stored run and what became of its table.
//  - Pushed: nc_file and table_version are set.
//  - Not pushed: not_pushed_reason says why. verdict kRefuse: compensation or the geometry
//    refused the correction. kHold: compensation held it. kApply: approval is required, or
//    the table on the control was edited by hand. The table is kept as pending_id (when one
//    could be built) for `gaugeloop nc approve`; the reason is also a refusal event naming
//    the run. The table in force stays.
struct JobReport {
  std::int64_t run_id = 0;
  MeasuredRun measured;
  LobeAnalysis analysis;
  // The run against its lobe's tolerances (judge_lobe), as stored.
  std::vector<Characteristic> characteristics;
  Verdict tolerance_verdict = Verdict::kNotJudged;
  std::optional<std::int64_t> correction_in_force_run;  // whose correction was built on
  // The table that ground the part: its version (empty: the design), who said so ("plc",
  // "option", "assumed") and, when assumed, what the part's error said about it.
  std::optional<int> ground_with_version;
  std::string ground_with_source;
  std::string ground_with_evidence;
  bool inspection = false;
  CompensationVerdict verdict = CompensationVerdict::kApply;
  double correction_max_um = 0.0;  // largest |correction| proposed
  int harmonics_fed_back = 0;      // the smoothing band 0..N of the correction (CompensationDecision::harmonics)
  // The table built (empty interpolation: none, the correction was refused).
  std::string interpolation;  // "linear" or "cspline"
  std::string table_writer;   // how its points were chosen, e.g. "adaptive cspline"
  int table_blocks = 0;
  double command_error_um = 0.0;  // largest |NC interpolation - exact X|
  // A C-X-Y pin's Y table, as the X table's figures above; 0 without.
  int y_table_blocks = 0;
  double y_command_error_um = 0.0;
  // With a speed program (JobSettings::speed): one turn under it and at the base speed, s, and
  // its feed blocks as written; 0 without.
  double speed_cycle_time_s = 0.0;
  double constant_cycle_time_s = 0.0;
  int speed_blocks = 0;
  double speed_error_percent = 0.0;
  std::filesystem::path nc_file;  // empty when not pushed
  int table_version = 0;          // 0 when not pushed
  std::string not_pushed_reason;  // empty when pushed
  std::optional<std::int64_t> pending_id;
  std::filesystem::path db_path;
  // Noticed before the gauge was read: commits the database lost (lost_commits_text); empty
  // when none. The run is stored all the same, with an id none of them had.
  std::string history_warning;

  bool pushed() const { return !nc_file.empty(); }
};

// Runs the job. Everything that can be checked without the gauge is checked before the first
// poll, so bad input costs no measurement: the geometry, the template, the names (part and
// program: 1 to 64 letters, digits, '_' or '-'), the serial and operator (check_run_identity),
// the NC directory (writable: a probe file is made and removed), the database (sound,
// writable, not locked), room on both file systems for a run and a program, and the table
// version the part was ground with. Interrupted pushes of the NC file are reconciled first
// (reconcile_pushes). Nothing is stored unless a complete run was
// measured and analysed; the NC file is pushed (push_program) after the run is stored. A
// correction that compensation holds or refuses (decide_correction), that the geometry
// refuses, or that would be built on a table that did not grind the part, is not an error:
// the run is stored and the report says why nothing was pushed.
// A run measured but not stored (the database failed) is written as JSON in
// <data-dir>/unstored-runs/ and the error names the file (store_unstored_run takes it back).
// Errors keep the code of the step that failed; their messages name the step.
Result<JobReport> run_measure_job(GaugeClient& gauge, const JobSettings& settings);

// Stores a kept measurement (read_unstored_run) as the run it would have been, as an inspection:
// analysed and judged with `settings` (the part's, as measured), the correction in force and the
// NC program untouched (a table built now from a part measured then could be stale). The
// gauge is not read. kInvalidInput when the file's part, lobe or machine is not the settings'.
Result<JobReport> store_unstored_run(const UnstoredRun& kept, JobSettings settings);

// The checks run_measure_job makes before the first poll that need neither the database nor
// the NC directory: for a service validating its configuration before it takes it into use.
Status check_job_settings(const JobSettings& settings);

// The main program's template of `settings`, for an approval or a rollback (the part and lobe
// left to the run's): empty when the settings have none.
MainProgramSource main_program_source(const JobSettings& settings);

// The NC directory exists (made if need be) and takes a file, and has room for a program: a
// probe named like our temporary files (so a leftover is cleaned up with them) is made and
// removed. kIo naming the directory (or `nc_file`, if something other than a file is there).
Status check_nc_directory(const std::filesystem::path& nc_dir, const std::filesystem::path& nc_file);

// Everything a push needs of the database and the NC directory, before the gauge is read or
// anything is written: the NC directory takes a file (check_nc_directory), the database's
// directory has room for a run, the database opens (created and upgraded if need be), is
// sound (with check_integrity) and writable, and pushes of `nc_file` interrupted earlier are
// reconciled (a stale main program written again from the settings' template). With `found`,
// what reconciliation found: the stale main program for `nc_file`, if any (the part measured
// next was ground with the table it coupled), and commits the database lost. Errors: kIo,
// kStorage, naming the file or directory.
struct StoreFindings {
  std::optional<StaleMain> stale;
  std::optional<LostCommits> lost_commits;
};
Result<RunStore> open_store_for_push(const JobSettings& s, const std::filesystem::path& nc_file,
                                     StoreFindings* found = nullptr);

// A part, machine or program name: 1 to 64 ASCII letters, digits, '_' or '-'. kInvalidInput
// naming `what` and the offending character's position otherwise.
Status check_name(std::string_view name, std::string_view what);

}  // namespace gaugeloop
