// gear ...: the worm-wheel generating grinder's gearbox for a gear part (docs/gears.md).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "acquisition/gear_probe.h"
#include "acquisition/tcp_endpoint.h"
#include "cli/cli_common.h"
#include "cli/embedded_defaults.h"
#include "cli/gear_loop.h"
#include "compensation/gear_coupling.h"
#include "compensation/gear_identification.h"
#include "config/gear_file.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "core/text_file.h"
#include "job/gear_run.h"
#include "job/gear_stroke.h"
#include "job/measure_job.h"
#include "job/slide_files.h"
#include "nc_out/stroke_program.h"
#include "report/dfq.h"
#include "report/gear_characteristics.h"
#include "report/gear_report.h"
#include "report/run_json.h"
#include "report/spc.h"

namespace gaugeloop {
namespace {

struct CouplingOptions {
  std::string part_path;
  bool json = false;
};

int cmd_gear_coupling(const CouplingOptions& o) {
  Result<GearPartFile> gf = read_gear_part_file(o.part_path);
  if (!gf) return report_error(gf.error());
  const GearPart& p = gf->part;
  const GearCoupling k = gear_coupling(p);
  if (o.json) {
    print_json(nlohmann::json{{"part", gf->name},
                              {"nc_program", gf->nc_program},
                              {"s_bc", k.s_bc},
                              {"s_zc_deg_per_mm", k.s_zc_deg_per_mm},
                              {"s_yc_deg_per_mm", k.s_yc_deg_per_mm},
                              {"s_sim_c", k.s_sim_c},
                              {"setting_angle_deg", k.setting_angle_deg},
                              {"lead_angle_deg", k.lead_angle_deg},
                              {"worm_lead_mm", k.worm_lead_mm},
                              {"gear_pitch_diameter_mm", k.gear_pitch_diameter_mm},
                              {"transverse_pitch_mm", k.transverse_pitch_mm}});
    return kExitOk;
  }
  const GearGeometry& g = p.gear;
  std::printf("gear %s: module %.4g mm, %d teeth, pressure angle %.4g deg, helix %.4g deg %s, face %.4g mm\n",
              gf->name.c_str(), g.normal_module_mm, g.teeth, g.pressure_angle_deg, g.helix_angle_deg,
              g.helix_angle_deg == 0.0 ? "(spur)" : std::string(hand_name(g.hand)).c_str(), g.face_width_mm);
  std::printf("worm: %d start%s, pitch diameter %.4g mm, %s hand, lead angle %.6f deg, lead %.6f mm\n", p.worm.starts,
              p.worm.starts == 1 ? "" : "s", p.worm.pitch_diameter_mm, std::string(hand_name(p.worm.hand)).c_str(),
              k.lead_angle_deg, k.worm_lead_mm);
  std::printf("gear pitch diameter %.6f mm, transverse pitch %.6f mm; worm set at %.6f deg\n", k.gear_pitch_diameter_mm,
              k.transverse_pitch_mm, k.setting_angle_deg);
  std::printf("electronic gearbox, C following (degrees of C):\n");
  std::printf("  S_BC   %+.12f deg per deg of B\n", k.s_bc);
  std::printf("  S_ZC   %+.12f deg per mm of Z\n", k.s_zc_deg_per_mm);
  std::printf("  S_YC   %+.12f deg per mm of Y\n", k.s_yc_deg_per_mm);
  std::printf("  SIM1   %+.12f deg per deg of SIM1\n", k.s_sim_c);
  std::printf("compensation through SIM1: dSIM = S_YC e_Y + S_ZC e_Z + S_BC e_B - e_C (e: axis errors)\n");
  return kExitOk;
}

// What `gear stroke` and `gear correct` push with.
struct PushTargetOptions {
  DataPaths paths;
  std::string part_path;
  std::string main_template_path;
  bool overwrite_edited = false;
  double feed_mm_per_min = 300.0;
  double int_incr_per_mm = 10000.0;
  double int_incr_per_deg = 1000.0;
};

struct StrokeOptions : PushTargetOptions {
  std::string errors_path;
  std::string out_path;
};

struct CorrectOptions : PushTargetOptions {
  std::string lead_path;
  std::string machine = "grinder-1";
  std::string serial;
  std::string operator_name;
  std::string note;
  bool require_approval = false;
};

// Sets `s` up to push gf's stroke into <nc-dir>/<nc_program>.SPF, as a measurement pushes a
// cam's table: the database opened into `store` (and interrupted pushes reconciled), the main
// program from `main_template_path` or the built-in gear_main.mpf.
Status open_push_target(const DataPaths& paths, const std::string& main_template_path, const GearPartFile& gf,
                        GearStrokeSettings& s, std::optional<RunStore>& store) {
  s.part_name = gf.name;
  s.program_name = gf.nc_program;
  s.nc_file = std::filesystem::absolute(paths.nc() / (gf.nc_program + ".SPF")).lexically_normal();
  JobSettings js;
  js.db_path = paths.db();
  js.nc_dir = paths.nc();
  Result<RunStore> opened = open_store_for_push(js, s.nc_file);
  if (!opened) return opened.error();
  store.emplace(std::move(*opened));
  s.store = &*store;
  if (main_template_path.empty()) {
    s.main.gear_template_text = std::string(embedded::kGearMainTemplate);
    s.main.gear_template_name = "embedded:gear_main.mpf";
    return {};
  }
  Result<std::string> text = read_regular_file(main_template_path, "main program template");
  if (!text) return text.error();
  s.main.gear_template_text = std::move(*text);
  s.main.gear_template_name = main_template_path;
  return {};
}

// `o`'s grids, feed and overwrite flag in `s`.
void apply_push_options(const PushTargetOptions& o, GearStrokeSettings& s) {
  s.feed_mm_per_min = o.feed_mm_per_min;
  s.format.z_increments_per_mm = o.int_incr_per_mm;
  s.format.sim_increments_per_deg = o.int_incr_per_deg;
  s.overwrite_edited = o.overwrite_edited;
}

int cmd_gear_stroke(const StrokeOptions& o) {
  Result<GearPartFile> gf = read_gear_part_file(o.part_path);
  if (!gf) return report_error(gf.error());
  Result<StrokeAxisErrors> errors = read_axis_errors_csv(o.errors_path);
  if (!errors) return report_error(errors.error());
  GearStrokeSettings s;
  apply_push_options(o, s);
  std::optional<RunStore> store;
  if (!o.out_path.empty()) {
    s.part_name = gf->name;
    s.program_name = gf->nc_program;
    s.out_file = o.out_path;
  } else if (Status t = open_push_target(o.paths, o.main_template_path, *gf, s, store); !t) {
    return report_error(t.error());
  }
  Result<GearStrokeReport> r = write_gear_stroke(gf->part, *errors, s);
  if (!r) return report_error(r.error());
  std::printf("stroke of %s: %zu spline points from Z %.3f to %.3f mm, SIM1 up to %.6f deg (%s)\n", gf->name.c_str(),
              r->points.size(), r->points.front().z_mm, r->points.back().z_mm, r->sim_max_abs_deg,
              o.errors_path.c_str());
  std::printf("  %-10s %12s %12s %12s %12s %12s\n", "Z mm", "e_Y um", "e_Z um", "e_B deg", "e_C deg", "SIM1 deg");
  for (const StrokeSimPoint& p : r->points) {
    std::printf("  %-10.3f %12.3f %12.3f %12.6f %12.6f %12.6f\n", p.z_mm, p.errors.y_mm * 1000.0,
                p.errors.z_mm * 1000.0, p.errors.b_deg, p.errors.c_deg, p.sim_deg);
  }
  if (r->version == 0) {
    std::printf("written %s, read back (not pushed: no history, no main program)\n", r->written.string().c_str());
    std::printf("the main program couples C to B, Z, Y and SIM1 with:\n%s\n", r->coupling_lines.c_str());
    return kExitOk;
  }
  std::printf("pushed %s as stroke version %d, read back; main program %s couples C to B, Z, Y and SIM1 with:\n%s\n",
              r->written.string().c_str(), r->version, main_program_path(r->written).string().c_str(),
              r->coupling_lines.c_str());
  return kExitOk;
}

// One trace's figures as `gear correct` and `gear runs show` print them.
void print_trace_table(const std::vector<GearTraceRecord>& traces) {
  std::printf("  %5s  %-6s  %10s  %10s  %10s  %6s\n", "gap", "flank", "F_beta um", "f_f_beta", "f_H_beta", "class");
  for (const GearTraceRecord& t : traces) {
    std::printf("  %5d  %-6s  %10.2f  %10.2f  %+10.2f  %6d\n", t.gap, t.flank.c_str(), t.total_um, t.form_um,
                t.slope_um, t.tolerance_class);
  }
}

// "in (class 5 asked: F_beta within 20.50 um)", with the profile's F_alpha when the profiles
// were measured; "not judged (the part names no tolerance_class)".
std::string gear_verdict_text(const GearRunRecord& r) {
  if (!r.required_class) return "not judged (the part names no tolerance_class)";
  std::string asked = "F_beta within " + format_fixed(r.total_tolerance_um.value_or(0.0), 2) + " um";
  if (r.profile_tolerance_um) asked += ", F_alpha within " + format_fixed(*r.profile_tolerance_um, 2) + " um";
  return std::string(r.verdict == Verdict::kIn ? "in" : "out") + " (class " + std::to_string(*r.required_class) +
         " asked: " + asked + ")";
}

// Keeps a measured gear as a gear run (judged against the part's class, ground with the stroke
// in force) and, with `correct`, corrects that stroke from it: pushed, or kept for approval.
// `source` names where the traces came from. Nothing is written when a trace cannot be judged;
// the gear run is kept when the correction is refused.
int keep_and_correct(const CorrectOptions& o, const GearPartFile& gf, const std::vector<LeadTrace>& traces,
                     const std::string& source, bool correct) {
  GearStrokeSettings s;
  apply_push_options(o, s);
  GearRunOrigin origin;
  origin.part_name = gf.name;
  origin.required_class = gf.tolerance_class;
  origin.machine = o.machine;
  origin.source = source;
  origin.serial = o.serial;
  origin.operator_name = o.operator_name;
  origin.note = o.note;
  // Every trace judged before anything is written: one too short for ISO 1328-1 is refused.
  Result<GearRunRecord> judged = judge_gear(gf.part, traces, origin);
  if (!judged) return report_error(make_error(judged.error().code, source + ": " + judged.error().message));
  std::optional<RunStore> store;
  if (Status t = open_push_target(o.paths, o.main_template_path, gf, s, store); !t) return report_error(t.error());
  // The gear is kept first, ground with the stroke in force if there is one, so that a refused
  // correction loses no measurement.
  Result<StrokeInForce> in_force = stroke_in_force(*store, s.nc_file, "");
  if (in_force) judged->ground_with_version = in_force->version;
  judged->nc_file = s.nc_file.string();
  Result<std::int64_t> id = store->insert_gear_run(*judged);
  if (!id) return report_error(id.error());
  std::printf("gear run %lld of %s: lead as measured (%s; ISO 1328-1 over %.2f .. %.2f mm):\n",
              static_cast<long long>(*id), gf.name.c_str(), source.c_str(), judged->traces.front().from_mm,
              judged->traces.front().to_mm);
  print_trace_table(judged->traces);
  std::printf("F_beta %.2f um at worst (class %d): %s\n", judged->total_max_um, judged->tolerance_class,
              gear_verdict_text(*judged).c_str());
  if (!correct) return kExitOk;
  s.require_approval = o.require_approval;
  s.gear_run_id = *id;
  Result<GearCorrection> c = correct_gear_stroke(gf.part, traces, "gear run " + std::to_string(*id) + ", " + source, s);
  if (!c) {
    std::fprintf(stderr, "gear run %lld is stored; no stroke was pushed from it\n", static_cast<long long>(*id));
    return report_error(c.error());
  }
  const MeshIdentification& m = c->identification;
  const std::optional<int> pushed = c->pushed.version > 0 ? std::optional<int>(c->pushed.version) : std::nullopt;
  if (Status r = store->record_gear_correction(*id, m.residual_rms_um, pushed); !r) return report_error(r.error());
  int held = 0;
  for (const bool seen : m.observed) held += seen ? 0 : 1;
  std::printf(
      "mesh error identified at %zu spline points (%d beyond the face held), %d traces, %d samples: residual "
      "%.2f um RMS, rank %d of %d (the mean is tooth thickness, not lead)\n",
      m.z_mm.size(), held, m.traces, m.samples, m.residual_rms_um, m.rank, m.unknowns);
  std::printf(
      "the lead sees only dSIM, the sum of the axes' errors through the gearbox: Y, Z, B and C are not "
      "separable from it\n");
  std::printf("  %-10s %14s %14s\n", "Z mm", "mesh deg", "SIM1 deg");
  for (std::size_t k = 0; k < m.z_mm.size(); ++k) {
    std::printf("  %-10.3f %14.6f %14.6f%s\n", m.z_mm[k], m.mesh_deg[k], c->pushed.points[k].sim_deg,
                m.observed[k] ? "" : "  (held)");
  }
  if (c->pushed.pending_id != 0) {
    std::printf(
        "the corrected stroke waits for approval as pending table %lld (from version %d); nothing was written to "
        "%s: `gaugeloop nc approve %lld --by NAME %s` pushes it, `nc reject` drops it\n",
        static_cast<long long>(c->pushed.pending_id), c->from_version, s.nc_file.string().c_str(),
        static_cast<long long>(c->pushed.pending_id), o.paths.where().c_str());
    return kExitOk;
  }
  std::printf("pushed %s as stroke version %d (from version %d), read back; main program %s\n",
              c->pushed.written.string().c_str(), c->pushed.version, c->from_version,
              main_program_path(c->pushed.written).string().c_str());
  return kExitOk;
}

int cmd_gear_correct(const CorrectOptions& o) {
  Result<GearPartFile> gf = read_gear_part_file(o.part_path);
  if (!gf) return report_error(gf.error());
  Result<std::vector<LeadTrace>> traces = read_lead_traces_csv(o.lead_path);
  if (!traces) return report_error(traces.error());
  return keep_and_correct(o, *gf, *traces, "lead traces " + o.lead_path, true);
}

struct ProbeMeasureOptions : CorrectOptions {
  std::string gauge;
  int base_address = 0;
  std::vector<int> gaps = {1, 20, 40, 60};
  double step_mm = 0.5;
  int point_timeout_ms = 5000;
  bool correct = false;
};

int cmd_gear_measure(const ProbeMeasureOptions& o) {
  Result<GearPartFile> gf = read_gear_part_file(o.part_path);
  if (!gf) return report_error(gf.error());
  for (int gap : o.gaps) {
    if (gap < 1 || gap > gf->part.gear.teeth) {
      return report_error(make_error(ErrorCode::kInvalidInput, "--gaps: gap " + std::to_string(gap) +
                                                                   " is not one of " + gf->name + "'s gaps 1 to " +
                                                                   std::to_string(gf->part.gear.teeth)));
    }
  }
  Result<TcpEndpoint> endpoint = parse_tcp_endpoint(o.gauge);
  if (!endpoint) return report_error(make_error(ErrorCode::kInvalidInput, "--gauge " + endpoint.error().message));
  GearProbeSettings ps;
  ps.link.host = endpoint->host;
  ps.link.port = endpoint->port;
  ps.link.response_timeout = std::chrono::milliseconds(1000);
  ps.base_address = o.base_address;
  ps.point_timeout = std::chrono::milliseconds(o.point_timeout_ms);
  GearProbe probe(ps);
  if (Status c = probe.connect(); !c) return report_error(c.error());
  Result<std::vector<LeadTrace>> traces = probe.measure_lead(o.gaps, lead_heights_mm(gf->part.gear, o.step_mm));
  if (!traces) return report_error(traces.error());
  return keep_and_correct(o, *gf, *traces, "flank probe " + probe.address(), o.correct);
}

struct GearRunsOptions {
  DataPaths paths;
  GearRunQuery query;
  std::string since;
  std::string until;
  std::string verdict;
  std::int64_t id = 0;
  bool json = false;
};

int cmd_gear_runs_list(GearRunsOptions o) {
  if (Status t = set_time_bounds(o.since, o.until, o.query.since_utc, o.query.until_utc); !t) {
    return report_error(t.error());
  }
  if (!o.verdict.empty()) {
    o.query.verdict = verdict_from_name(o.verdict);
    if (!o.query.verdict) {
      return report_error(
          make_error(ErrorCode::kInvalidInput, "--verdict '" + o.verdict + "' is not one of in, out, not_judged"));
    }
  }
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<std::vector<StoredGearRun>> runs = store->list_gear_runs(o.query);
  if (!runs) return report_error(runs.error());
  if (o.json) {
    nlohmann::json j = nlohmann::json::array();
    for (const StoredGearRun& g : *runs) j.push_back(gear_run_json(g, false));
    print_json(j);
    return kExitOk;
  }
  if (runs->empty()) {
    std::printf("no gear runs (in %s)\n", store->path().string().c_str());
    return kExitOk;
  }
  std::printf("%6s  %-20s  %-12s  %-20s  %-12s  %9s  %5s  %-10s  %6s  %6s\n", "id", "started (UTC)", "part", "machine",
              "serial", "F_beta um", "class", "verdict", "ground", "pushed");
  for (const StoredGearRun& g : *runs) {
    const GearRunRecord& r = g.record;
    std::printf("%6lld  %-20s  %-12s  %-20s  %-12s  %9.2f  %5d  %-10s  %6s  %6s\n", static_cast<long long>(g.id),
                r.started_utc.c_str(), r.part.c_str(), r.machine.c_str(), r.serial.empty() ? "-" : r.serial.c_str(),
                r.total_max_um, r.tolerance_class, std::string(verdict_name(r.verdict)).c_str(),
                r.ground_with_version ? ("v" + std::to_string(*r.ground_with_version)).c_str() : "-",
                g.pushed_version ? ("v" + std::to_string(*g.pushed_version)).c_str() : "-");
  }
  return kExitOk;
}

struct GearExportOptions {
  DataPaths paths;
  GearRunQuery query;
  std::string since;
  std::string until;
  std::string format = "dfq";
  std::string operation = "gear grinding";
  std::string out_path;
};

// Every gear run of a range, far more than a plant keeps of one gear.
constexpr int kMaxExportedGearRuns = 1000000;

// The gear runs `query` selects (its time bounds from since/until), each with its traces, as
// characteristics, oldest first. kNotFound, saying where to look, when none match.
Result<std::vector<RunCharacteristics>> selected_gear_runs(const DataPaths& paths, GearRunQuery query,
                                                           const std::string& since, const std::string& until) {
  if (Status t = set_time_bounds(since, until, query.since_utc, query.until_utc); !t) return t.error();
  Result<RunStore> store = open_history_read_only(paths);
  if (!store) return store.error();
  Result<std::vector<StoredGearRun>> listed = store->list_gear_runs(query);
  if (!listed) return listed.error();
  if (listed->empty()) {
    return make_error(ErrorCode::kNotFound, "no gear runs match in " + store->path().string() +
                                                "; `gaugeloop gear runs list " + paths.where() +
                                                "` shows what is stored");
  }
  std::vector<RunCharacteristics> runs;
  for (auto g = listed->rbegin(); g != listed->rend(); ++g) {
    Result<StoredGearRun> full = store->load_gear_run(g->id);
    if (!full) return full.error();
    runs.push_back(gear_run_characteristics(*full));
  }
  return runs;
}

int cmd_gear_runs_export(GearExportOptions o) {
  o.query.limit = kMaxExportedGearRuns;
  Result<std::vector<RunCharacteristics>> selected = selected_gear_runs(o.paths, o.query, o.since, o.until);
  if (!selected) return report_error(selected.error());
  const std::vector<RunCharacteristics>& runs = *selected;
  DfqOptions options;
  options.operation = o.operation;
  Result<std::string> dfq = write_dfq(runs, options);
  if (!dfq) return report_error(dfq.error());
  if (o.out_path.empty()) {
    std::fwrite(dfq->data(), 1, dfq->size(), stdout);
    return kExitOk;
  }
  if (Status w = write_file_atomically(o.out_path, *dfq); !w) return report_file_error(w.error());
  std::printf("%zu gear run%s exported to %s\n", runs.size(), runs.size() == 1 ? "" : "s", o.out_path.c_str());
  return kExitOk;
}

struct GearSpcOptions {
  DataPaths paths;
  GearRunQuery query;
  std::string since;
  std::string until;
  bool json = false;
};

int cmd_gear_runs_spc(const GearSpcOptions& o) {
  Result<std::vector<RunCharacteristics>> runs = selected_gear_runs(o.paths, o.query, o.since, o.until);
  if (!runs) return report_error(runs.error());
  const std::vector<SpcFigure> figures = spc_figures(*runs);
  if (o.json) {
    nlohmann::json out{{"part", o.query.part},
                       {"machine", o.query.machine.empty() ? nlohmann::json() : nlohmann::json(o.query.machine)},
                       {"runs", runs->size()},
                       {"first_started_utc", runs->front().run.started_utc},
                       {"last_started_utc", runs->back().run.started_utc},
                       {"characteristics", nlohmann::json::array()}};
    for (const SpcFigure& f : figures) out["characteristics"].push_back(spc_figure_json(f));
    print_json(out);
    return kExitOk;
  }
  std::printf("SPC of the gears of %s%s: %zu gear run%s, %s to %s (UTC)\n", o.query.part.c_str(),
              o.query.machine.empty() ? "" : (" on " + o.query.machine).c_str(), runs->size(),
              runs->size() == 1 ? "" : "s", runs->front().run.started_utc.c_str(),
              runs->back().run.started_utc.c_str());
  std::fputs(spc_table_text(figures).c_str(), stdout);
  return kExitOk;
}

struct GearReportOptions {
  DataPaths paths;
  std::int64_t id = 0;
  std::string out_path;
};

int cmd_gear_runs_report(const GearReportOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<StoredGearRun> g = store->load_gear_run(o.id);
  if (!g) return report_error(g.error());
  const std::string out = o.out_path.empty() ? "gear_run" + std::to_string(o.id) + ".pdf" : o.out_path;
  if (Status w = write_gear_report(*g, out); !w) return report_file_error(w.error());
  std::printf("gear report of gear run %lld written to %s\n", static_cast<long long>(o.id), out.c_str());
  return kExitOk;
}

int cmd_gear_runs_show(const GearRunsOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<StoredGearRun> g = store->load_gear_run(o.id);
  if (!g) return report_error(g.error());
  if (o.json) {
    print_json(gear_run_json(*g, true));
    return kExitOk;
  }
  const GearRunRecord& r = g->record;
  std::printf("gear run %lld: part %s on %s, measured %s from %s\n", static_cast<long long>(g->id), r.part.c_str(),
              r.machine.c_str(), r.started_utc.c_str(), r.source.c_str());
  if (!r.serial.empty() || !r.operator_name.empty()) {
    std::printf("serial %s, operator %s\n", r.serial.empty() ? "-" : r.serial.c_str(),
                r.operator_name.empty() ? "-" : r.operator_name.c_str());
  }
  if (!r.note.empty()) std::printf("note: %s\n", r.note.c_str());
  std::printf("ground from %s, stroke version %s\n", r.nc_file.c_str(),
              r.ground_with_version ? std::to_string(*r.ground_with_version).c_str() : "not known");
  std::printf("lead, ISO 1328-1 over %.2f .. %.2f mm:\n", r.traces.front().from_mm, r.traces.front().to_mm);
  print_trace_table(r.traces);
  std::printf("F_beta %.2f um at worst, %.2f mean (class %d); f_f_beta %.2f um mean, |f_H_beta| %.2f um mean\n",
              r.total_max_um, r.total_mean_um, r.tolerance_class, r.form_mean_um, r.slope_mean_abs_um);
  if (r.profiles.empty()) {
    std::printf("profile: not measured (the traces are leads only)\n");
  } else {
    std::printf("profile at the face's middle, ISO 1328-1 over roll lengths %.2f .. %.2f mm:\n",
                r.profiles.front().from_roll_mm, r.profiles.front().to_roll_mm);
    std::printf("  %5s  %-6s  %10s  %10s  %10s  %6s\n", "gap", "flank", "F_alpha um", "f_f_alpha", "f_H_alpha",
                "class");
    for (const GearProfileRecord& p : r.profiles) {
      std::printf("  %5d  %-6s  %10.2f  %10.2f  %+10.2f  %6d\n", p.gap, p.flank.c_str(), p.total_um, p.form_um,
                  p.slope_um, p.tolerance_class);
    }
    const GearProfileFigures f = gear_profile_figures(r);
    std::printf("F_alpha %.2f um at worst, %.2f mean (class %d); f_f_alpha %.2f um mean, |f_H_alpha| %.2f um mean\n",
                f.total_max_um, f.total_mean_um, f.tolerance_class, f.form_mean_um, f.slope_mean_abs_um);
  }
  std::printf("verdict: %s\n", gear_verdict_text(r).c_str());
  if (g->pushed_version) {
    std::printf("stroke version %d was pushed from it (mesh error fit: residual %.2f um RMS)\n", *g->pushed_version,
                g->mesh_residual_rms_um.value_or(0.0));
  } else if (g->mesh_residual_rms_um) {
    std::printf(
        "a stroke was corrected from it (mesh error fit: residual %.2f um RMS) and not pushed: it waits for approval "
        "or was rejected (`gaugeloop nc pending --all`)\n",
        *g->mesh_residual_rms_um);
  } else {
    std::printf("no stroke was pushed from it\n");
  }
  return kExitOk;
}

struct IdentifyOptions {
  DataPaths paths;
  std::string part_path;
  std::string lead_path;
  std::string ballbar_path;
  double ballbar_radius_mm = 100.0;
  std::string terms;
  std::string out_path;
  bool uncompensated = false;
};

// The stroke the measured gear was ground with: the one in force in the history, or none.
Result<std::vector<StrokeSimPoint>> ground_with(const IdentifyOptions& o, const GearPartFile& gf) {
  if (o.uncompensated) return std::vector<StrokeSimPoint>{};
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return store.error();
  Result<StrokeInForce> s = stroke_in_force(
      *store, std::filesystem::absolute(o.paths.nc() / (gf.nc_program + ".SPF")).lexically_normal(),
      "the SIM1 the gear was ground with is not known; if it was ground without a stroke from gaugeloop, say "
      "--uncompensated");
  if (!s) return s.error();
  return std::move(s->points);
}

int cmd_gear_identify(const IdentifyOptions& o) {
  Result<GearPartFile> gf = read_gear_part_file(o.part_path);
  if (!gf) return report_error(gf.error());
  Result<std::vector<ErrorTerm>> terms = parse_error_terms(o.terms);
  if (!terms) return report_error(terms.error());
  Result<std::vector<LeadTrace>> traces = read_lead_traces_csv(o.lead_path);
  if (!traces) return report_error(traces.error());
  std::optional<BallbarCircle> ballbar;
  if (!o.ballbar_path.empty()) {
    Result<BallbarCircle> b = read_ballbar_csv(o.ballbar_path, o.ballbar_radius_mm);
    if (!b) return report_error(b.error());
    ballbar = std::move(*b);
  }
  Result<std::vector<StrokeSimPoint>> sim = ground_with(o, *gf);
  if (!sim) return report_error(sim.error());
  const GearCoupling k = gear_coupling(gf->part);
  Result<AxisIdentification> id =
      identify_axis_errors(k, base_radius_mm(gf->part.gear), *terms, *traces, *sim, ballbar ? &*ballbar : nullptr);
  if (!id) return report_error(id.error());
  std::printf("%s: %d lead samples (%zu traces)%s, %zu terms; condition %.3g\n", gf->name.c_str(), id->lead_samples,
              traces->size(), ballbar ? (", " + std::to_string(id->ballbar_samples) + " ballbar points").c_str() : "",
              id->terms.size(), id->condition);
  std::printf("  %-22s %16s %12s\n", "term", "value", "phase deg");
  for (const IdentifiedTerm& t : id->terms) {
    const bool linear_axis = t.term.axis == 'Y' || t.term.axis == 'Z';
    const std::string unit = t.term.kind == ErrorTermKind::kLinear ? (linear_axis ? " um/mm" : " deg/mm")
                             : t.term.kind == ErrorTermKind::kBow  ? (linear_axis ? " um/mm2" : " deg/mm2")
                                                                   : (linear_axis ? " um" : " deg");
    const double value = linear_axis ? t.value * 1000.0 : t.value;
    std::printf("  %-22s %16.6g%-7s", t.term.name().c_str(), value, unit.c_str());
    if (t.term.kind == ErrorTermKind::kPeriodic) std::printf(" %8.2f", t.phase_rad * 180.0 / 3.14159265358979323846);
    std::printf("\n");
  }
  std::printf("residual: lead %.3f um RMS", id->lead_residual_rms_um);
  if (ballbar) std::printf(", ballbar %.3f um RMS", id->ballbar_residual_rms_um);
  std::printf("\n");
  if (o.out_path.empty()) return kExitOk;
  // The model along the stroke, in the table `gear stroke --errors` reads.
  std::string csv = "# " + gf->name + ": axis errors identified from " + o.lead_path +
                    (ballbar ? " and " + o.ballbar_path : std::string()) + " (" + o.terms + ")\n" +
                    "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg\n";
  for (const double z : stroke_spline_points_mm(gf->part.stroke)) {
    const AxisErrors e = id->at(z);
    csv += format_fixed(z, 4) + "," + format_fixed(e.y_mm * 1000.0, 4) + "," + format_fixed(e.z_mm * 1000.0, 4) + "," +
           format_fixed(e.b_deg, 7) + "," + format_fixed(e.c_deg, 7) + "\n";
  }
  if (Status w = write_file_atomically(o.out_path, csv); !w) return report_file_error(w.error());
  std::printf("written %s: the errors along the stroke, for `gaugeloop gear stroke --errors`\n", o.out_path.c_str());
  return kExitOk;
}

// The options `gear stroke` and `gear correct` share: where and how the stroke is pushed.
void add_push_target_options(CLI::App& cmd, PushTargetOptions& o) {
  cmd.add_option("--part", o.part_path, "Gear part file (TOML with [gear])")->required();
  add_data_options(cmd, o.paths);
  cmd.add_option("--nc-dir", o.paths.nc_dir, "Directory the stroke program is pushed to [<data-dir>/nc]");
  cmd.add_option("--main-template", o.main_template_path,
                 "Main program template: must hold {{gearbox_coupling}} before the call of {{program_name}} "
                 "[built-in examples/sinumerik/gear_main.mpf]");
  cmd.add_flag("--overwrite-edited", o.overwrite_edited,
               "Overwrite a stroke program on the control that was edited by hand (it is refused otherwise)");
  cmd.add_option("--feed-mm-per-min", o.feed_mm_per_min, "Stroke feed along Z")->capture_default_str();
  cmd.add_option("--int-incr-per-mm", o.int_incr_per_mm, "The control's MD10200 (Z's grid)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e6));
  cmd.add_option("--int-incr-per-deg", o.int_incr_per_deg,
                 "The control's MD10210 (SIM1's grid; the control's default 1000 puts C back to 0.0005 deg)")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e6));
}

}  // namespace

