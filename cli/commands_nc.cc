// nc: the curve tables pushed to the control, and the decisions on them: history, diff,
// rollback, check, and the approval of pending tables.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>

#include "cli/cli_common.h"
#include "cli/embedded_defaults.h"
#include "cli/measure_options.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "core/text_file.h"
#include "job/layer_files.h"
#include "job/nc_push.h"
#include "nc_out/slide_compensation.h"
#include "nc_out/stroke_program.h"
#include "nc_out/table_program.h"
#include "nc_out/table_writer.h"
#include "report/run_json.h"

namespace gaugeloop {
namespace {

using nlohmann::json;

struct NcOptions {
  DataPaths paths;
  // NAME: <nc-dir>/NAME.SPF; NAME.EXT (AX_EEC.INI): that file; empty: the one program the history has
  std::string program;
  bool json_out = false;
};

void add_nc_options(CLI::App& cmd, NcOptions& o) {
  add_data_options(cmd, o.paths);
  cmd.add_option("--nc-dir", o.paths.nc_dir, "Directory the curve-table programs are written to [<data-dir>/nc]");
  cmd.add_option("--program", o.program,
                 "Program name, e.g. CAM_INTAKE_L1 (the file <nc-dir>/NAME.SPF), or a file with its extension, e.g. "
                 "AX_EEC.INI (the slide tables) [the only program pushed]");
}

std::string person(const std::string& given) {
  if (!given.empty()) return given;
  const char* user = std::getenv("USER");
  return user != nullptr && *user != '\0' ? user : "operator";
}

// The NC file the command is about, as measure records it: an absolute path.
Result<std::string> resolve_program(const RunStore& store, const NcOptions& o) {
  if (!o.program.empty()) {
    std::string name = o.program;
    if (name.size() > 4 && (name.ends_with(".SPF") || name.ends_with(".spf"))) name.resize(name.size() - 4);
    if (!std::filesystem::path(name).has_extension()) name += ".SPF";
    return std::filesystem::absolute(o.paths.nc() / name).lexically_normal().string();
  }
  PushQuery q;
  q.limit = 100000;
  Result<std::vector<NcPush>> pushes = store.list_pushes(q);
  if (!pushes) return pushes.error();
  std::set<std::string> files;
  for (const NcPush& p : *pushes) files.insert(p.nc_file);
  if (files.size() == 1) return *files.begin();
  if (files.empty()) {
    return make_error(ErrorCode::kNotFound, "no table was pushed yet; run `gaugeloop demo` or `gaugeloop measure`");
  }
  std::string list;
  for (const std::string& f : files) {
    const std::filesystem::path p(f);
    list += (list.empty() ? "" : ", ") + (p.extension() == ".SPF" ? p.stem().string() : p.filename().string());
  }
  return make_error(ErrorCode::kInvalidInput, "tables were pushed to several programs (" + list +
                                                  "): name one with --program, and --nc-dir if it is not the default");
}

// ---- nc history ----

struct HistoryOptions : NcOptions {
  int limit = 50;
};

int cmd_history(const HistoryOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  PushQuery q;
  q.limit = o.limit;
  if (!o.program.empty()) {
    Result<std::string> file = resolve_program(*store, o);
    if (!file) return report_error(file.error());
    q.nc_file = *file;
  }
  Result<std::vector<NcPush>> pushes = store->list_pushes(q);
  if (!pushes) return report_error(pushes.error());
  if (o.json_out) {
    json out = json::array();
    for (const NcPush& p : *pushes) out.push_back(nc_push_json(p));
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  std::printf("%-16s %7s  %-20s  %6s  %-8s  %6s  %9s  %s\n", "program", "version", "pushed (UTC)", "run", "table",
              "blocks", "error um", "reason");
  for (const NcPush& p : *pushes) {
    // Run "-": a program written from the drawing (nc new).
    std::printf("%-16s %7d  %-20s  %6s  %-8s  %6s  %9s  %s\n", std::filesystem::path(p.nc_file).stem().string().c_str(),
                p.table_version, p.pushed_utc.c_str(), p.run_id != 0 ? std::to_string(p.run_id).c_str() : "-",
                p.table.interpolation.empty() ? "-" : p.table.interpolation.c_str(),
                p.table.block_count ? std::to_string(*p.table.block_count).c_str() : "-",
                p.table.command_error_um ? format_fixed(*p.table.command_error_um, 3).c_str() : "-", p.reason.c_str());
  }
  if (pushes->empty()) std::printf("(no table was pushed)\n");
  return kExitOk;
}

// ---- nc diff ----

struct DiffOptions : NcOptions {
  int a = 0;
  int b = 0;
  double threshold_um = 0.1;
};

// Version `version` of `file` as pushed, with its program text.
Result<NcPush> pushed_program(const RunStore& store, const std::string& file, int version) {
  Result<NcPush> p = store.load_push(file, version);
  if (!p) return p.error();
  if (!p->program_text) {
    return make_error(ErrorCode::kNotFound, "table version " + std::to_string(version) + " of " + file +
                                                " was pushed before gaugeloop kept program texts; it cannot be "
                                                "compared or rolled back to");
  }
  return p;
}

Result<ParsedTable> pushed_table(const RunStore& store, const std::string& file, int version, NcPush& push) {
  Result<NcPush> p = pushed_program(store, file, version);
  if (!p) return p.error();
  push = *p;
  return parse_table_program(*p->program_text, file + " version " + std::to_string(version));
}

// Two versions of a gear's stroke: SIM1 at each spline point of both, and the difference.
int diff_strokes(const DiffOptions& o, const std::string& file, const NcPush& pa, const NcPush& pb) {
  Result<ParsedStrokeProgram> sa = parse_stroke_program(*pa.program_text, file + " version " + std::to_string(o.a));
  if (!sa) return report_error(sa.error());
  Result<ParsedStrokeProgram> sb = parse_stroke_program(*pb.program_text, file + " version " + std::to_string(o.b));
  if (!sb) return report_error(sb.error());
  if (sa->points.size() != sb->points.size()) {
    return report_error(make_error(ErrorCode::kInvalidInput, file + ": version " + std::to_string(o.a) + " has " +
                                                                 std::to_string(sa->points.size()) +
                                                                 " spline points, version " + std::to_string(o.b) +
                                                                 " " + std::to_string(sb->points.size())));
  }
  json rows = json::array();
  double worst = 0.0;
  for (std::size_t i = 0; i < sa->points.size(); ++i) {
    const StrokeProgramPoint& a = sa->points[i];
    const StrokeProgramPoint& b = sb->points[i];
    if (a.z_mm != b.z_mm) {
      return report_error(make_error(ErrorCode::kInvalidInput, file + ": spline point " + std::to_string(i + 1) +
                                                                   " is at Z" + format_fixed(a.z_mm, 4) +
                                                                   " in one version, Z" + format_fixed(b.z_mm, 4) +
                                                                   " in the other"));
    }
    if (std::abs(b.sim_deg - a.sim_deg) > std::abs(worst)) worst = b.sim_deg - a.sim_deg;
    rows.push_back(
        {{"z_mm", a.z_mm}, {"sim_a_deg", a.sim_deg}, {"sim_b_deg", b.sim_deg}, {"dsim_deg", b.sim_deg - a.sim_deg}});
  }
  if (o.json_out) {
    print_json(json{{"nc_file", file},
                    {"a", nc_push_json(pa)},
                    {"b", nc_push_json(pb)},
                    {"largest_dsim_deg", worst},
                    {"points", rows}});
    return kExitOk;
  }
  std::printf("%s: stroke version %d -> version %d, %zu spline points, SIM1(B) - SIM1(A) largest %+.6f deg\n",
              file.c_str(), o.a, o.b, sa->points.size(), worst);
  std::printf("  %10s  %12s  %12s  %12s\n", "Z mm", "SIM1 A deg", "SIM1 B deg", "dSIM deg");
  for (const json& r : rows) {
    std::printf("  %10.4f  %12.6f  %12.6f  %+12.6f\n", r["z_mm"].get<double>(), r["sim_a_deg"].get<double>(),
                r["sim_b_deg"].get<double>(), r["dsim_deg"].get<double>());
  }
  return kExitOk;
}

// The slide tables a version of AX_EEC.INI pushed: its LEC tables and the CEC tables of the file
// pushed beside it.
Result<std::vector<SlideCompensationTable>> pushed_slides(const RunStore& store, const std::string& file,
                                                          const NcPush& push) {
  const std::string name = file + " version " + std::to_string(push.table_version);
  Result<std::vector<SlideCompensationTable>> out = parse_slide_compensation(*push.program_text, name);
  if (!out) return out.error();
  Result<std::vector<PushFile>> files = store.files_of_push(file, push.table_version);
  if (!files) return files.error();
  for (const PushFile& f : *files) {
    if (f.role != PushFileRole::kCec || !f.text) continue;
    Result<std::vector<SlideCompensationTable>> cec = parse_slide_compensation(*f.text, f.path + " " + name);
    if (!cec) return cec.error();
    out->insert(out->end(), cec->begin(), cec->end());
  }
  return out;
}

// Two versions of the slides' tables: for each table, the largest change and where.
int diff_slides(const DiffOptions& o, const RunStore& store, const std::string& file, const NcPush& pa,
                const NcPush& pb) {
  Result<std::vector<SlideCompensationTable>> a = pushed_slides(store, file, pa);
  if (!a) return report_error(a.error());
  Result<std::vector<SlideCompensationTable>> b = pushed_slides(store, file, pb);
  if (!b) return report_error(b.error());
  json rows = json::array();
  for (const SlideCompensationTable& tb : *b) {
    const auto ta = std::find_if(a->begin(), a->end(), [&tb](const SlideCompensationTable& t) {
      return t.kind == tb.kind && t.input_axis == tb.input_axis && t.output_axis == tb.output_axis;
    });
    // Compared at B's points, A read as the control interpolates it (none: 0).
    double worst_um = 0.0;
    double at_mm = tb.min_mm;
    for (std::size_t k = 0; k < tb.error_mm.size(); ++k) {
      const double x = tb.min_mm + tb.step_mm * static_cast<double>(k);
      const double d_um = (tb.error_mm[k] - (ta == a->end() ? 0.0 : ta->taken_out_mm(x))) * 1000.0;
      if (std::abs(d_um) > std::abs(worst_um)) {
        worst_um = d_um;
        at_mm = x;
      }
    }
    rows.push_back({{"kind", tb.kind == SlideTableKind::kLeadscrew ? "LEC" : "CEC"},
                    {"input_axis", std::string(1, tb.input_axis)},
                    {"output_axis", std::string(1, tb.output_axis)},
                    {"in_a", ta != a->end()},
                    {"largest_change_um", worst_um},
                    {"at_mm", at_mm}});
  }
  if (o.json_out) {
    print_json(json{{"nc_file", file}, {"a", nc_push_json(pa)}, {"b", nc_push_json(pb)}, {"tables", rows}});
    return kExitOk;
  }
  std::printf("%s: slide tables version %d -> version %d (with the CEC file beside each)\n", file.c_str(), o.a, o.b);
  for (const json& r : rows) {
    std::printf("  %s %s over %s: largest change %+.1f um at %s %.1f mm%s\n", r["kind"].get<std::string>().c_str(),
                r["output_axis"].get<std::string>().c_str(), r["input_axis"].get<std::string>().c_str(),
                r["largest_change_um"].get<double>(), r["input_axis"].get<std::string>().c_str(),
                r["at_mm"].get<double>(), r["in_a"].get<bool>() ? "" : " (new in B)");
  }
  return kExitOk;
}

int cmd_diff(const DiffOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<std::string> file = resolve_program(*store, o);
  if (!file) return report_error(file.error());
  NcPush pa;
  NcPush pb;
  {
    Result<NcPush> a = pushed_program(*store, *file, o.a);
    if (!a) return report_error(a.error());
    Result<NcPush> b = pushed_program(*store, *file, o.b);
    if (!b) return report_error(b.error());
    if (is_stroke_program(*a->program_text) && is_stroke_program(*b->program_text)) {
      return diff_strokes(o, *file, *a, *b);
    }
    if (is_slide_compensation(*a->program_text) && is_slide_compensation(*b->program_text)) {
      return diff_slides(o, *store, *file, *a, *b);
    }
  }
  Result<ParsedTable> ta = pushed_table(*store, *file, o.a, pa);
  if (!ta) return report_error(ta.error());
  Result<ParsedTable> tb = pushed_table(*store, *file, o.b, pb);
  if (!tb) return report_error(tb.error());
  Result<TableInterpolant> ia = TableInterpolant::of(ta->points, ta->interpolation);
  if (!ia) return report_error(ia.error());
  Result<TableInterpolant> ib = TableInterpolant::of(tb->points, tb->interpolation);
  if (!ib) return report_error(ib.error());
  // What the NC runs, compared at every 0.01 deg of C; listed at whole degrees.
  double worst_um = 0.0;
  double worst_c = 0.0;
  double sum_sq = 0.0;
  constexpr int kRows = 36000;
  for (int k = 0; k < kRows; ++k) {
    const double c = k * 0.01;
    const double d_um = (ib->at(c).x_mm - ia->at(c).x_mm) * 1000.0;
    sum_sq += d_um * d_um;
    if (std::abs(d_um) > std::abs(worst_um)) {
      worst_um = d_um;
      worst_c = c;
    }
  }
  const double rms_um = std::sqrt(sum_sq / kRows);
  std::vector<std::pair<int, double>> degrees;
  for (int d = 0; d < 360; ++d) {
    const double d_um = (ib->at(d).x_mm - ia->at(d).x_mm) * 1000.0;
    if (std::abs(d_um) >= o.threshold_um) degrees.emplace_back(d, d_um);
  }
  if (o.json_out) {
    json rows = json::array();
    for (const auto& [d, um] : degrees) rows.push_back({{"c_deg", d}, {"dx_um", um}});
    json out{{"nc_file", *file},
             {"a", nc_push_json(pa)},
             {"b", nc_push_json(pb)},
             {"largest_dx_um", worst_um},
             {"largest_at_c_deg", worst_c},
             {"rms_dx_um", rms_um},
             {"threshold_um", o.threshold_um},
             {"degrees", rows}};
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  std::printf("%s: version %d -> version %d\n", file->c_str(), o.a, o.b);
  for (const auto* p : {&pa, &pb}) {
    // Where the version came from, once: "run 12", "run 12, approved by anna", or the drawing's
    // reason for a program with no run.
    const std::string run = "run " + std::to_string(p->run_id);
    const std::string from = p->run_id == 0 || p->reason == run ? p->reason : run + ", " + p->reason;
    std::printf("  version %-4d %s, %s, %zu points, pushed %s\n", p->table_version, from.c_str(),
                p->table.interpolation.empty() ? "-" : p->table.interpolation.c_str(),
                (p == &pa ? ta : tb)->points.size(), p->pushed_utc.c_str());
  }
  std::printf("  X(B) - X(A), as the NC interpolates each: largest %+.3f um at C%.2f, RMS %.3f um\n", worst_um, worst_c,
              rms_um);
  if (degrees.empty()) {
    std::printf("  no whole degree differs by %.2f um or more\n", o.threshold_um);
  } else {
    std::printf("  whole degrees of C differing by %.2f um or more:\n  %6s  %9s\n", o.threshold_um, "C deg", "dX um");
    for (const auto& [d, um] : degrees) std::printf("  %6d  %+9.3f\n", d, um);
  }
  return kExitOk;
}

// ---- nc rollback ----

struct RollbackOptions : NcOptions {
  int version = 0;
  std::string by;
  std::string main_template_path;
};

constexpr const char* kMainTemplateHelp =
    "Main program template, rewritten beside the table as <program>_MAIN.MPF to couple the table just written "
    "[built-in Sinumerik 840D main program]";

// The main program's template as the option names it; its part and lobe are the run's.
// Without --main-template, a crankpin ground C-X gets the built-in pin main program, a gear's
// stroke the built-in gear main program, a correction layer the built-in layer main program and
// a table kept with its speed subprogram the built-in main program that calls it.
Result<MainProgramSource> main_source(const std::string& path) {
  MainProgramSource m;
  Result<std::string> text = load_main_template(path, m.template_name);
  if (!text) return text.error();
  m.template_text = std::move(*text);
  if (path.empty()) {
    m.pin_cx_template_text = std::string(embedded::kPinMainCxTemplate);
    m.pin_cx_template_name = "embedded:pin_main_cx.mpf";
    m.gear_template_text = std::string(embedded::kGearMainTemplate);
    m.gear_template_name = "embedded:gear_main.mpf";
    m.layer_template_text = std::string(embedded::kNcMainLayerTemplate);
    m.layer_template_name = "embedded:cam_main_layer.mpf";
    m.speed_template_text = std::string(embedded::kNcMainSpeedTemplate);
    m.speed_template_name = "embedded:cam_main_speed.mpf";
  }
  return m;
}

int cmd_rollback(const RollbackOptions& o) {
  Result<RunStore> store = open_history(o.paths);
  if (!store) return report_error(store.error());
  Result<std::string> file = resolve_program(*store, o);
  if (!file) return report_error(file.error());
  Result<MainProgramSource> main = main_source(o.main_template_path);
  if (!main) return report_error(main.error());
  Result<PushOutcome> pushed = rollback_to_version(*store, *file, o.version, person(o.by), *main);
  if (!pushed) return report_error(pushed.error());
  if (pushed->stroke) {
    std::printf("%s: stroke version %d written, the stroke of version %d; it is now the stroke in force\n",
                file->c_str(), pushed->table_version, o.version);
    return kExitOk;
  }
  if (pushed->slides) {
    std::printf(
        "%s: slide tables version %d written with the CEC file beside it, the pair of version %d; load them with "
        "compensation off (MD32700 and MD32710 0), then on\n",
        file->c_str(), pushed->table_version, o.version);
    return kExitOk;
  }
  std::printf("%s: table version %d written, the table of version %d (%s); it is now the table in force\n",
              file->c_str(), pushed->table_version, o.version, origin_text(pushed->run_id).c_str());
  return kExitOk;
}

// ---- nc check ----

int cmd_check(const NcOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<std::string> file = resolve_program(*store, o);
  if (!file) return report_error(file.error());
  if (Status c = check_not_edited_by_hand(*store, *file); !c) return report_error(c.error());
  // The main program must couple the table the subprogram defines: else the control grinds another.
  Result<std::optional<StaleMain>> stale = find_stale_main(*store, *file);
  if (!stale) return report_error(stale.error());
  if (*stale) {
    std::fprintf(stderr,
                 "gaugeloop: %s: %s. A push was cut (or its main program not written) after the table was in "
                 "place; `gaugeloop nc reconcile` writes the main program again for the table on the control "
                 "(--main-template if the service uses its own), the next push or measurement does too\n",
                 (**stale).main_file.string().c_str(), stale_main_text(**stale).c_str());
    return kExitNcOutput;
  }
  // Every other file of the push in force (speed subprogram, Y table, main program) as it wrote it.
  Result<std::vector<PushFileMismatch>> beside = compare_push_files(*store, *file);
  if (!beside) return report_error(beside.error());
  for (const PushFileMismatch& m : *beside) {
    std::fprintf(stderr, "gaugeloop: %s: %s; %s\n", m.file.path.c_str(), push_file_mismatch_text(m).c_str(),
                 m.missing || m.written_for ? "`gaugeloop nc reconcile` writes it again as that push wrote it"
                                            : "no push of gaugeloop wrote what it holds (edited by hand?): copy it "
                                              "elsewhere to keep it, then remove it and run `gaugeloop nc reconcile`");
  }
  if (!beside->empty()) return kExitNcOutput;
  // Temporary files of interrupted writes: harmless to the control, removed by reconciliation.
  for (const std::filesystem::path& path : files_of_push(*file)) {
    if (!std::filesystem::is_directory(path.parent_path())) break;
    Result<std::vector<std::filesystem::path>> leftovers = atomic_leftovers(path);
    if (!leftovers) return report_error(leftovers.error());
    for (const std::filesystem::path& l : *leftovers) {
      std::printf("%s: a temporary file left by an interrupted write of %s; `gaugeloop nc reconcile` removes it\n",
                  l.string().c_str(), path.filename().string().c_str());
    }
  }
  Result<std::optional<NcPush>> last = store->last_push(*file);
  if (!last) return report_error(last.error());
  if (!std::filesystem::exists(*file)) {
    std::printf("%s: not on disk%s\n", file->c_str(),
                *last ? (" (version " + std::to_string((**last).table_version) + " was pushed)").c_str() : "");
    return kExitNcOutput;
  }
  // Written by a push whose record was interrupted: that push's table, recorded at the next
  // push or by `nc reconcile`.
  Result<std::vector<PushIntent>> open = store->open_push_intents(*file);
  if (!open) return report_error(open.error());
  Result<std::string> on_disk = read_regular_file(*file, "NC program");
  if (!on_disk) return report_error(on_disk.error());
  for (const PushIntent& i : *open) {
    if (i.push.program_text != *on_disk) continue;
    std::printf(
        "%s: table version %d as written for run %lld (%s); its push was interrupted before it was "
        "recorded: `gaugeloop nc reconcile` or the next push records it\n",
        file->c_str(), i.push.table_version, static_cast<long long>(i.run_id), i.created_utc.c_str());
    return kExitOk;
  }
  if (!*last) {
    // A program the history never pushed: what it did push, in the NC directory in force.
    Result<std::vector<std::string>> pushed = store->pushed_files();
    if (!pushed) return report_error(pushed.error());
    std::string held;
    for (const std::string& f : *pushed) held += (held.empty() ? "" : ", ") + f;
    std::fprintf(stderr,
                 "gaugeloop: %s: the history in %s records no push to this file, so it cannot say what it should "
                 "hold; %s. Check one of those programs (--program), or the NC directory they were pushed to "
                 "(--nc-dir)\n",
                 file->c_str(), o.paths.db().string().c_str(),
                 held.empty() ? "it records no push at all" : ("its pushes went to " + held).c_str());
    return kExitNcOutput;
  }
  if (is_stroke_program(*on_disk)) {
    std::printf("%s: stroke version %d as pushed (%s, %s)\n", file->c_str(), *last ? (**last).table_version : 0,
                *last ? (**last).reason.c_str() : "-", *last ? (**last).pushed_utc.c_str() : "-");
    return kExitOk;
  }
  if (is_slide_compensation(*on_disk)) {
    std::printf("%s: slide tables version %d as pushed, the CEC file beside it too (%s, %s)\n", file->c_str(),
                (**last).table_version, (**last).reason.c_str(), (**last).pushed_utc.c_str());
    return kExitOk;
  }
  // A correction layer: the design table it is added to must be there, the one written.
  Result<std::optional<LayerOnControl>> layer = layer_on_control(*on_disk, *file);
  if (!layer) return report_error(layer.error());
  std::string design;
  if (*layer) {
    const LayerOnControl& l = **layer;
    if (!l.problem.empty()) {
      std::fprintf(stderr, "gaugeloop: %s is a correction layer, and its design table cannot be used: %s\n",
                   file->c_str(), l.problem.c_str());
      return kExitNcOutput;
    }
    design = ", a correction layer added to the design table " + l.design_file.filename().string() + " (table " +
             std::to_string(l.design_table_number) + ", as written from the drawing)";
  }
  std::printf("%s: %s version %d as pushed (%s, %s)%s\n", file->c_str(), design.empty() ? "table" : "layer",
              *last ? (**last).table_version : 0, *last ? origin_text((**last).run_id).c_str() : "-",
              *last ? (**last).pushed_utc.c_str() : "-", design.c_str());
  return kExitOk;
}

// ---- nc reconcile ----

struct ReconcileOptions : NcOptions {
  std::string main_template_path;
};

int cmd_reconcile(const ReconcileOptions& o) {
  Result<RunStore> store = RunStore::open(o.paths.db());
  if (!store) return report_error(store.error());
  store->set_nc_dir(o.paths.nc());
  Result<MainProgramSource> main = main_source(o.main_template_path);
  if (!main) return report_error(main.error());
  Result<ReconcileReport> r = reconcile_all_pushes(*store, &*main);
  if (!r) return report_error(r.error());
  for (const std::string& m : r->messages) std::printf("%s\n", m.c_str());
  const auto repointed =
      std::count_if(r->stale_mains.begin(), r->stale_mains.end(), [](const StaleMain& m) { return m.repointed; });
  const auto put_back =
      std::count_if(r->files.begin(), r->files.end(), [](const PushFileMismatch& m) { return m.restored; });
  std::printf(
      "%d interrupted push(es) recorded, %d abandoned, %d temporary file(s) removed, %d main program(s) written "
      "again, %d other file(s) of a push written again\n",
      r->completed, r->abandoned, r->leftovers_removed, static_cast<int>(repointed), static_cast<int>(put_back));
  // A main program still coupling another table than its subprogram defines (the control grinds
  // that one), or a file of the push edited by hand: not in agreement.
  return repointed == static_cast<long>(r->stale_mains.size()) && put_back == static_cast<long>(r->files.size())
             ? kExitOk
             : kExitNcOutput;
}

// ---- nc pending, approve, reject ----

struct PendingOptions : NcOptions {
  bool all = false;
  int limit = 50;
};

int cmd_pending(const PendingOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  PendingQuery q;
  q.limit = o.limit;
  if (!o.all) q.status = PendingStatus::kPending;
  if (!o.program.empty()) {
    Result<std::string> file = resolve_program(*store, o);
    if (!file) return report_error(file.error());
    q.nc_file = *file;
  }
  Result<std::vector<PendingTable>> tables = store->list_pending(q);
  if (!tables) return report_error(tables.error());
  if (o.json_out) {
    json out = json::array();
    for (const PendingTable& t : *tables) {
      out.push_back(pending_table_json(t));
    }
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  // With --all, who decided and when: "anna 2026-12-05T10:00:00Z", a superseded table's
  // successor, "-" while it waits.
  std::printf("%5s  %8s  %-20s  %-16s  %-7s  %-10s  ", "id", "run", "created (UTC)", "program", "verdict", "status");
  if (o.all) std::printf("%-32s  ", "decided");
  std::printf("reason\n");
  for (const PendingTable& t : *tables) {
    // A gear's stroke names its gear run: "gear 3".
    const std::string run = t.gear_run_id != 0 ? "gear " + std::to_string(t.gear_run_id) : std::to_string(t.run_id);
    std::printf("%5lld  %8s  %-20s  %-16s  %-7s  %-10s  ", static_cast<long long>(t.id), run.c_str(),
                t.created_utc.c_str(), std::filesystem::path(t.nc_file).stem().string().c_str(),
                std::string(pending_verdict_name(t.verdict)).c_str(),
                std::string(pending_status_name(t.status)).c_str());
    if (o.all) {
      const std::string decided = t.status == PendingStatus::kPending ? "-"
                                  : t.status == PendingStatus::kSuperseded && t.superseded_by
                                      ? "by table " + std::to_string(*t.superseded_by) + " " + t.decided_utc
                                      : (t.decided_by.empty() ? "?" : t.decided_by) + " " + t.decided_utc;
      std::printf("%-32s  ", decided.c_str());
    }
    std::printf("%s\n", t.reason.c_str());
  }
  if (tables->empty()) std::printf(o.all ? "(no pending tables)\n" : "(no table waits for approval)\n");
  return kExitOk;
}

struct DecideOptions {
  DataPaths paths;
  std::int64_t id = 0;
  std::string by;
  std::string note;
  bool overwrite_edited = false;
  std::string main_template_path;  // approve only
};

int cmd_approve(const DecideOptions& o) {
  Result<RunStore> store = open_history(o.paths);
  if (!store) return report_error(store.error());
  const std::string by = person(o.by);
  Result<MainProgramSource> main = main_source(o.main_template_path);
  if (!main) return report_error(main.error());
  Result<PushOutcome> pushed = approve_pending(*store, o.id, by, o.note, o.overwrite_edited, *main);
  if (!pushed) return report_error(pushed.error());
  if (pushed->stroke) {
    std::printf("%s: stroke version %d written from gear run %lld (pending table %lld, approved by %s)%s\n",
                pushed->nc_file.c_str(), pushed->table_version, static_cast<long long>(pushed->gear_run_id),
                static_cast<long long>(o.id), by.c_str(),
                pushed->decision_recorded ? "" : "; it had stopped pending meanwhile, the push is recorded alone");
    return kExitOk;
  }
  std::printf("%s: table version %d written from run %lld (pending table %lld, approved by %s)%s\n",
              pushed->nc_file.c_str(), pushed->table_version, static_cast<long long>(pushed->run_id),
              static_cast<long long>(o.id), by.c_str(),
              pushed->decision_recorded ? "" : "; it had stopped pending meanwhile, the push is recorded alone");
  return kExitOk;
}

int cmd_reject(const DecideOptions& o) {
  Result<RunStore> store = open_history(o.paths);
  if (!store) return report_error(store.error());
  if (Status s = store->reject_pending(o.id, person(o.by), o.note); !s) return report_error(s.error());
  std::printf("pending table %lld rejected; the table in force stays\n", static_cast<long long>(o.id));
  return kExitOk;
}

void add_decide_options(CLI::App& cmd, DecideOptions& o) {
  add_data_options(cmd, o.paths);
  cmd.add_option("id", o.id, "Pending table id (see `nc pending`)")->required();
  cmd.add_option("--by", o.by, "Who decides [$USER]");
  cmd.add_option("--note", o.note, "Why, kept with the decision");
}

}  // namespace

void add_nc_commands(CLI::App& app, CommandAction& action) {
  CLI::App* nc =
      app.add_subcommand("nc", "Curve tables on the control: a new program, history, diff, rollback, approval.");
  nc->require_subcommand(1);
  add_nc_new_command(*nc, action);

  auto history = std::make_shared<HistoryOptions>();
  CLI::App* history_cmd = nc->add_subcommand("history", "Every table pushed, newest first: version, run, reason.");
  add_nc_options(*history_cmd, *history);
  history_cmd->add_option("--limit", history->limit, "Most pushes to show")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  history_cmd->add_flag("--json", history->json_out, "Print JSON");
  history_cmd->callback([&action, history] { action = [history] { return cmd_history(*history); }; });

  auto diff = std::make_shared<DiffOptions>();
  CLI::App* diff_cmd =
      nc->add_subcommand("diff", "Two table versions of a program: how X differs where the NC interpolates them.");
  add_nc_options(*diff_cmd, *diff);
  diff_cmd->add_option("a", diff->a, "First table version (see `nc history`)")->required();
  diff_cmd->add_option("b", diff->b, "Second table version")->required();
  diff_cmd->add_option("--threshold-um", diff->threshold_um, "List whole degrees differing by at least this")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  diff_cmd->add_flag("--json", diff->json_out, "Print JSON");
  diff_cmd->callback([&action, diff] { action = [diff] { return cmd_diff(*diff); }; });

  auto rollback = std::make_shared<RollbackOptions>();
  CLI::App* rollback_cmd = nc->add_subcommand(
      "rollback", "Push an earlier table version again, as a new version; the next run builds on its correction.");
  add_nc_options(*rollback_cmd, *rollback);
  rollback_cmd->add_option("version", rollback->version, "Table version to restore (see `nc history`)")->required();
  rollback_cmd->add_option("--by", rollback->by, "Who rolls back [$USER]");
  rollback_cmd->add_option("--main-template", rollback->main_template_path, kMainTemplateHelp);
  rollback_cmd->callback([&action, rollback] { action = [rollback] { return cmd_rollback(*rollback); }; });

  auto check = std::make_shared<NcOptions>();
  CLI::App* check_cmd = nc->add_subcommand(
      "check",
      "Is the program on disk the table last pushed? Reports a table edited by hand (exit status 2), a main "
      "program coupling another table than the one on the control, left by a cut push, and any other file of the "
      "push in force (main program, speed and Y subprograms) missing or not as that push wrote it (exit status "
      "5).");
  add_nc_options(*check_cmd, *check);
  check_cmd->callback([&action, check] { action = [check] { return cmd_check(*check); }; });

  auto reconcile = std::make_shared<ReconcileOptions>();
  CLI::App* reconcile_cmd = nc->add_subcommand(
      "reconcile",
      "Finish pushes that were interrupted (kill, power cut, full disk, locked database): a program the control "
      "holds is recorded as pushed, one it never got is abandoned, leftover temporary files of the table, its main "
      "program, speed and Y subprograms are removed, and a main program coupling another table than the one on "
      "the control is written again, as is any other file of the push in force that is missing or another push's "
      "(exit status 5 if one is left, or a file was edited by hand). Every push and measurement does this for its "
      "own program first.");
  add_data_options(*reconcile_cmd, reconcile->paths);
  reconcile_cmd->add_option("--main-template", reconcile->main_template_path, kMainTemplateHelp);
  reconcile_cmd->callback([&action, reconcile] { action = [reconcile] { return cmd_reconcile(*reconcile); }; });

  auto pending = std::make_shared<PendingOptions>();
  CLI::App* pending_cmd =
      nc->add_subcommand("pending", "Tables waiting for approval: held by compensation, or approval required.");
  add_nc_options(*pending_cmd, *pending);
  pending_cmd->add_flag("--all", pending->all, "Also those approved, rejected or superseded");
  pending_cmd->add_option("--limit", pending->limit, "Most to show")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  pending_cmd->add_flag("--json", pending->json_out, "Print JSON");
  pending_cmd->callback([&action, pending] { action = [pending] { return cmd_pending(*pending); }; });

  auto approve = std::make_shared<DecideOptions>();
  CLI::App* approve_cmd =
      nc->add_subcommand("approve", "Write a pending table to the control (atomically) and record who approved it.");
  add_decide_options(*approve_cmd, *approve);
  approve_cmd->add_option("--main-template", approve->main_template_path, kMainTemplateHelp);
  approve_cmd->add_flag("--overwrite-edited", approve->overwrite_edited,
                        "Overwrite the program even if it was edited by hand since the last push");
  approve_cmd->callback([&action, approve] { action = [approve] { return cmd_approve(*approve); }; });

  auto reject = std::make_shared<DecideOptions>();
  CLI::App* reject_cmd = nc->add_subcommand("reject", "Refuse a pending table; the table in force stays.");
  add_decide_options(*reject_cmd, *reject);
  reject_cmd->callback([&action, reject] { action = [reject] { return cmd_reject(*reject); }; });
}

}  // namespace gaugeloop
