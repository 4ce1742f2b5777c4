// The programs of one table version: built from a path, rendered, pushed as one set.
#include "job/program_set.h"

#include <cmath>
#include <utility>

#include "compensation/pin_path.h"
#include "compensation/wheel_path.h"
#include "core/number_text.h"
#include "job/pin_files.h"
#include "job/speed_files.h"
#include "nc_out/infeed.h"
#include "nc_out/main_program.h"
#include "nc_out/table_guards.h"
#include "nc_out/table_layer.h"
#include "nc_out/table_program.h"

namespace gaugeloop {
namespace {

// The speed program is planned on the fine path (0.01 deg) and written from every 0.5 deg of
// it: the feed blocks are tens of degrees long, and the writer's search over block ends grows
// with the square of the points a block may span.
constexpr double kSpeedProgramStepDeg = 0.5;

// The lobe's speed program on `path` (JobSettings::speed), within the slide's limits of the
// axis guards. Errors: kInvalidInput for settings out of range (naming the key); kRefused
// when no feed profile keeps the speed bound at the control's block rate.
WorkSpeedSettings speed_settings(const JobSettings& s) {
  WorkSpeedSettings ws = *s.speed;
  ws.x_velocity_max_mm_per_s = s.axis_limits.x_velocity_max_mm_per_s;
  ws.x_acceleration_max_mm_per_s2 = s.axis_limits.x_acceleration_max_mm_per_s2;
  return ws;
}

// The feed blocks of a planned speed program.
Result<BuiltSpeed> speed_from_plan(Result<WorkSpeedPlan> plan, const JobSettings& s) {
  if (!plan) return plan.error();
  BuiltSpeed out;
  const auto every = static_cast<std::size_t>(std::lround(kSpeedProgramStepDeg / plan->program.c_step_deg));
  out.written.c_step_deg = plan->program.c_step_deg * static_cast<double>(every);
  for (std::size_t k = 0; k < plan->program.speed_rpm.size(); k += every) {
    out.written.speed_rpm.push_back(plan->program.speed_rpm[k]);
  }
  Result<SpeedProfile> profile = write_speed_profile(out.written, s.speed_profile);
  if (!profile) return profile.error();
  out.plan = std::move(*plan);
  out.profile = std::move(*profile);
  return out;
}

// The table the settings ask for on the exact path `fine`.
Result<CurveTable> table_of_kind(const SampledPath& fine, const JobSettings& s, const TablePointsInForce* in_force) {
  const AdaptiveSettings adaptive{s.table_choice.bound_um, s.table_choice.max_step_deg};
  switch (s.table_kind) {
    case TableKind::kAuto:
      return write_default_table(fine, s.table_choice, s.table_format, in_force);
    case TableKind::kLinear:
      return write_linear_table(fine, s.table_step_deg, s.table_format);
    case TableKind::kSpline:
      return write_spline_table(fine, s.table_step_deg, s.table_format);
    case TableKind::kAdaptiveLinear:
      return write_adaptive_linear_table(fine, adaptive, s.table_format);
    case TableKind::kAdaptiveSpline:
      return write_adaptive_spline_table(fine, adaptive, s.table_format);
    case TableKind::kPoly:
      return write_poly_table(fine, s.table_step_deg, s.table_format);
  }
  return make_error(ErrorCode::kInternal, "unknown table kind");
}

// The table the settings ask for on the exact path `fine` of one following axis, with the
// axis guards on the path and on the table as the NC will interpolate it.
Result<CurveTable> table_for_path(const SampledPath& fine, const AxisLimits& limits, const JobSettings& s,
                                  const TablePointsInForce* in_force, const std::string& what) {
  if (Status g = check_path_guards(fine, limits); !g) return in_step(what + " path", g.error());
  Result<CurveTable> table = table_of_kind(fine, s, in_force);
  if (!table) return in_step(what + " table", table.error());
  if (Status g = check_table_guards(*table, fine, limits); !g) return in_step(what + " table", g.error());
  return table;
}

SampledPath fine_path(std::vector<double> x, std::vector<double> dx, std::vector<double> d2x) {
  SampledPath out;
  out.c_step_deg = kFinePathStepDeg;
  out.x_mm = std::move(x);
  out.dx_dc_mm_per_deg = std::move(dx);
  out.d2x_dc2_mm_per_deg2 = std::move(d2x);
  return out;
}

// The part, its number and a pin's mode in a table's header.
void name_the_part(const JobSettings& s, TableProvenance& provenance) {
  provenance.part = s.part.name;
  provenance.lobe = s.part.lobe;
  if (s.pin) provenance.pin_mode = std::string(pin_mode_name(s.pin->mode));
}

}  // namespace

Result<BuiltTable> build_table(const PeriodicSpline& lift_mm, const JobSettings& s, const TablePointsInForce* in_force,
                               const TableInterpolant* layer_on) {
  Result<MachinePath> path = compute_machine_path(lift_mm, s.part, kFinePathStepDeg);
  if (!path) return in_step("wheel path", path.error());
  BuiltTable out;
  if (s.speed) {
    Result<BuiltSpeed> speed = speed_from_plan(plan_work_speed(*path, s.part, speed_settings(s)), s);
    if (!speed) return in_step("speed program", speed.error());
    out.speed = std::move(*speed);
  }
  out.fine = fine_path(std::move(path->x_mm), std::move(path->dx_dc_mm_per_deg), std::move(path->d2x_dc2_mm_per_deg2));
  if (s.layer_design_table_number != 0) {
    if (layer_on == nullptr) {
      return make_error(ErrorCode::kInternal, "a correction layer is built against its design table: none given");
    }
    if (Status g = check_path_guards(out.fine, s.axis_limits); !g) return in_step("wheel path", g.error());
    Result<SampledPath> layer = layer_path(out.fine, *layer_on);
    if (!layer) return in_step("correction layer", layer.error());
    Result<CurveTable> table = table_of_kind(*layer, s, in_force);
    if (!table) return in_step("correction layer table", table.error());
    if (Status g = check_layered_guards(*table, *layer_on, out.fine, s.axis_limits); !g) {
      return in_step("correction layer table", g.error());
    }
    out.fine = std::move(*layer);
    out.table = std::move(*table);
    return out;
  }
  Result<CurveTable> table = table_for_path(out.fine, s.axis_limits, s, in_force, "wheel");
  if (!table) return table.error();
  out.table = std::move(*table);
  return out;
}

Result<BuiltTable> build_pin_table(const DegreeTable& correction_um, const JobSettings& s,
                                   const TablePointsInForce* in_force) {
  Result<PinPath> path = corrected_pin_path(*s.pin, correction_um, kFinePathStepDeg);
  if (!path) return in_step("pin path", path.error());
  BuiltTable out;
  if (s.speed) {
    Result<BuiltSpeed> speed = speed_from_plan(plan_pin_work_speed(*path, *s.pin, speed_settings(s)), s);
    if (!speed) return in_step("speed program", speed.error());
    out.speed = std::move(*speed);
  }
  out.fine = fine_path(std::move(path->x_mm), std::move(path->dx_dc_mm_per_deg), std::move(path->d2x_dc2_mm_per_deg2));
  Result<CurveTable> x = table_for_path(out.fine, s.axis_limits, s, in_force, "X");
  if (!x) return x.error();
  out.table = std::move(*x);
  if (s.pin->mode == PinMode::kCXY) {
    out.y_fine =
        fine_path(std::move(path->y_mm), std::move(path->dy_dc_mm_per_deg), std::move(path->d2y_dc2_mm_per_deg2));
    Result<CurveTable> y = table_for_path(*out.y_fine, s.y_axis_limits, s, nullptr, "Y");
    if (!y) return y.error();
    out.y_table = std::move(*y);
  }
  return out;
}

std::map<std::string, std::string> template_values(const JobSettings& s) {
  return {{"program_name", s.nc_program},
          {"part", s.part.name},
          {"lobe", std::to_string(s.part.lobe)},
          {"version", GAUGELOOP_VERSION},
          {"run_id", "0"},
          {"origin", origin_text(0)},
          {"created_utc", ""},
          {"correction_max_um", "0"},
          {"table_number", std::to_string(s.table_numbers[0])}};
}

Result<std::string> with_archive_header(const JobSettings& s, Result<std::string> program) {
  if (!program || !s.nc_archive_header) return program;
  Result<std::string> header = archive_header(s.nc_program, NcProgramKind::kSubprogram);
  if (!header) return header.error();
  return *header + *program;
}

Result<std::string> render_speed(const JobSettings& s, const BuiltSpeed& speed, std::int64_t run_id,
                                 const std::string& created_utc, int table_version) {
  std::map<std::string, std::string> values = template_values(s);
  values["run_id"] = std::to_string(run_id);
  values["origin"] = origin_text(run_id);
  values["created_utc"] = created_utc;
  SpeedProvenance provenance;
  provenance.run_id = run_id;
  provenance.table_version = table_version;
  return render_speed_program(s.nc_speed_template, s.nc_speed_template_name, values, speed.profile, provenance);
}

MainProgramSource main_source(const JobSettings& s, const std::string& created_utc) {
  MainProgramSource m = main_program_source(s);
  m.files = s.nc_files.get();
  m.part = s.part.name;
  m.lobe = s.part.lobe;
  m.created_utc = created_utc;
  if (s.pin && s.pin->mode == PinMode::kCXY) {
    m.y_program_name = pin_y_program_name(s.nc_program);
    m.y_table_numbers = s.y_table_numbers;
  }
  return m;
}

Result<std::string> render_y_table(const JobSettings& s, const CurveTable& y_table, std::int64_t run_id,
                                   const std::string& created_utc, int table_version) {
  std::map<std::string, std::string> values = template_values(s);
  values["program_name"] = pin_y_program_name(s.nc_program);
  values["run_id"] = std::to_string(run_id);
  values["origin"] = origin_text(run_id);
  values["created_utc"] = created_utc;
  values["correction_max_um"] = format_fixed(0.0, 1);  // Y keeps the design's path
  values["table_number"] = std::to_string(s.y_table_numbers[0]);
  TableProvenance provenance;
  provenance.run_id = run_id;
  provenance.table_version = table_version;
  provenance.table_numbers = s.y_table_numbers;
  name_the_part(s, provenance);
  Result<std::string> program =
      render_table_program(s.nc_y_template, s.nc_y_template_name, values, y_table, provenance, s.table_format);
  if (!program || !s.nc_archive_header) return program;
  Result<std::string> header = archive_header(pin_y_program_name(s.nc_program), NcProgramKind::kSubprogram);
  if (!header) return header.error();
  return *header + *program;
}

Result<std::string> render_x_table(const JobSettings& s, const BuiltTable& built, std::int64_t run_id,
                                   const std::string& created_utc, double correction_max_um, int table_version) {
  std::map<std::string, std::string> values = template_values(s);
  values["run_id"] = std::to_string(run_id);
  values["origin"] = origin_text(run_id);
  values["created_utc"] = created_utc;
  values["correction_max_um"] = format_fixed(correction_max_um, 1);
  TableProvenance provenance;
  provenance.run_id = run_id;
  provenance.table_version = table_version;
  provenance.table_numbers = s.table_numbers;
  provenance.grinding_cycle = grinding_cycle_text({s.cycle, s.axis_limits.speed_rpm, s.table_format});
  name_the_part(s, provenance);
  if (s.layer_design_table_number != 0) {
    provenance.design_program = design_program_name(s.nc_program);
    provenance.design_table_number = s.layer_design_table_number;
  }
  return with_archive_header(
      s, render_table_program(s.nc_template, s.nc_template_name, values, built.table, provenance, s.table_format));
}

Result<LayerDesign> build_layer_design(const PeriodicSpline& design_lift, const JobSettings& s,
                                       const std::string& created_utc) {
  JobSettings whole_path = s;
  whole_path.layer_design_table_number = 0;
  Result<BuiltTable> whole = build_table(design_lift, whole_path);
  if (!whole) return whole.error();
  Result<std::string> program = render_design_table(s, whole->table, created_utc);
  if (!program) return in_step("design table", program.error());
  const std::string name = design_program_name(s.nc_program) + ".SPF";
  Result<DesignTable> table = read_design_table(*program, name, s.layer_design_table_number);
  if (!table) return in_step("design table", table.error());
  return LayerDesign{std::move(*whole), std::move(*program), std::move(*table)};
}

Result<std::string> render_design_table(const JobSettings& s, const CurveTable& design,
                                        const std::string& created_utc) {
  const std::string name = design_program_name(s.nc_program);
  std::map<std::string, std::string> values = template_values(s);
  values["program_name"] = name;
  values["created_utc"] = created_utc;
  values["origin"] = "the drawing";
  TableProvenance provenance;
  provenance.table_numbers = {s.layer_design_table_number, s.layer_design_table_number};
  provenance.layer_program = s.nc_program;
  name_the_part(s, provenance);
  Result<std::string> program =
      render_table_program(s.nc_template, s.nc_template_name, values, design, provenance, s.table_format);
  if (!program || !s.nc_archive_header) return program;
  Result<std::string> header = archive_header(name, NcProgramKind::kSubprogram);
  if (!header) return header.error();
  return *header + *program;
}

Result<PushCompletion> push_program_set(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                                        const BuiltTable& built, const JobSettings& s, const std::string& created_utc,
                                        double correction_max_um, PushOptions options) {
  const RenderForVersion render_table = [&](int table_version) {
    return render_x_table(s, built, facts.run_id, created_utc, correction_max_um, table_version);
  };
  if (built.y_table) {
    const RenderYForVersion render_y = [&](int table_version) {
      return render_y_table(s, *built.y_table, facts.run_id, created_utc, table_version);
    };
    return push_pin_programs(store, nc_file, facts, render_table, render_y, options);
  }
  if (!built.speed) return push_program(store, nc_file, facts, render_table, options);
  // The speed subprogram names the table version it goes with.
  Result<int> next = next_table_version_settled(store, nc_file, options);
  if (!next) return next.error();
  Result<std::string> speed = render_speed(s, *built.speed, facts.run_id, created_utc, *next);
  if (!speed) return speed.error();
  return push_program_with_speed(store, nc_file, facts, render_table, *speed, options);
}

}  // namespace gaugeloop
