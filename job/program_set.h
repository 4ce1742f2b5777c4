// The programs one table version puts on the control, built from a wheel path and pushed as
// one set: the table (X), in C-X-Y a crankpin's Y table, a speed subprogram when the part has
// a work speed program, and the main program coupling them. A measured run and a program
// written from the drawing (nc_new.h) build and push them alike.
//
// Frames and units as nc_out: machine frame, C in degrees (leading axis), X and Y in mm.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "compensation/periodic_spline.h"
#include "compensation/work_speed.h"
#include "core/result.h"
#include "core/run.h"
#include "job/measure_job.h"
#include "job/nc_push.h"
#include "nc_out/sampled_path.h"
#include "nc_out/speed_table.h"
#include "nc_out/table_layer.h"
#include "nc_out/table_writer.h"
#include "storage/run_store.h"

namespace gaugeloop {

// The exact wheel path the tables are chosen against and checked on: 36,000 rows.
inline constexpr double kFinePathStepDeg = 0.01;

// `e` with "<step>: " before its message.
inline Error in_step(const std::string& step, Error e) {
  e.message = step + ": " + e.message;
  return e;
}

// A speed program planned for a path, and its feed blocks as the control will run them.
struct BuiltSpeed {
  WorkSpeedPlan plan;
  WorkSpeedProgram written;  // the plan's program on the grid it is written from (0.5 deg)
  SpeedProfile profile;
};

// A table and the exact path it was chosen against, and its speed program when there is one.
struct BuiltTable {
  SampledPath fine;
  CurveTable table;
  std::optional<BuiltSpeed> speed;
  // A C-X-Y pin's Y table and the exact Y path it was chosen against.
  std::optional<SampledPath> y_fine;
  std::optional<CurveTable> y_table;
};

// The wheel path of `lift_mm` on the fine C grid (compute_machine_path: exact rows), the
// axis guards on it, the table the settings ask for (keeping `in_force`'s points when given,
// write_default_table), the guards on the table as the NC will interpolate it, and with
// JobSettings::speed the speed program planned on the same path. Refusals (a wheel that does
// not fit, a limit broken, a speed the control's block rate cannot follow) are kRefused.
// With `layer_on` (a correction layer, JobSettings::layer_design_table_number) the table is the
// layer: written on the path less the design table as the NC interpolates it (`fine` is that
// layer path), guarded as the sum the control commands (check_layered_guards).
Result<BuiltTable> build_table(const PeriodicSpline& lift_mm, const JobSettings& s,
                               const TablePointsInForce* in_force = nullptr,
                               const TableInterpolant* layer_on = nullptr);

// A correction layer's design: the design's whole table (built with the layer off), its
// program as `nc new` writes it (render_design_table) and that program read back as the
// control will hold it.
struct LayerDesign {
  BuiltTable whole;
  std::string program;
  DesignTable table;
};
Result<LayerDesign> build_layer_design(const PeriodicSpline& design_lift, const JobSettings& s,
                                       const std::string& created_utc);

// The design's whole table of a correction layer, rendered from the table template as the
// subprogram design_program_name(nc_program) defining layer_design_table_number, from C.
Result<std::string> render_design_table(const JobSettings& s, const CurveTable& design, const std::string& created_utc);

// A pin's tables for `correction_um` (pin frame): the path moved along the grinding normal and
// split onto X (and Y), the X table (keeping the points in force, as a lobe's), the Y table in
// C-X-Y, and in C-X the speed program that holds the grinding-point speed.
Result<BuiltTable> build_pin_table(const DegreeTable& correction_um, const JobSettings& s,
                                   const TablePointsInForce* in_force = nullptr);

// The placeholders every program of the part is rendered with (program_name, part, lobe,
// version, run_id 0, origin, created_utc empty, correction_max_um 0, the first table number).
std::map<std::string, std::string> template_values(const JobSettings& s);

// `program` (a rendered table program) with the archive header when the settings ask for it.
Result<std::string> with_archive_header(const JobSettings& s, Result<std::string> program);

// The table program (X) of `built` for a table version (0: not yet known), from the settings'
// template, with the archive header when asked. run_id 0: written from the drawing.
Result<std::string> render_x_table(const JobSettings& s, const BuiltTable& built, std::int64_t run_id,
                                   const std::string& created_utc, double correction_max_um, int table_version);

// The Y table program of a C-X-Y pin for a table version, from the settings' Y template. Y
// keeps the design's path (docs/crankpins.md): its correction_max_um is 0.
Result<std::string> render_y_table(const JobSettings& s, const CurveTable& y_table, std::int64_t run_id,
                                   const std::string& created_utc, int table_version);

// The speed subprogram for `speed`, from the settings' template, for run `run_id` and the
// table version it goes to the control with.
Result<std::string> render_speed(const JobSettings& s, const BuiltSpeed& speed, std::int64_t run_id,
                                 const std::string& created_utc, int table_version = 0);

// The main program's template and the part it grinds, for push_program.
MainProgramSource main_source(const JobSettings& s, const std::string& created_utc);

// Pushes the set of `built` as one table version: a C-X-Y pin's Y table first
// (push_pin_programs), the speed subprogram before the table (push_program_with_speed), then
// the table and the main program (push_program). Errors as those.
Result<PushCompletion> push_program_set(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                                        const BuiltTable& built, const JobSettings& s, const std::string& created_utc,
                                        double correction_max_um, PushOptions options);

}  // namespace gaugeloop
