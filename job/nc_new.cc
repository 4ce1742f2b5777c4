// The first program of a part from its drawing: built, pushed as version 1, read back.
#include "job/nc_new.h"

#include <cmath>
#include <optional>
#include <utility>

#include "compensation/periodic_spline.h"
#include "compensation/pin_kinematics.h"
#include "compensation/work_speed.h"
#include "core/number_text.h"
#include "core/utc_time.h"
#include "job/nc_files.h"
#include "job/pin_files.h"
#include "job/speed_files.h"
#include "nc_out/main_program.h"
#include "nc_out/table_layer.h"
#include "nc_out/table_program.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

// The candidates for one following axis: what the default weighed; none for a fixed kind.
Result<std::vector<TableCandidate>> candidates_for(const SampledPath& fine, const JobSettings& s) {
  if (s.table_kind != TableKind::kAuto) return std::vector<TableCandidate>{};
  return default_table_candidates(fine, s.table_choice, s.table_format);
}

// A table program as the control holds it: it parses, its body matches its checksum and it
// holds the points written.
Status read_back_table(NcFiles& files, const std::filesystem::path& path, const CurveTable& written,
                       const CurveTableFormat& format) {
  Result<std::optional<std::string>> text = files.read_program(path);
  if (!text) return text.error();
  if (!*text) return make_error(ErrorCode::kIo, path.string() + ": written, but not there when read back");
  Result<ParsedTable> parsed = parse_table_program(**text, path.string());
  if (!parsed) return parsed.error();
  if (Status s = verify_table_checksum(*parsed, path.string()); !s) return s;
  return compare_table_points(*parsed, written.points, path.string(), format);
}

// The main program as the control holds it couples the table number of `table_program`.
Status read_back_main(NcFiles& files, const std::filesystem::path& nc_file, std::string_view table_program) {
  const std::filesystem::path path = main_program_path(nc_file);
  Result<std::optional<std::string>> text = files.read_program(path);
  if (!text) return text.error();
  if (!*text) return make_error(ErrorCode::kIo, path.string() + ": written, but not there when read back");
  Result<int> coupled = coupled_table_number(**text, path.string());
  if (!coupled) return coupled.error();
  Result<ParsedTable> table = parse_table_program(table_program, nc_file.string());
  if (!table) return table.error();
  if (*coupled != table->table_number) {
    return make_error(ErrorCode::kIo, path.string() + " couples table " + std::to_string(*coupled) + ", not table " +
                                          std::to_string(table->table_number) + " that " + nc_file.filename().string() +
                                          " defines");
  }
  return {};
}

// One row a whole degree: the fine path's row there, the speed, and the command error over
// the degree.
Status fill_rows(ProgramPreview& p, const JobSettings& s) {
  const BuiltTable& b = p.built;
  Result<std::vector<double>> x_error = command_error_per_degree_um(b.fine, b.table);
  if (!x_error) return x_error.error();
  std::optional<std::vector<double>> y_error;
  if (b.y_table) {
    Result<std::vector<double>> e = command_error_per_degree_um(*b.y_fine, *b.y_table);
    if (!e) return e.error();
    y_error = std::move(*e);
  }
  Result<TableInterpolant> nc = TableInterpolant::of(b.table.points, b.table.interpolation);
  if (!nc) return nc.error();
  const auto per_degree = static_cast<std::size_t>(std::lround(1.0 / b.fine.c_step_deg));
  for (int d = 0; d < 360; ++d) {
    const std::size_t k = static_cast<std::size_t>(d) * per_degree;
    PreviewRow r;
    r.c_deg = d;
    r.x_mm = b.fine.x_mm[k];
    r.dx_mm_per_deg = b.fine.dx_dc_mm_per_deg[k];
    r.d2x_mm_per_deg2 = b.fine.d2x_dc2_mm_per_deg2[k];
    if (b.y_fine) r.y_mm = b.y_fine->x_mm[k];
    r.c_speed_rpm = b.speed ? b.speed->plan.program.speed_rpm[k] : std::abs(s.axis_limits.speed_rpm);
    r.grinding_point_speed_mm_per_min =
        s.pin ? pin_grinding_point_speed_mm_per_min(*s.pin, d, r.c_speed_rpm)
              : grinding_point_speed_mm_per_min(
                    contact_arc_mm_per_deg(r.x_mm, r.dx_mm_per_deg, r.d2x_mm_per_deg2, s.part.base_circle_radius_mm,
                                           s.part.wheel_radius_mm),
                    r.c_speed_rpm);
    r.x_nc_mm = nc->at(d).x_mm;
    r.command_error_um = (*x_error)[static_cast<std::size_t>(d)];
    if (y_error) r.y_command_error_um = (*y_error)[static_cast<std::size_t>(d)];
    p.rows.push_back(r);
  }
  return {};
}

