// The first program of a part, written from its drawing before any part was measured: the
// table(s), the speed subprogram and the main program exactly as a push writes them, as
// version 1 of the program, recorded with no run behind it (docs/nc_output.md, "The first
// program"). The first measured run then builds on it, as on any table in force.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"
#include "job/layer_files.h"
#include "job/measure_job.h"
#include "job/program_set.h"
#include "nc_out/infeed.h"
#include "nc_out/table_writer.h"
#include "report/program_preview.h"

namespace gaugeloop {

// What a new program is, before anything is written: the design's tables, the choices the
// default table weighed, and the passes of the main program.
// The profile at one whole degree of C (machine frame), as the preview shows it.
struct PreviewRow {
  int c_deg = 0;
  double x_mm = 0.0;  // the exact wheel path and its C-derivatives
  double dx_mm_per_deg = 0.0;
  double d2x_mm_per_deg2 = 0.0;
  std::optional<double> y_mm;  // a C-X-Y pin's wheel height
  double c_speed_rpm = 0.0;    // the work spindle: the speed program's, or the constant speed
  double grinding_point_speed_mm_per_min = 0.0;
  double x_nc_mm = 0.0;           // what the control interpolates from the table at C
  double command_error_um = 0.0;  // the largest |NC - exact X| in [C, C + 1)
  std::optional<double> y_command_error_um;
};

struct ProgramPreview {
  std::vector<PreviewRow> rows;  // C = 0 .. 359
  BuiltTable built;              // the table chosen (X), a C-X-Y pin's Y table, the speed program
  // The candidates of the default choice for X (and for Y in C-X-Y): why this table. Empty
  // when the settings ask for one kind of table (--table other than auto).
  std::vector<TableCandidate> x_candidates;
  std::vector<TableCandidate> y_candidates;
  InfeedPlan infeed;
  double work_speed_rpm = 0.0;  // the constant speed, without a speed program
  // One turn: under the speed program, or at work_speed_rpm; and the whole cycle's passes.
  double turn_time_s = 0.0;
  double cycle_time_s = 0.0;
};

// The checks of a measurement that need no gauge (names, the design, the axis limits, every
// template renders; check_job_settings), then the design's tables and speed program, the
// candidates weighed and the passes. Nothing is written. Errors: as check_job_settings, and
// kRefused when no table keeps the command error bound or a guard refuses the design.
Result<ProgramPreview> preview_new_program(const JobSettings& s);

// The preview as CSV (RFC 4180, header first): one row per whole degree of C with X, X', X'',
// (Y), the speeds, what the NC interpolates and the command error.
std::string preview_csv(const ProgramPreview& p);

// The preview's page (report/program_preview.h) with its title, the table chosen in the
// subtitle and the control's resolution in the footer.
ProgramPreviewPage preview_page(const ProgramPreview& p, const JobSettings& s);

struct NewProgramOptions {
  // A program with a push history, or a file there that gaugeloop did not write, is refused
  // unless this is set; the history is kept and the new program is its next version.
  bool replace = false;
  std::string by;         // who writes it, for the history ("new program from intake.toml by anna")
  std::string from_file;  // the part file, for the history
};

struct NewProgramReport {
  ProgramPreview preview;
  std::filesystem::path nc_file;
  // A correction layer's design table (JobSettings::layer_design_table_number): written from
  // the drawing when it is not there or `replace`, left as it is when it holds this drawing's
  // table; nc_file is then the layer. Empty without a layer.
  std::filesystem::path design_file;
  int table_version = 0;
  // Every file written, read back from the NC directory after the push: the table, a pin's Y
  // table, the speed subprogram, the main program.
  std::vector<std::filesystem::path> files;
};

// Writes the first program set of the part in `s` to s.nc_dir through the push (journal,
// atomic writes, alternating table numbers, version history), as run 0 (none), then reads every
// file back: the table programs must parse, match their checksums and hold the points written,
// the speed program must parse and verify, the main program must couple the table just written.
// Refusals (kRefused): a program with a history, or a file there gaugeloop did not write,
// without `replace` (naming the file, its last version and what to do). Errors: as
// preview_new_program, the push's (kStorage, kIo), and kIo for a file that does not read back.
Result<NewProgramReport> write_new_program(const JobSettings& s, const NewProgramOptions& options);

}  // namespace gaugeloop
