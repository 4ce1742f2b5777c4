// A gear's stroke program written from the axes' errors along the stroke: the SIM1 position at
// every spline point (compensation/gear_coupling.h), the program text (nc_out/stroke_program.h)
// pushed into the NC directory through the push journal as the cam tables are (version, hand-edit
// check, main program, history, rollback), or written to a file alone; read back either way.
// docs/gears.md.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "compensation/gear_coupling.h"
#include "compensation/gear_lead.h"
#include "core/result.h"
#include "job/nc_push.h"
#include "nc_out/stroke_program.h"

namespace gaugeloop {

struct GearStrokeSettings {
  std::string part_name;
  std::string program_name;        // the part file's nc_program; the file's header names it
  double feed_mm_per_min = 300.0;  // the stroke's feed along Z
  StrokeProgramFormat format;
  // Where the program goes. With a store: pushed to nc_file (push_program, job/nc_push.h) with
  // the main program `main` beside it (its gear_template_text; empty: none), a hand-edited
  // program overwritten only with overwrite_edited. Without: written to out_file alone, no
  // history and no main program.
  RunStore* store = nullptr;
  std::filesystem::path nc_file;
  MainProgramSource main;
  bool overwrite_edited = false;
  std::filesystem::path out_file;
  // With a store: keep the program as a pending table waiting for a person's approval (`nc
  // approve`, which pushes it as the next version) instead of pushing it; gear_run_id names the
  // gear run it was corrected from (required then: a pending table names where it comes from).
  bool require_approval = false;
  std::int64_t gear_run_id = 0;
};

struct GearStrokeReport {
  GearCoupling coupling;
  std::vector<StrokeSimPoint> points;
  std::string coupling_lines;  // EGDEF and EGON for the main program
  double sim_max_abs_deg = 0.0;
  std::filesystem::path written;  // the stroke program's file; empty when it waits for approval
  int version = 0;                // the stroke version pushed; 0: written to a file, not pushed, or pending
  std::int64_t pending_id = 0;    // the pending table waiting for approval (require_approval); 0: none
};

// The points and the program, pushed (settings.store), kept for approval
// (settings.require_approval) or written atomically to settings.out_file, then read back (the
// pending table's text when it waits): it must parse, match its checksum and hold every point as
// written (on the control's grid). Errors: validate's and stroke_sim_points' kInvalidInput; push_program's (a
// hand-edited program kRefused, a main template without the gearbox kInvalidInput, both before
// anything is written); kIo for a file that cannot be written or does not read back as written.
Result<GearStrokeReport> write_gear_stroke(const GearPart& part, const StrokeAxisErrors& errors,
                                           const GearStrokeSettings& settings);

// write_gear_stroke for SIM1 positions already known at the spline points (a stroke corrected
// from a measured gear): `source` says where they come from (the program's header, the push's
// reason). kInvalidInput for fewer than 2 points.
Result<GearStrokeReport> push_gear_stroke(const GearPart& part, std::vector<StrokeSimPoint> points,
                                          const std::string& source, const GearStrokeSettings& settings);

// The stroke in force: the version last pushed to a file, SIM1 at its spline points as the
// control holds them.
struct StrokeInForce {
  int version = 0;
  std::vector<StrokeSimPoint> points;  // z_mm and sim_deg; no axis errors
};

// kNotFound naming `nc_file` when no stroke program was pushed there (`advice` says what to do);
// kStorage for the database's errors.
Result<StrokeInForce> stroke_in_force(const RunStore& store, const std::filesystem::path& nc_file,
                                      const std::string& advice);

// A stroke corrected from a measured gear.
struct GearCorrection {
  int from_version = 0;  // the stroke in force that ground the gear
  MeshIdentification identification;
  GearStrokeReport pushed;
};

// The stroke in force (the version last pushed to settings.nc_file, its SIM1 as the control
// holds it) less the mesh error identify_mesh_error finds in `traces` at its spline points,
// pushed as the next version with `source` as its origin (or kept for approval, as
// settings.require_approval says). kInvalidInput without a store;
// kNotFound when no stroke was pushed to the file (push one with write_gear_stroke first);
// identify_mesh_error's and push_gear_stroke's errors. Nothing is written on an error.
Result<GearCorrection> correct_gear_stroke(const GearPart& part, const std::vector<LeadTrace>& traces,
                                           const std::string& source, const GearStrokeSettings& settings);

}  // namespace gaugeloop