// A correction layer's design table `whole` (the preview's) on the control: written when it is
// not there; left as it is (never rewritten) when it holds that table already; refused when it
// holds another unless `replace`. Then the layer that goes with the design table as the control
// holds it.
Result<BuiltTable> write_design_table(const JobSettings& s, const CurveTable& whole, NcFiles& files, bool replace,
                                      const std::string& created_utc) {
  Result<PeriodicSpline> lift = PeriodicSpline::fit(s.design.angle_deg, s.design.lift_mm);
  if (!lift) return in_step("design lift table " + s.design.source, lift.error());
  Result<std::string> program = render_design_table(s, whole, created_utc);
  if (!program) return in_step("design table", program.error());
  const std::filesystem::path file =
      design_program_path(std::filesystem::absolute(s.nc_dir / (s.nc_program + ".SPF")).lexically_normal());
  Result<std::optional<std::string>> on_control = files.read_program(file);
  if (!on_control) return on_control.error();
  bool same = false;
  if (*on_control) {
    Result<DesignTable> there = read_design_table(**on_control, file.string(), s.layer_design_table_number);
    same = there && compare_table_points(there->parsed, whole.points, file.string(), s.table_format) &&
           there->parsed.interpolation == whole.interpolation;
    if (!same && !replace) {
      return make_error(ErrorCode::kRefused,
                        file.string() + " holds another design table than this drawing's (" +
                            (there ? std::string("other points") : there.error().message) +
                            "): the correction layer in force is added to it. To start again from the drawing, "
                            "replace it (--replace; over the HTTP API \"replace\": true)");
    }
  }
  if (!same) {
    if (Status w = files.write_program(file, *program, {}); !w) return in_step("design table", w.error());
  }
  Result<std::optional<std::string>> text = files.read_program(file);
  if (!text) return text.error();
  if (!*text) return make_error(ErrorCode::kIo, file.string() + ": written, but not there when read back");
  Result<DesignTable> held = read_design_table(**text, file.string(), s.layer_design_table_number);
  if (!held) return held.error();
  return build_table(*lift, s, nullptr, &held->nc);
}

}  // namespace

Result<ProgramPreview> preview_new_program(const JobSettings& s) {
  if (Status c = check_job_settings(s); !c) return c.error();
  ProgramPreview p;
  Result<BuiltTable> built = [&]() -> Result<BuiltTable> {
    if (s.pin) return build_pin_table(DegreeTable{}, s);
    Result<PeriodicSpline> design = PeriodicSpline::fit(s.design.angle_deg, s.design.lift_mm);
    if (!design) return in_step("design lift table " + s.design.source, design.error());
    if (s.layer_design_table_number == 0) return build_table(*design, s);
    // A correction layer: the new program is the design's whole table; the layer that goes
    // with it holds what the design table's interpolation misses.
    Result<LayerDesign> layer_design = build_layer_design(*design, s, "");
    if (!layer_design) return layer_design.error();
    return std::move(layer_design->whole);
  }();
  if (!built) return in_step("the design", built.error());
  p.built = std::move(*built);
  Result<std::vector<TableCandidate>> x = candidates_for(p.built.fine, s);
  if (!x) return x.error();
  p.x_candidates = std::move(*x);
  if (p.built.y_fine) {
    Result<std::vector<TableCandidate>> y = candidates_for(*p.built.y_fine, s);
    if (!y) return y.error();
    p.y_candidates = std::move(*y);
  }
  if (Status r = fill_rows(p, s); !r) return r.error();
  Result<InfeedPlan> infeed = plan_infeed(s.cycle, s.table_format);
  if (!infeed) return in_step("part " + s.part.name, infeed.error());
  p.infeed = std::move(*infeed);
  p.work_speed_rpm = s.axis_limits.speed_rpm;
  p.turn_time_s = p.built.speed ? p.built.speed->plan.cycle_time_s : 60.0 / std::abs(s.axis_limits.speed_rpm);
  p.cycle_time_s = p.turn_time_s * p.infeed.turns();
  return p;
}