int run_gear_demo(const GearDemoOptions& o) {
  Result<GearPartFile> gf = read_gear_part_file(o.part_path);
  if (!gf) return report_error(gf.error());
  GearLoopSettings ls;
  ls.part = *gf;
  ls.machine = seeded_gear_machine(o.machine_seed);
  ls.iterations = o.iterations;
  GearStrokeSettings& s = ls.stroke;
  s.format.z_increments_per_mm = o.z_increments_per_mm;
  // A generating grinder's rotary axes are set finer than the control's default 1000 per degree.
  s.format.sim_increments_per_deg = 100000.0;
  std::optional<RunStore> store;
  if (Status t = open_push_target(o.paths, "", *gf, s, store); !t) return report_error(t.error());
  const GearCoupling k = gear_coupling(gf->part);
  const GearMachineErrors& m = ls.machine;
  std::printf("virtual gear grinder: %s, %d teeth, module %.4g mm, helix %.4g deg, face %.4g mm; machine seed %llu\n",
              gf->name.c_str(), gf->part.gear.teeth, gf->part.gear.normal_module_mm, gf->part.gear.helix_angle_deg,
              gf->part.gear.face_width_mm, static_cast<unsigned long long>(o.machine_seed));
  std::printf(
      "  axis errors over the stroke: Y bow %.1f um, Z screw %.1f um / %.1f mm, B drift %.4f deg, C drive %.4f deg / "
      "%.1f mm; checker noise %.1f um\n",
      std::abs(m.y_mm.bow_per_mm2) * 15.0 * 15.0 * 1000.0, m.z_mm.slow * 1000.0, m.z_mm.slow_pitch_mm,
      std::abs(m.b_deg.linear_per_mm) * 30.0, m.c_deg.slow, m.c_deg.slow_pitch_mm, m.checker_noise_um);
  std::printf("  gearbox: S_BC %+.9f, S_ZC %+.9f deg/mm, S_YC %+.9f deg/mm; the checker measures gaps", k.s_bc,
              k.s_zc_deg_per_mm, k.s_yc_deg_per_mm);
  for (int gap : ls.gaps) std::printf(" %d", gap);
  std::printf(", both flanks, every %.1f mm\n", ls.lead_step_mm);
  std::fflush(stdout);
  auto on_gear = [](const GearLoopIteration& g) {
    std::printf(
        "gear %d (stroke version %d, gear run %lld): F_beta %.2f um mean, %.2f max (ISO 1328-1 class %d, %s); "
        "f_f_beta %.2f, |f_H_beta| %.2f um; as ground F_beta %.2f um\n",
        g.iteration, g.ground_from_version, static_cast<long long>(g.gear_run_id), g.measured.total_mean_um,
        g.measured.total_max_um, g.measured.tolerance_class, std::string(verdict_name(g.measured.verdict)).c_str(),
        g.measured.form_mean_um, g.measured.slope_mean_abs_um, g.ground.total_mean_um);
    std::printf("  profile at the face's middle: F_alpha %.2f um mean, %.2f max; f_f_alpha %.2f, |f_H_alpha| %.2f um\n",
                g.profile.total_mean_um, g.profile.total_max_um, g.profile.form_mean_um, g.profile.slope_mean_abs_um);
    if (g.identified) {
      std::printf(
          "  mesh error identified at %zu spline points (%d traces, %d samples, residual %.2f um RMS); "
          "stroke version %d pushed, SIM1 up to %.5f deg\n",
          g.identified->z_mm.size(), g.identified->traces, g.identified->samples, g.identified->residual_rms_um,
          g.pushed_version, g.sim_max_abs_deg);
    }
    std::fflush(stdout);
  };
  // The slides first, as a shop would: a ZY ballbar, the tables fitted to it, the ballbar again.
  const SlideErrors slides = seeded_slides(o.machine_seed);
  Result<SlideRound> round = run_slide_round(slides, *store, s.nc_file.parent_path(), SlideTableLayout{},
                                             "ZY ballbar of the virtual gear grinder");
  if (!round) return report_error(round.error());
  print_ballbar_figures("ZY ballbar before (radius 100 mm, 1000 mm/min)", round->before);
  print_slide_identification(round->identified);
  std::printf("  slide tables written: %s, %s\n",
              slide_file(s.nc_file.parent_path(), SlideTableKind::kLeadscrew).string().c_str(),
              slide_file(s.nc_file.parent_path(), SlideTableKind::kInterpolatory).string().c_str());
  print_ballbar_figures("ZY ballbar after", round->after);
  std::printf("ballbar roundness %.1f -> %.1f um (%.1f times), position error %.1f -> %.1f um\n",
              round->before.roundness_um, round->after.roundness_um,
              round->before.roundness_um / std::max(1e-9, round->after.roundness_um), round->before.position_error_um,
              round->after.position_error_um);
  std::fflush(stdout);
  Result<std::vector<GearLoopIteration>> r = run_gear_loop(ls, on_gear);
  if (!r) return report_error(r.error());
  const GearLoopIteration& a = r->front();
  const GearLoopIteration& b = r->back();
  std::printf(
      "lead F_beta (mean of %zu flanks): %.2f -> %.2f um measured (%.1f times), %.2f -> %.2f um as ground; "
      "class %d -> %d\n",
      ls.gaps.size() * 2, a.measured.total_mean_um, b.measured.total_mean_um,
      a.measured.total_mean_um / std::max(1e-9, b.measured.total_mean_um), a.ground.total_mean_um,
      b.ground.total_mean_um, a.measured.tolerance_class, b.measured.tolerance_class);
  std::printf(
      "profile F_alpha (mean of %zu flanks, face middle): %.2f -> %.2f um: SIM1 turns C along the stroke, which "
      "the profile sees as tooth thickness; what is left is the worm's once-per-turn error and the checker's noise\n",
      ls.gaps.size() * 2, a.profile.total_mean_um, b.profile.total_mean_um);
  std::printf(
      "the lead sees only the sum of the axes' errors through the gearbox (dSIM): Y, Z, B and C are not "
      "separable from it\n");
  std::printf("stroke program %s, main program %s\n", s.nc_file.string().c_str(),
              main_program_path(s.nc_file).string().c_str());
  std::printf("gear runs %lld to %lld kept: `gaugeloop gear runs list %s`\n", static_cast<long long>(a.gear_run_id),
              static_cast<long long>(b.gear_run_id), o.paths.where().c_str());
  return kExitOk;
}

