// One measurement run, end to end: acquire -> analyse -> correct -> store -> push the table.
#pragma once

#include <filesystem>
#include <optional>
#include <string>

#include "acquisition/gauge_client.h"
#include "acquisition/poller.h"
#include "compensation/analysis.h"
#include "compensation/correction.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

struct JobSettings {
  Part part;
  LiftTable design;        // the part's design lift table, already read
  std::string nc_program;  // subprogram name: the file written is <nc_dir>/<nc_program>.SPF
  PollerSettings poller;
  AnalysisSettings analysis;
  CompensationSettings compensation;
  std::filesystem::path db_path;
  std::filesystem::path nc_dir;
  std::string nc_template;       // template text
  std::string nc_template_name;  // for messages
  double table_step_deg = 1.0;   // C step of the curve table
  int table_number = 1;          // CTABDEF table number
  std::string machine = "grinder-1";
  std::string note;
  // True (measuring a part the machine ground): the new correction builds on the one in
  // force, that of the last run of this machine, part and lobe whose table was pushed.
  // False: correct from the design, as the demo does: its simulator does not grind with
  // the pushed table, so its parts never carry an earlier correction.
  bool build_on_table_in_force = true;
};

// A stored run. verdict kApply: its table was pushed (nc_file, table_points). kHold or
// kRefuse: the run and its proposed correction are stored, nothing was pushed, the table in
// force stays; verdict_reasons says why (also recorded as a refusal event naming the run).
struct JobReport {
  std::int64_t run_id = 0;
  MeasuredRun measured;
  LobeAnalysis analysis;
  std::optional<std::int64_t> correction_in_force_run;  // whose correction was built on
  CompensationVerdict verdict = CompensationVerdict::kApply;
  std::string verdict_reasons;     // empty when applied
  double correction_max_um = 0.0;  // largest |correction| proposed (applied when kApply)
  int table_points = 0;            // 0 when not pushed
  std::filesystem::path nc_file;   // empty when not pushed
  std::filesystem::path db_path;
};

// Runs the job. Everything that can be checked without the gauge (geometry, template,
// database, output directory) is checked before the first poll, so bad input costs no
// measurement. Nothing is stored unless a complete run was measured and analysed; the NC
// file is written atomically after the run is stored, and only then marked as pushed. A
// correction that compensation holds or refuses (decide_correction), or that the geometry
// refuses, is not an error: the run is stored and the report says why nothing was pushed.
// Errors keep the code of the step that failed; their messages name the step.
Result<JobReport> run_measure_job(GaugeClient& gauge, const JobSettings& settings);

}  // namespace gaugeloop