Result<NewProgramReport> write_new_program(const JobSettings& s, const NewProgramOptions& options) {
  Result<ProgramPreview> preview = preview_new_program(s);
  if (!preview) return preview.error();
  NewProgramReport report;
  report.preview = std::move(*preview);
  // Absolute, so the push history names one file whatever directory a command runs in.
  report.nc_file = std::filesystem::absolute(s.nc_dir / (s.nc_program + ".SPF")).lexically_normal();
  const std::filesystem::path& nc_file = report.nc_file;
  Result<RunStore> store = open_store_for_push(s, nc_file);
  if (!store) return store.error();
  NcFiles& files = s.nc_files ? *s.nc_files : real_nc_files();
  Result<std::optional<NcPush>> last = store->last_push(nc_file.string());
  if (!last) return last.error();
  if (*last && !options.replace) {
    const NcPush& p = **last;
    return make_error(ErrorCode::kRefused,
                      nc_file.string() + " has a history: version " + std::to_string(p.table_version) + " was pushed " +
                          p.pushed_utc + " (" + p.reason +
                          "). A new program starts a part from its drawing and would throw away what the loop has "
                          "learnt; `gaugeloop nc history --program " +
                          s.nc_program +
                          "` shows it. To start again from the drawing all the same, replace it (--replace; over "
                          "the HTTP API \"replace\": true): the history stays and the new program becomes version " +
                          std::to_string(p.table_version + 1) + ")");
  }

  const std::string created_utc = utc_now();
  std::optional<BuiltTable> layer;
  if (s.layer_design_table_number != 0) {
    Result<BuiltTable> l = write_design_table(s, report.preview.built.table, files, options.replace, created_utc);
    if (!l) return l.error();
    layer = std::move(*l);
    report.design_file = design_program_path(nc_file);
  }
  const BuiltTable& built = layer ? *layer : report.preview.built;
  PushFacts facts;
  facts.run_id = 0;
  facts.reason = "new program" + (options.from_file.empty() ? std::string() : " from " + options.from_file) +
                 (options.by.empty() ? std::string() : " by " + options.by);
  facts.table.interpolation = std::string(interpolation_name(built.table.interpolation));
  facts.table.block_count = built.table.block_count();
  facts.table.command_error_um = built.table.error.max_abs_um;
  facts.table.point_count = static_cast<int>(built.table.points.size());
  facts.table.correction_max_um = 0.0;
  PushOptions push;
  push.files = s.nc_files.get();
  push.main = main_source(s, created_utc);
  push.overwrite_edited = options.replace;  // a file there that gaugeloop did not write
  Result<PushCompletion> done = push_program_set(*store, nc_file, facts, built, s, created_utc, 0.0, push);
  if (!done) return done.error();
  report.table_version = done->table_version;

  // Every file as the control holds it now.
  auto read_back = [&](Status st, const std::filesystem::path& path) -> Status {
    if (!st) {
      Error e = st.error();
      e.message = "version " + std::to_string(report.table_version) + " is pushed, but " + path.filename().string() +
                  " does not read back: " + e.message;
      return e;
    }
    report.files.push_back(path);
    return {};
  };
  if (layer) {
    const CurveTable& design = report.preview.built.table;
    if (Status r = read_back(read_back_table(files, report.design_file, design, s.table_format), report.design_file);
        !r) {
      return r.error();
    }
  }
  if (Status r = read_back(read_back_table(files, nc_file, built.table, s.table_format), nc_file); !r) return r.error();
  if (built.y_table) {
    const std::filesystem::path y = y_table_program_path(nc_file);
    if (Status r = read_back(read_back_table(files, y, *built.y_table, s.table_format), y); !r) return r.error();
  }
  if (built.speed) {
    Result<ParsedSpeedProgram> speed = read_speed_program(nc_file, files);
    if (Status r = read_back(speed ? Status{} : Status(speed.error()), speed_program_path(nc_file)); !r) {
      return r.error();
    }
  }
  if (!s.nc_main_template.empty()) {
    Result<std::optional<std::string>> table_text = files.read_program(nc_file);
    if (!table_text) return table_text.error();
    Status main = *table_text ? read_back_main(files, nc_file, **table_text)
                              : Status(make_error(ErrorCode::kIo, nc_file.string() + ": gone"));
    if (Status r = read_back(main, main_program_path(nc_file)); !r) return r.error();
  }

  EventRecord event;
  event.kind = EventKind::kInfo;
  event.code = "new_program";
  event.machine = s.machine;
  event.part = s.part.name;
  event.lobe = s.part.lobe;
  event.message = nc_file.string() + " version " + std::to_string(report.table_version) +
                  " written from the drawing (" + facts.reason + "): " + std::to_string(built.table.block_count()) +
                  " blocks, command position error " + format_fixed(built.table.error.max_abs_um, 3) + " um";
  (void)store->record_event(event);  // the push is recorded; the event only tells it again
  return report;
}