void add_gear_commands(CLI::App& app, CommandAction& action) {
  CLI::App* gear = app.add_subcommand(
      "gear", "Gears ground by a worm wheel on a generating grinder: the electronic gearbox (docs/gears.md)");
  gear->require_subcommand(1);
  auto o = std::make_shared<CouplingOptions>();
  CLI::App* cmd = gear->add_subcommand(
      "coupling",
      "Print the gearbox's coupling factors for a gear part (C following B, Z, Y and the virtual axis SIM1), the "
      "worm's setting angle and lead, derived from the generating motion");
  cmd->add_option("--part", o->part_path, "Gear part file (TOML with [gear]), e.g. examples/gear_71.toml")->required();
  cmd->add_flag("--json", o->json, "Print the factors as JSON");
  cmd->callback([&action, o] { action = [o] { return cmd_gear_coupling(*o); }; });

  auto so = std::make_shared<StrokeOptions>();
  CLI::App* stroke = gear->add_subcommand(
      "stroke",
      "Write the stroke program for the axes' errors along the stroke: Z through the spline points, SIM1 at each "
      "where it puts the gear back in mesh (dSIM = S_YC e_Y + S_ZC e_Z + S_BC e_B - e_C). Pushed to "
      "<nc-dir>/<nc_program>.SPF as a measurement pushes a cam's table (version, history, hand-edit check, "
      "`nc rollback`), with <nc_program>_MAIN.MPF coupling C to B, Z, Y and SIM1; or, with --out, written to a "
      "file alone. Read back either way");
  add_push_target_options(*stroke, *so);
  stroke
      ->add_option("--errors", so->errors_path,
                   "Axis errors along the stroke, CSV: z_mm, y_error_um, z_error_um, b_error_deg, c_error_deg")
      ->required();
  stroke
      ->add_option("--out", so->out_path,
                   "Write the stroke program to this file alone: not pushed, no history, no main program")
      ->excludes("--nc-dir")
      ->excludes("--main-template")
      ->excludes("--overwrite-edited");
  stroke->callback([&action, so] { action = [so] { return cmd_gear_stroke(*so); }; });

  auto co = std::make_shared<CorrectOptions>();
  CLI::App* correct = gear->add_subcommand(
      "correct",
      "Correct the stroke in force from a measured gear: read the lead traces a gear checker exported (CSV: gap, "
      "flank, z_mm, deviation_um), report ISO 1328-1's helix deviations of each, identify the gearbox's mesh error "
      "at the stroke's spline points by least squares, and push the stroke in force less it as the next version. The "
      "measured gear is kept first, as a gear run (`gear runs`), judged against the part's tolerance_class");
  add_push_target_options(*correct, *co);
  correct->add_option("--lead", co->lead_path, "Lead traces, CSV: gap, flank (left/right), z_mm, deviation_um")
      ->required();
  correct->add_option("--machine", co->machine, "The grinder that ground the gear, stored with the gear run")
      ->capture_default_str();
  correct->add_option("--serial", co->serial, "Serial number of the measured gear (at most 64 characters)");
  correct->add_option("--operator", co->operator_name, "Who measured it (at most 64 characters)");
  correct->add_option("--note", co->note, "A note stored with the gear run");
  correct->add_flag("--require-approval", co->require_approval,
                    "Keep the corrected stroke as a pending table until a person approves it (`nc approve ID`) "
                    "instead of pushing it");
  correct->callback([&action, co] { action = [co] { return cmd_gear_correct(*co); }; });

  auto mo = std::make_shared<ProbeMeasureOptions>();
  CLI::App* measure = gear->add_subcommand(
      "measure",
      "Measure a gear on the grinder with its flank probe over Modbus TCP (the gear probe block, docs/gears.md): the "
      "lead of the gaps asked, both flanks, across the face; keep it as a gear run judged against the part's "
      "tolerance_class; with --correct, correct the stroke in force from it as `gear correct` does");
  add_push_target_options(*measure, *mo);
  measure->add_option("--gauge", mo->gauge, "The machine's Modbus server, HOST:PORT")->required();
  measure->add_option("--base-address", mo->base_address, "Holding register of word 0 of the gear probe block")
      ->capture_default_str()
      ->check(CLI::Range(0, 65536 - 11));
  measure->add_option("--gaps", mo->gaps, "Tooth gaps to measure, e.g. 1,20,40,60")
      ->delimiter(',')
      ->capture_default_str();
  measure->add_option("--step-mm", mo->step_mm, "Spacing of the points across the face")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 50.0));
  measure->add_option("--point-timeout-ms", mo->point_timeout_ms, "How long the machine may take for one point")
      ->capture_default_str()
      ->check(CLI::Range(10, 600000));
  CLI::Option* correct_flag =
      measure->add_flag("--correct", mo->correct, "Correct the stroke in force from the gear measured");
  measure->add_option("--machine", mo->machine, "The grinder, stored with the gear run")->capture_default_str();
  measure->add_option("--serial", mo->serial, "Serial number of the measured gear (at most 64 characters)");
  measure->add_option("--operator", mo->operator_name, "Who measured it (at most 64 characters)");
  measure->add_option("--note", mo->note, "A note stored with the gear run");
  measure
      ->add_flag("--require-approval", mo->require_approval,
                 "With --correct: keep the corrected stroke for approval (`nc approve ID`) instead of pushing it")
      ->needs(correct_flag);
  measure->callback([&action, mo] { action = [mo] { return cmd_gear_measure(*mo); }; });

  CLI::App* runs = gear->add_subcommand("runs", "The gears measured: their lead, ISO 1328-1 figures and verdicts");
  runs->require_subcommand(1);
  auto lo = std::make_shared<GearRunsOptions>();
  CLI::App* list = runs->add_subcommand("list", "The gear runs, newest first");
  add_data_options(*list, lo->paths);
  list->add_option("--part", lo->query.part, "Only this part");
  list->add_option("--machine", lo->query.machine, "Only this machine");
  list->add_option("--serial", lo->query.serial, "Only this serial number (exact)");
  list->add_option("--verdict", lo->verdict, "Only this verdict: in, out or not_judged");
  list->add_option("--since", lo->since, "Started at or after (UTC, 2026-11-22 or 2026-11-22T06:00:00Z)");
  list->add_option("--until", lo->until, "Started before (UTC)");
  list->add_option("--limit", lo->query.limit, "At most this many")->capture_default_str();
  list->add_flag("--json", lo->json, "Print JSON");
  list->callback([&action, lo] { action = [lo] { return cmd_gear_runs_list(*lo); }; });
  auto so2 = std::make_shared<GearRunsOptions>();
  CLI::App* show = runs->add_subcommand("show", "One gear run: every trace's figures, the verdict, the stroke pushed");
  show->add_option("id", so2->id, "Gear run id (`gear runs list`)")->required();
  add_data_options(*show, so2->paths);
  show->add_flag("--json", so2->json, "Print JSON, with the traces");
  show->callback([&action, so2] { action = [so2] { return cmd_gear_runs_show(*so2); }; });

  auto ro = std::make_shared<GearReportOptions>();
  CLI::App* report = runs->add_subcommand(
      "report", "One gear run's lead report: the verdict, a lead chart per gap (both flanks), every trace's figures");
  report->add_option("id", ro->id, "Gear run id (`gear runs list`)")->required();
  add_data_options(*report, ro->paths);
  report->add_option("--out", ro->out_path, "The file: .pdf, .svg or .png [gear_run<ID>.pdf]");
  report->callback([&action, ro] { action = [ro] { return cmd_gear_runs_report(*ro); }; });

  auto spo = std::make_shared<GearSpcOptions>();
  CLI::App* spc = runs->add_subcommand(
      "spc", "SPC of a gear part's runs: per ISO 1328-1 figure the mean, s, Cp and Cpk against its tolerance");
  add_data_options(*spc, spo->paths);
  spc->add_option("--part", spo->query.part, "The gear part")->required();
  spc->add_option("--machine", spo->query.machine, "Only this machine");
  spc->add_option("--since", spo->since, "Started at or after (UTC, 2026-11-22 or 2026-11-22T06:00:00Z)");
  spc->add_option("--until", spo->until, "Started before (UTC)");
  spc->add_option("--limit", spo->query.limit, "The newest this many gear runs")
      ->capture_default_str()
      ->check(CLI::Range(2, 1000000));
  spc->add_flag("--json", spo->json, "Print JSON");
  spc->callback([&action, spo] { action = [spo] { return cmd_gear_runs_spc(*spo); }; });

  auto eo = std::make_shared<GearExportOptions>();
  CLI::App* exp = runs->add_subcommand(
      "export", "The gear runs' ISO 1328-1 figures as an AQDEF (Q-DAS .dfq) file for the plant's SPC system");
  add_data_options(*exp, eo->paths);
  exp->add_option("--format", eo->format, "dfq (the only format)")
      ->check(CLI::IsMember({"dfq"}))
      ->capture_default_str();
  exp->add_option("--part", eo->query.part, "Only this part");
  exp->add_option("--machine", eo->query.machine, "Only this machine");
  exp->add_option("--serial", eo->query.serial, "Only this serial number (exact)");
  exp->add_option("--since", eo->since, "Started at or after (UTC, 2026-11-22 or 2026-11-22T06:00:00Z)");
  exp->add_option("--until", eo->until, "Started before (UTC)");
  exp->add_option("--operation", eo->operation, "K1086, the work cycle")->capture_default_str();
  exp->add_option("--out", eo->out_path, "Write the file here (atomically) instead of to standard output");
  exp->callback([&action, eo] { action = [eo] { return cmd_gear_runs_export(*eo); }; });

  auto io = std::make_shared<IdentifyOptions>();
  CLI::App* identify = gear->add_subcommand(
      "identify",
      "Fit a per-axis error model to a measured gear's lead traces (and a ZY ballbar circle) by least squares: the "
      "terms' values, the residuals, and a refusal naming the terms the data cannot tell apart; --out writes the "
      "errors along the stroke for `gear stroke --errors`");
  identify->add_option("--part", io->part_path, "Gear part file (TOML with [gear])")->required();
  identify->add_option("--lead", io->lead_path, "Lead traces, CSV: gap, flank (left/right), z_mm, deviation_um")
      ->required();
  identify
      ->add_option("--terms", io->terms,
                   "The model: <axis>:<kind>,... with axis y, z, b, c and kind linear, bow or periodic@<pitch mm>, "
                   "e.g. y:bow,z:periodic@12,c:periodic@24")
      ->required();
  identify->add_option("--ballbar", io->ballbar_path, "Ballbar circle in ZY, CSV: angle_deg, radial_um");
  identify->add_option("--ballbar-radius-mm", io->ballbar_radius_mm, "The ballbar circle's radius")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1000.0));
  identify->add_option("--out", io->out_path, "Write the identified errors along the stroke here (CSV)");
  add_data_options(*identify, io->paths);
  identify->add_option("--nc-dir", io->paths.nc_dir, "Directory of the stroke in force [<data-dir>/nc]");
  identify->add_flag("--uncompensated", io->uncompensated,
                     "The gear was ground without a stroke from gaugeloop (SIM1 0); otherwise the stroke in force "
                     "is read from the history");
  identify->callback([&action, io] { action = [io] { return cmd_gear_identify(*io); }; });

  add_gear_slide_commands(*gear, action);
}

}  // namespace gaugeloop