std::string preview_csv(const ProgramPreview& p) {
  const bool y = p.built.y_table.has_value();
  auto fixed = [](double v, int d) { return format_fixed(v, d); };
  std::string out = "c_deg,x_mm,dx_mm_per_deg,d2x_mm_per_deg2," + std::string(y ? "y_mm," : "") +
                    "c_speed_rpm,grinding_point_speed_mm_per_min,x_nc_mm,command_error_um" +
                    (y ? ",y_command_error_um" : "") + "\n";
  for (const PreviewRow& r : p.rows) {
    out += std::to_string(r.c_deg) + "," + fixed(r.x_mm, 6) + "," + fixed(r.dx_mm_per_deg, 8) + "," +
           fixed(r.d2x_mm_per_deg2, 10) + "," + (y ? fixed(r.y_mm.value_or(0.0), 6) + "," : std::string()) +
           fixed(r.c_speed_rpm, 3) + "," + fixed(r.grinding_point_speed_mm_per_min, 1) + "," + fixed(r.x_nc_mm, 6) +
           "," + fixed(r.command_error_um, 4) + (y ? "," + fixed(r.y_command_error_um.value_or(0.0), 4) : "") + "\n";
  }
  return out;
}

ProgramPreviewPage preview_page(const ProgramPreview& p, const JobSettings& s) {
  ProgramPreviewPage page;
  page.title =
      "New program " + s.nc_program + ": " + s.part.name + (s.pin ? " pin " : " lobe ") + std::to_string(s.part.lobe);
  const CurveTable& t = p.built.table;
  page.subtitle = std::to_string(t.block_count()) + " blocks (" + t.writer + "), seam C" +
                  format_fixed(t.points.front().c_deg, 3) + ", command position error " +
                  format_fixed(t.error.max_abs_um, 3) + " um (bound " + format_fixed(s.table_choice.bound_um, 3) +
                  " um); " + std::to_string(p.infeed.turns()) + " turns, " + format_fixed(p.cycle_time_s, 1) + " s";
  page.footer = "machine frame, C the work spindle; resolution " + format_fixed(s.table_format.x_increments_per_mm, 0) +
                " increments/mm \u00b7 gaugeloop " + GAUGELOOP_VERSION;
  page.command_error_bound_um = s.table_choice.bound_um;
  for (const PreviewRow& r : p.rows) {
    page.x_mm.push_back(r.x_mm);
    page.dx_mm_per_deg.push_back(r.dx_mm_per_deg);
    page.d2x_mm_per_deg2.push_back(r.d2x_mm_per_deg2);
    if (r.y_mm) page.y_mm.push_back(*r.y_mm);
    page.c_speed_rpm.push_back(r.c_speed_rpm);
    page.grinding_point_speed_mm_per_min.push_back(r.grinding_point_speed_mm_per_min);
    page.command_error_um.push_back(r.command_error_um);
    if (r.y_command_error_um) page.y_command_error_um.push_back(*r.y_command_error_um);
  }
  return page;
}

}  // namespace gaugeloop
