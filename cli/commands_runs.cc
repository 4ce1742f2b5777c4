// runs and events: the questions people ask the run history, as text and as --json.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli/cli_common.h"
#include "cli/commands_dfq.h"
#include "cli/commands_report.h"
#include "cli/commands_spc.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "report/judged_error.h"
#include "report/run_json.h"
#include "report/svg_plot.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

using nlohmann::json;

// ---- Helpers shared by the commands ----

std::string list_hint(const DataPaths& paths) { return "`gaugeloop runs list " + paths.where() + "` shows the ids"; }

Result<StoredRun> load(const RunStore& store, std::int64_t id, const DataPaths& paths) {
  Result<StoredRun> run = store.load_run(id);
  if (!run && run.error().code == ErrorCode::kNotFound) {
    return make_error(ErrorCode::kNotFound, run.error().message + "; " + list_hint(paths));
  }
  return run;
}

std::time_t now() { return std::time(nullptr); }

std::string opt(const std::optional<double>& v, int decimals, bool with_sign = false) {
  if (!v) return "-";
  return with_sign ? format_signed_fixed(*v, decimals) : format_fixed(*v, decimals);
}

std::size_t argmax_abs(const DegreeTable& t) {
  std::size_t best = 0;
  for (std::size_t d = 1; d < t.size(); ++d) {
    if (std::abs(t[d]) > std::abs(t[best])) best = d;
  }
  return best;
}

std::size_t argmax(const DegreeTable& t) {
  return static_cast<std::size_t>(std::max_element(t.begin(), t.end()) - t.begin());
}

// ---- runs list ----

struct ListOptions {
  DataPaths paths;
  std::string db_url;  // --db: the central history instead of the file
  RunQuery query;
  std::string since, until;
  std::string verdict;  // --verdict; empty: any
  bool json_out = false;
  std::string plot;                           // trend: draw to this file instead of printing
  std::string characteristic = "lift_error";  // trend --plot: which characteristic
};

Result<RunQuery> resolved(const ListOptions& o) {
  RunQuery q = o.query;
  if (Status t = set_time_bounds(o.since, o.until, q.since_utc, q.until_utc); !t) return t.error();
  if (!o.verdict.empty()) q.verdict = verdict_from_name(o.verdict);
  return q;
}

// The runs `runs list` (RunHistory::list_runs) or `runs trend` (RunHistory::trend) selects,
// from the grinder's file or the central history (--db).
using RunSelection = Result<std::vector<RunSummary>> (RunHistory::*)(const RunQuery&) const;
Result<std::vector<RunSummary>> selected_runs(const ListOptions& o, RunSelection select) {
  Result<RunQuery> q = resolved(o);
  if (!q) return q.error();
  Result<std::unique_ptr<RunHistory>> history = open_run_history(o.paths, o.db_url);
  if (!history) return history.error();
  return ((**history).*select)(*q);
}

void print_runs_json(const std::vector<RunSummary>& runs) {
  json out = json::array();
  for (const RunSummary& r : runs) out.push_back(run_summary_json(r));
  print_json(out);
}

int cmd_list(const ListOptions& o) {
  // A serial no run can have (too long, a control character) would only find nothing.
  if (Status s = check_run_identity("--serial", o.query.serial); !s) return report_error(s.error());
  Result<std::vector<RunSummary>> runs = selected_runs(o, &RunHistory::list_runs);
  if (!runs) return report_error(runs.error());
  if (o.json_out) {
    print_runs_json(*runs);
    return kExitOk;
  }
  std::printf("%6s  %-20s  %-10s  %-24s %4s  %-16s  %4s  %8s  %8s  %8s  %8s  %-10s  %s\n", "run", "started (UTC)",
              "machine", "part", "lobe", "serial", "revs", "max um", "rms um", "rep um", "phase", "verdict", "status");
  for (const RunSummary& r : *runs) {
    std::printf("%6lld  %-20s  %-10s  %-24s %4d  %-16s  %4d  %8.2f  %8.2f  %8.2f  %8s  %-10s  %s%s\n",
                static_cast<long long>(r.id), r.started_utc.c_str(), r.machine.c_str(), r.part.c_str(), r.lobe,
                r.serial.empty() ? "-" : r.serial.c_str(), r.revolutions, r.max_abs_error_um, r.rms_error_um,
                r.repeatability_um, opt(r.phase_error_deg, 3, true).c_str(), verdict_name(r.verdict).data(),
                r.status.c_str(), r.raw_pruned_utc.empty() ? "" : " (raw pruned)");
  }
  if (runs->empty()) std::printf("(no runs match)\n");
  return kExitOk;
}

// ---- runs show ----

// "-10.000 .. 10.000", "<= 8.000", ">= -1.000" or "-": a tolerance as the table shows it.
std::string limits_text(const Limits& l, int decimals) {
  if (l.lower && l.upper) return format_fixed(*l.lower, decimals) + " .. " + format_fixed(*l.upper, decimals);
  if (l.upper) return "<= " + format_fixed(*l.upper, decimals);
  if (l.lower) return ">= " + format_fixed(*l.lower, decimals);
  return "-";
}

void print_characteristics(const StoredRun& r, PartKind kind) {
  if (kind == PartKind::kPin) {
    // A pin has no lift error and no timing: nothing was judged after a best-fit phase.
    std::printf("tolerances        %s\n", verdict_name(r.summary.verdict).data());
  } else {
    std::printf(
        "tolerances        %s (lift error judged %s)\n", verdict_name(r.summary.verdict).data(),
        r.lift_error_reference == LiftErrorReference::kNominal ? "at the nominal timing" : "after the best-fit phase");
  }
  if (r.characteristics.empty()) {
    std::printf("  not judged: no characteristics recorded with this run\n");
    return;
  }
  std::printf("  %-46s %14s %14s  %-24s %-9s %s\n", "characteristic", "value", "range", "limits", "unit", "verdict");
  for (const Characteristic& c : r.characteristics) {
    const int d = figure_decimals(c.unit);
    std::string title = characteristic_title(c.key, kind);
    if (c.from_deg && c.to_deg) title += " (" + std::to_string(*c.from_deg) + ".." + std::to_string(*c.to_deg) + ")";
    const std::string range = c.min == c.max ? "" : format_fixed(c.max - c.min, d);
    std::printf("  %-46s %14s %14s  %-24s %-9s %s\n", title.c_str(), format_fixed(c.value, d).c_str(), range.c_str(),
                limits_text(c.limits, d).c_str(), c.unit.c_str(), verdict_name(c.verdict).data());
  }
}

struct RunOptions {
  DataPaths paths;
  std::int64_t id = 0;
  bool json_out = false;
};

constexpr const char* kPinFrame = "pin frame, 0 deg along the crank radius outward";

std::string frame_text(const StoredRun& r, const RunPart& part) {
  if (part.pin()) {
    return std::string(kPinFrame) +
           (part.pin_mode ? (*part.pin_mode == PinMode::kCXY ? " (C-X-Y)" : " (C-X)") : std::string());
  }
  if (!r.geometry) return "not recorded with this run (revolutions stay in the machine frame)";
  const Part& g = *r.geometry;
  return "C = " + std::string(g.rotation_sense > 0 ? "+" : "-") + "psi + " + format_fixed(g.c_offset_deg, 3) +
         " deg; probe " + format_signed_fixed(g.probe_offset_deg, 3) + " deg of C from the wheel";
}

// A pin's own figures, from its characteristics (a pin run has no phase or runout; its
// stored phase is the index error). "-" for one the run did not record.
void print_pin_figures(const std::vector<Characteristic>& characteristics) {
  auto figure = [&characteristics](const char* key, int decimals, bool with_sign = true) -> std::string {
    for (const Characteristic& c : characteristics) {
      if (c.key == key) return with_sign ? format_signed_fixed(c.value, decimals) : format_fixed(c.value, decimals);
    }
    return "-";
  };
  std::printf("  roundness         %s um (least-squares circle)\n", figure("roundness", 2, false).c_str());
  std::printf("  diameter error    %s um\n", figure("diameter_error", 2).c_str());
  std::printf("  stroke error      %s um (pin centre along the crank radius, outward)\n",
              figure("stroke_error", 2).c_str());
  std::printf("  index error       %s deg (pin centre round the main axis, in the sense of C)\n",
              figure("index_error", 4).c_str());
}

std::vector<std::pair<int, double>> top_harmonics(const LobeAnalysis& a, std::size_t n) {
  std::vector<std::pair<int, double>> h;
  for (std::size_t i = 1; i < a.harmonic_amplitude_um.size(); ++i) {
    h.emplace_back(static_cast<int>(i), a.harmonic_amplitude_um[i]);
  }
  std::sort(h.begin(), h.end(), [](const auto& x, const auto& y) { return x.second > y.second; });
  if (h.size() > n) h.resize(n);
  return h;
}

int cmd_show(const RunOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<StoredRun> run = load(*store, o.id, o.paths);
  if (!run) return report_error(run.error());
  const StoredRun& r = *run;
  const RunSummary& s = r.summary;
  const LobeAnalysis& a = r.analysis;
  const bool has_inspection = s.phase_error_deg.has_value();
  const std::size_t worst = argmax_abs(a.error_um);
  const std::size_t worst_spread = argmax(a.spread_um);
  const std::size_t worst_corr = argmax_abs(r.correction_um);

  if (o.json_out) {
    print_json(run_detail_json(r));
    return kExitOk;
  }

  const RunPart part = run_part(r);
  const bool pin = part.pin();
  // A pin's tables are indexed by pin degrees, a lobe's by cam degrees.
  const char* const at = pin ? "pin" : "cam";
  std::printf("run %lld: %s %s %d on %s (%s)\n", static_cast<long long>(s.id), s.part.c_str(), pin ? "pin" : "lobe",
              s.lobe, s.machine.c_str(), s.status.c_str());
  std::printf("  started           %s, finished %s\n", s.started_utc.c_str(), r.finished_utc.c_str());
  std::printf("  gauge             %s\n", r.gauge.c_str());
  std::printf("  serial            %s\n", s.serial.empty() ? "not given" : s.serial.c_str());
  std::printf("  operator          %s\n", s.operator_name.empty() ? "not given" : s.operator_name.c_str());
  std::printf("  part temperature  %s\n", part_temperature_text(run_part_temperature(r), "degC").c_str());
  if (!s.note.empty()) std::printf("  note              %s\n", s.note.c_str());
  std::printf("  revolutions       %d (%lld discarded, %lld reconnects, %lld polls)%s\n", s.revolutions,
              static_cast<long long>(r.discarded_revolutions), static_cast<long long>(r.reconnects),
              static_cast<long long>(r.polls),
              s.raw_pruned_utc.empty() ? "" : ("; raw samples pruned " + s.raw_pruned_utc).c_str());
  std::printf("  frame             %s\n", frame_text(r, part).c_str());
  std::printf("  settings          %s\n", s.settings_hash.empty() ? "not recorded" : s.settings_hash.c_str());
  if (pin) {
    std::printf("analysis (%s)\n", kPinFrame);
    std::printf("  largest radius error %.2f um at pin %d deg (%+.2f um)\n", s.max_abs_error_um, signed_degree(worst),
                a.error_um[worst]);
    std::printf("  RMS radius error  %.2f um\n", s.rms_error_um);
  } else {
    std::printf("analysis (cam frame, 0 deg at the nose, opening side negative)\n");
    std::printf("  max lift error    %.2f um at cam %d deg (%+.2f um), raw: at nominal timing\n", s.max_abs_error_um,
                signed_degree(worst), a.error_um[worst]);
    std::printf("  RMS lift error    %.2f um, raw\n", s.rms_error_um);
  }
  std::printf("  peak to valley    %.2f um%s\n", s.peak_to_valley_um, pin ? "" : ", raw");
  // The curve the verdicts judge when it is not the raw error: its own figures, named.
  if (const JudgedError judged = judged_error(r); judged.raw_error_um) {
    std::printf("  judged            %s: max %.2f um at %s %d deg, RMS %.2f um, peak to valley %.2f um\n",
                judged.name.c_str(), judged.max_abs_um, at, judged.max_abs_at_deg, judged.rms_um,
                judged.peak_to_valley_um);
  }
  std::printf("  repeatability     %.2f um (largest per-degree standard deviation, at %s %d deg)\n", s.repeatability_um,
              at, signed_degree(worst_spread));
  if (pin) {
    print_pin_figures(r.characteristics);
  } else {
    std::printf("  phase error       %s deg\n", opt(s.phase_error_deg, 3, true).c_str());
    if (has_inspection) {
      std::printf("  runout            %.2f um (base circle, dial: total indicator reading)\n", a.dial_runout_um);
    }
    std::printf("  eccentricity      %s um (base circle's first harmonic, as the runout of a pure eccentric)\n",
                opt(s.base_circle_runout_um, 2).c_str());
  }
  if (has_inspection) {
    std::string h;
    for (const auto& [n, amp] : top_harmonics(a, 5)) h += "  h" + std::to_string(n) + " " + format_fixed(amp, 2);
    std::printf("  largest harmonics%s um\n", h.c_str());
  }
  std::printf("%s\n", pin ? "correction (in pin degrees)" : "correction (cam frame)");
  std::printf("  largest           %.2f um at %s %d deg, %s\n", std::abs(r.correction_um[worst_corr]), at,
              signed_degree(worst_corr),
              r.correction_in_force_run ? ("built on run " + std::to_string(*r.correction_in_force_run) +
                                           "'s (the table that ground the part)")
                                              .c_str()
                                        : "from the design");
  if (r.harmonics_fed_back) {
    std::printf("  band fed back     harmonics 0..%d%s\n", *r.harmonics_fed_back,
                r.harmonic_threshold_um
                    ? (", each above " + format_fixed(*r.harmonic_threshold_um, 3) + " um (the gauge noise's)").c_str()
                    : " (fixed, or no spread to tell the noise)");
  }
  if (!r.ground_with_source.empty()) {
    std::printf("  ground with       table version %d (%s)\n", r.ground_with_version.value_or(0),
                r.ground_with_source == "plc"      ? "said by the PLC"
                : r.ground_with_source == "option" ? "said by --ground-with"
                                                   : "assumed: the table in force");
  }
  if (r.inspection) std::printf("  inspection        measured to inspect: the correction in force, unchanged\n");
  print_characteristics(r, part.kind);
  if (r.pushes.empty()) std::printf("  NC pushes         none\n");
  for (const NcPush& p : r.pushes) {
    std::string detail = ", version " + std::to_string(p.table_version);
    if (!p.reason.empty()) detail += " (" + p.reason + ")";
    if (p.table.point_count) detail += ", " + std::to_string(*p.table.point_count) + " points";
    if (p.table.command_error_um) {
      detail += ", command position error " + format_fixed(*p.table.command_error_um, 3) + " um";
    }
    if (p.table.correction_max_um) detail += ", " + format_fixed(*p.table.correction_max_um, 2) + " um max";
    std::printf("  NC push           %s  %s%s\n", p.pushed_utc.c_str(), p.nc_file.c_str(), detail.c_str());
  }
  return kExitOk;
}

// ---- runs export ----

struct ExportOptions {
  DataPaths paths;
  std::int64_t id = 0;
  std::string out;  // empty: stdout
  bool comments = false;
};

int cmd_export(const ExportOptions& o) {
  if (o.id == 0) return report_error(make_error(ErrorCode::kInvalidInput, "give the run id to export as CSV"));
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<StoredRun> run = load(*store, o.id, o.paths);
  if (!run) return report_error(run.error());
  const std::string csv = run_csv(*run, o.comments);
  if (o.out.empty()) {
    std::fwrite(csv.data(), 1, csv.size(), stdout);
    return kExitOk;
  }
  if (Status w = write_file_atomically(o.out, csv); !w) return report_file_error(w.error());
  std::printf("run %lld exported to %s (360 rows)\n", static_cast<long long>(o.id), o.out.c_str());
  return kExitOk;
}

// ---- runs compare ----

struct CompareOptions {
  DataPaths paths;
  std::int64_t a = 0, b = 0;
  bool json_out = false;
};

std::vector<std::string> lines_of(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) out.push_back(line);
  return out;
}

int cmd_compare(const CompareOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<StoredRun> ra = load(*store, o.a, o.paths);
  if (!ra) return report_error(ra.error());
  Result<StoredRun> rb = load(*store, o.b, o.paths);
  if (!rb) return report_error(rb.error());
  const StoredRun& A = *ra;
  const StoredRun& B = *rb;

  DegreeTable d_error{}, d_corr{};
  double rms_diff = 0.0;
  for (std::size_t d = 0; d < d_error.size(); ++d) {
    d_error[d] = B.analysis.error_um[d] - A.analysis.error_um[d];
    d_corr[d] = B.correction_um[d] - A.correction_um[d];
    rms_diff += d_error[d] * d_error[d];
  }
  rms_diff = std::sqrt(rms_diff / kDegreesPerRevolution);
  const std::size_t we = argmax_abs(d_error);
  const std::size_t wc = argmax_abs(d_corr);
  // Settings lines in one run and not the other.
  const std::vector<std::string> la = lines_of(A.settings), lb = lines_of(B.settings);
  const std::set<std::string> sa(la.begin(), la.end()), sb(lb.begin(), lb.end());
  std::vector<std::string> only_a, only_b;
  for (const std::string& l : la) {
    if (!sb.count(l)) only_a.push_back(l);
  }
  for (const std::string& l : lb) {
    if (!sa.count(l)) only_b.push_back(l);
  }
  const bool same_lobe = A.summary.part == B.summary.part && A.summary.lobe == B.summary.lobe;

  struct Figure {
    const char* name;
    std::optional<double> a, b;
    int decimals;
  };
  const Figure figures[] = {
      {"max_abs_error_um", A.summary.max_abs_error_um, B.summary.max_abs_error_um, 2},
      {"rms_error_um", A.summary.rms_error_um, B.summary.rms_error_um, 2},
      {"peak_to_valley_um", A.summary.peak_to_valley_um, B.summary.peak_to_valley_um, 2},
      {"repeatability_um", A.summary.repeatability_um, B.summary.repeatability_um, 2},
      {"phase_error_deg", A.summary.phase_error_deg, B.summary.phase_error_deg, 3},
      {"base_circle_runout_um", A.summary.base_circle_runout_um, B.summary.base_circle_runout_um, 2},
  };
  if (o.json_out) {
    json j;
    j["a"] = run_summary_json(A.summary);
    j["b"] = run_summary_json(B.summary);
    json changes = json::object();
    for (const Figure& f : figures) {
      changes[f.name] = (f.a && f.b) ? json(*f.b - *f.a) : json(nullptr);
    }
    j["change_b_minus_a"] = changes;
    j["same_part_and_lobe"] = same_lobe;
    j["error_difference"] = {
        {"max_abs_um", std::abs(d_error[we])}, {"at_cam_deg", signed_degree(we)}, {"rms_um", rms_diff}};
    j["correction_difference"] = {{"max_abs_um", std::abs(d_corr[wc])}, {"at_cam_deg", signed_degree(wc)}};
    j["settings_same"] = A.summary.settings_hash == B.summary.settings_hash;
    j["settings_only_in_a"] = only_a;
    j["settings_only_in_b"] = only_b;
    j["a_correction_in_force_run"] = A.correction_in_force_run ? json(*A.correction_in_force_run) : json(nullptr);
    j["b_correction_in_force_run"] = B.correction_in_force_run ? json(*B.correction_in_force_run) : json(nullptr);
    print_json(j);
    return kExitOk;
  }
  const std::string ha = "run " + std::to_string(o.a), hb = "run " + std::to_string(o.b);
  std::printf("%-24s %-22s %-22s %s\n", "", ha.c_str(), hb.c_str(), "change (B - A)");
  std::printf("%-24s %-22s %-22s\n", "started (UTC)", A.summary.started_utc.c_str(), B.summary.started_utc.c_str());
  std::printf("%-24s %-22s %-22s\n", "machine", A.summary.machine.c_str(), B.summary.machine.c_str());
  std::printf("%-24s %-22s %-22s\n", "part lobe", (A.summary.part + " " + std::to_string(A.summary.lobe)).c_str(),
              (B.summary.part + " " + std::to_string(B.summary.lobe)).c_str());
  std::printf("%-24s %-22s %-22s\n", "status", A.summary.status.c_str(), B.summary.status.c_str());
  auto in_force = [](const StoredRun& r) {
    return r.correction_in_force_run ? "run " + std::to_string(*r.correction_in_force_run) : std::string("design");
  };
  std::printf("%-24s %-22s %-22s\n", "ground with correction", in_force(A).c_str(), in_force(B).c_str());
  for (const Figure& f : figures) {
    std::printf("%-24s %-22s %-22s %s\n", f.name, opt(f.a, f.decimals).c_str(), opt(f.b, f.decimals).c_str(),
                (f.a && f.b) ? format_signed_fixed(*f.b - *f.a, f.decimals).c_str() : "-");
  }
  if (!same_lobe)
    std::printf("note: the runs are of different parts or lobes; per-degree differences compare unlike lobes\n");
  std::printf("per degree (cam frame):\n");
  std::printf("  error difference      max %.2f um at cam %d deg, RMS %.2f um\n", std::abs(d_error[we]),
              signed_degree(we), rms_diff);
  std::printf("  correction difference max %.2f um at cam %d deg\n", std::abs(d_corr[wc]), signed_degree(wc));
  if (A.summary.settings_hash == B.summary.settings_hash) {
    std::printf("settings: %s\n", A.summary.settings_hash.empty() ? "not recorded for either run" : "the same");
  } else {
    std::printf("settings differ:\n");
    for (const std::string& l : only_a) std::printf("  - %s   (run %lld)\n", l.c_str(), static_cast<long long>(o.a));
    for (const std::string& l : only_b) std::printf("  + %s   (run %lld)\n", l.c_str(), static_cast<long long>(o.b));
    if (A.settings.empty() || B.settings.empty()) std::printf("  (one run did not record its settings)\n");
  }
  return kExitOk;
}

// ---- runs trend ----

constexpr int kDefaultTrendRuns = 200;

int cmd_trend(const ListOptions& o) {
  if (!o.plot.empty()) {
    Result<RunQuery> q = resolved(o);
    return q ? cmd_trend_plot(o.paths, o.db_url, *q, o.plot, o.characteristic) : report_error(q.error());
  }
  Result<std::vector<RunSummary>> runs = selected_runs(o, &RunHistory::trend);
  if (!runs) return report_error(runs.error());
  if (o.json_out) {
    print_runs_json(*runs);
    return kExitOk;
  }
  const RunQuery& q = o.query;
  std::printf("%s lobe %d%s, oldest first (cam frame figures)\n", q.part.c_str(), q.lobe,
              q.machine.empty() ? "" : (" on " + q.machine).c_str());
  std::printf("%6s  %-20s  %-10s  %8s  %8s  %9s  %10s  %8s  %s\n", "run", "started (UTC)", "machine", "max um",
              "rms um", "phase deg", "runout um", "rep um", "status");
  for (const RunSummary& r : *runs) {
    std::printf("%6lld  %-20s  %-10s  %8.2f  %8.2f  %9s  %10s  %8.2f  %s\n", static_cast<long long>(r.id),
                r.started_utc.c_str(), r.machine.c_str(), r.max_abs_error_um, r.rms_error_um,
                opt(r.phase_error_deg, 3, true).c_str(), opt(r.base_circle_runout_um, 2).c_str(), r.repeatability_um,
                r.status.c_str());
  }
  if (runs->empty()) {
    std::printf("(no runs of %s lobe %d match; `gaugeloop runs list` shows which parts and lobes have runs)\n",
                q.part.c_str(), q.lobe);
  } else if (runs->size() >= 2) {
    const RunSummary& f = runs->front();
    const RunSummary& l = runs->back();
    std::printf("max error %.2f -> %.2f um (%+.2f) over %zu runs\n", f.max_abs_error_um, l.max_abs_error_um,
                l.max_abs_error_um - f.max_abs_error_um, runs->size());
  }
  if (runs->size() == static_cast<std::size_t>(q.limit)) {
    std::printf("note: the newest %d runs; there may be older ones (--limit N or --since DATE for a longer trend)\n",
                q.limit);
  }
  return kExitOk;
}

// ---- runs plot ----

struct PlotOptions {
  DataPaths paths;
  std::int64_t id = 0;
  std::string out;
  double tolerance_um = 0.0;  // 0: none
  bool no_correction = false;
  std::string layout = "wide";
};

int cmd_plot(const PlotOptions& o) {
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<StoredRun> run = load(*store, o.id, o.paths);
  if (!run) return report_error(run.error());
  ErrorPlot p = run_error_plot(*run);
  if (o.no_correction) p.correction_um.reset();
  if (o.tolerance_um > 0) {
    p.limits_um.reset();
    p.tolerance_um = o.tolerance_um;
  }
  p.footer += " \u00b7 " + o.paths.db().string();
  const PlotShape shape = o.layout == "narrow" ? PlotShape::kNarrow : PlotShape::kWide;
  if (Status w = write_file_atomically(o.out, render_error_plot_svg(p, shape)); !w) return report_file_error(w.error());
  std::printf("run %lld plotted to %s\n", static_cast<long long>(o.id), o.out.c_str());
  return kExitOk;
}

// ---- runs prune ----

struct PruneOptions {
  DataPaths paths;
  int days = 0;
};

int cmd_prune(const PruneOptions& o) {
  Result<RunStore> store = open_history(o.paths);
  if (!store) return report_error(store.error());
  const std::time_t t = now();
  const std::string cutoff = format_utc(t - static_cast<std::time_t>(o.days) * 86400);
  Result<std::int64_t> pruned = store->prune_raw_samples(cutoff, format_utc(t));
  if (!pruned) return report_error(pruned.error());
  std::printf(
      "pruned the raw samples of %lld runs started before %s; their summaries, profiles, corrections, "
      "pushes and events are kept\n",
      static_cast<long long>(*pruned), cutoff.c_str());
  return kExitOk;
}

// ---- events ----

struct EventOptions {
  DataPaths paths;
  EventQuery query;
  std::string kind, since, until;
  bool json_out = false;
};

int cmd_events(const EventOptions& o) {
  EventQuery q = o.query;
  if (o.kind == "fault") q.kind = EventKind::kFault;
  if (o.kind == "refusal") q.kind = EventKind::kRefusal;
  if (o.kind == "info") q.kind = EventKind::kInfo;
  if (Status t = set_time_bounds(o.since, o.until, q.since_utc, q.until_utc); !t) return report_error(t.error());
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<std::vector<StoredEvent>> events = store->list_events(q);
  if (!events) return report_error(events.error());
  if (o.json_out) {
    json out = json::array();
    for (const StoredEvent& e : *events) out.push_back(event_json(e));
    print_json(out);
    return kExitOk;
  }
  std::printf("%-20s  %-7s  %-18s  %-10s  %-16s %4s  %5s  %s\n", "at (UTC)", "kind", "code", "machine", "part", "lobe",
              "run", "message");
  for (const StoredEvent& e : *events) {
    std::printf("%-20s  %-7s  %-18s  %-10s  %-16s %4s  %5s  %s\n", e.event.at_utc.c_str(),
                std::string(event_kind_name(e.event.kind)).c_str(), e.event.code.c_str(), e.event.machine.c_str(),
                e.event.part.c_str(), e.event.lobe > 0 ? std::to_string(e.event.lobe).c_str() : "-",
                e.event.run_id ? std::to_string(*e.event.run_id).c_str() : "-", e.event.message.c_str());
  }
  if (events->empty()) std::printf("(no events match)\n");
  return kExitOk;
}

// ---- Wiring ----

void add_time_options(CLI::App& cmd, std::string& since, std::string& until) {
  cmd.add_option("--since", since, "Only from this UTC date or time on, e.g. 2026-11-22 or 2026-11-22T08:30");
  cmd.add_option("--until", until, "Only up to this UTC date or time, inclusive (2026-11-22: the whole day)");
}

CLI::Option* add_filter_options(CLI::App& cmd, ListOptions& o, bool lobe_required) {
  CLI::Option* db = add_central_db_option(cmd, o.db_url, add_data_options(cmd, o.paths));
  CLI::Option* part = cmd.add_option("--part", o.query.part, "Only runs of this part");
  CLI::Option* lobe = cmd.add_option("--lobe", o.query.lobe, "Only runs of this lobe")->check(CLI::Range(1, 1000));
  if (lobe_required) {
    part->required();
    lobe->required();
  }
  cmd.add_option("--machine", o.query.machine, "Only runs on this machine");
  add_time_options(cmd, o.since, o.until);
  cmd.add_flag("--json", o.json_out, "Print JSON instead of a table");
  return db;
}

}  // namespace

void add_runs_commands(CLI::App& app, CommandAction& action) {
  CLI::App* runs = app.add_subcommand("runs", "Query the run history.");
  runs->require_subcommand(1);

  auto list = std::make_shared<ListOptions>();
  CLI::App* list_cmd = runs->add_subcommand("list", "List runs, newest first.");
  add_filter_options(*list_cmd, *list, false);
  list_cmd->add_option("--serial", list->query.serial,
                       "Only runs of the part with this serial number (matched exactly, case and all)");
  list_cmd->add_option("--status", list->query.status, "Only runs with this status")
      ->check(CLI::IsMember({"measured", "pushed"}));
  list_cmd->add_option("--verdict", list->verdict, "Only runs with this verdict against their tolerances")
      ->check(CLI::IsMember({"in", "out", "not_judged"}));
  list_cmd->add_option("--limit", list->query.limit, "Most runs to show")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  list_cmd->callback([&action, list] { action = [list] { return cmd_list(*list); }; });

  auto show = std::make_shared<RunOptions>();
  CLI::App* show_cmd = runs->add_subcommand("show", "One run: summary, analysis, correction and NC pushes.");
  add_data_options(*show_cmd, show->paths);
  show_cmd->add_option("id", show->id, "Run id (see `runs list`)")->required();
  show_cmd->add_flag("--json", show->json_out, "Print JSON");
  show_cmd->callback([&action, show] { action = [show] { return cmd_show(*show); }; });

  auto exp = std::make_shared<ExportOptions>();
  CLI::App* export_cmd = runs->add_subcommand(
      "export",
      "One run per cam degree as CSV (RFC 4180): design, each revolution, mean, spread, error, correction, the "
      "run's identity. --format dfq: the characteristics of runs as an AQDEF (Q-DAS) file.");
  add_data_options(*export_cmd, exp->paths);
  export_cmd->add_option("id", exp->id, "Run id (see `runs list`); --format dfq also takes a selection");
  auto dfq = add_dfq_export_options(*export_cmd);
  export_cmd->add_option("--out", exp->out, "Write the CSV (or DFQ) to this file instead of standard output");
  export_cmd->add_flag("--comments", exp->comments,
                       "Put '#' lines saying the run, frame and units before the header (spreadsheets read them "
                       "as data rows)");
  export_cmd->callback([&action, exp, dfq] {
    action = [exp, dfq] {
      if (wants_dfq(*dfq)) return cmd_export_dfq(*dfq, exp->paths, exp->id, exp->out);
      if (int refused = refuse_dfq_options_for_csv(*dfq); refused != kExitOk) return refused;
      return cmd_export(*exp);
    };
  });

  auto cmp = std::make_shared<CompareOptions>();
  CLI::App* compare_cmd = runs->add_subcommand("compare",
                                               "Two runs side by side: figures, per-degree differences, "
                                               "settings and the correction each was ground with.");
  add_data_options(*compare_cmd, cmp->paths);
  compare_cmd->add_option("a", cmp->a, "First run id")->required();
  compare_cmd->add_option("b", cmp->b, "Second run id")->required();
  compare_cmd->add_flag("--json", cmp->json_out, "Print JSON");
  compare_cmd->callback([&action, cmp] { action = [cmp] { return cmd_compare(*cmp); }; });

  auto trend = std::make_shared<ListOptions>();
  // As GET /api/trend: the newest 200, a few milliseconds at any size of the history (at 1,000,000
  // runs 1,000 took 15 to 25 ms over HTTP, most of it the JSON); --limit or --since for more.
  trend->query.limit = kDefaultTrendRuns;
  CLI::App* trend_cmd =
      runs->add_subcommand("trend", "Max error, phase and runout of one lobe over time, oldest first.");
  add_filter_options(*trend_cmd, *trend, true);
  trend_cmd->add_option("--limit", trend->query.limit, "At most the newest this many runs")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  CLI::Option* trend_plot =
      trend_cmd->add_option("--plot", trend->plot, "Draw the characteristic over the runs to this .svg, .pdf or .png");
  trend_cmd->add_option("--characteristic", trend->characteristic, "With --plot: the characteristic's key")
      ->capture_default_str()
      ->needs(trend_plot);
  trend_cmd->callback([&action, trend] { action = [trend] { return cmd_trend(*trend); }; });

  add_report_commands(runs, action);

  auto plot = std::make_shared<PlotOptions>();
  CLI::App* plot_cmd = runs->add_subcommand("plot", "SVG of one run's lift error per cam degree, polar and linear.");
  add_data_options(*plot_cmd, plot->paths);
  plot_cmd->add_option("id", plot->id, "Run id (see `runs list`)")->required();
  plot_cmd->add_option("--out", plot->out, "SVG file to write, e.g. run12.svg")->required();
  plot_cmd
      ->add_option("--tolerance-um", plot->tolerance_um,
                   "Draw the band +-T um at every degree, instead of the limits the run was judged against, and mark "
                   "the degrees outside it")
      ->check(CLI::PositiveNumber);
  plot_cmd->add_flag("--no-correction", plot->no_correction, "Leave the correction curve out");
  plot_cmd
      ->add_option("--layout", plot->layout,
                   "wide: polar and linear side by side, 1200 x 640 px (A4 landscape); narrow: stacked, 380 x 1060 px, "
                   "for a phone")
      ->check(CLI::IsMember({"wide", "narrow"}))
      ->default_str("wide");
  plot_cmd->callback([&action, plot] { action = [plot] { return cmd_plot(*plot); }; });

  auto prune = std::make_shared<PruneOptions>();
  CLI::App* prune_cmd = runs->add_subcommand(
      "prune", "Delete raw samples of old runs; summaries, profiles, corrections, pushes and events stay.");
  add_data_options(*prune_cmd, prune->paths);
  prune_cmd->add_option("--raw-older-than-days", prune->days, "Prune runs started more than N days ago")
      ->required()
      ->check(CLI::Range(0, 100000));
  prune_cmd->callback([&action, prune] { action = [prune] { return cmd_prune(*prune); }; });

  add_spc_commands(runs, action);

  auto events = std::make_shared<EventOptions>();
  CLI::App* events_cmd = app.add_subcommand("events", "Faults, refusals and the service's steps (info), newest first.");
  add_data_options(*events_cmd, events->paths);
  events_cmd->add_option("--kind", events->kind, "Only this kind")->check(CLI::IsMember({"fault", "refusal", "info"}));
  events_cmd->add_option("--machine", events->query.machine, "Only events on this machine");
  events_cmd->add_option("--part", events->query.part, "Only events about this part");
  add_time_options(*events_cmd, events->since, events->until);
  events_cmd->add_option("--limit", events->query.limit, "Most events to show")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  events_cmd->add_flag("--json", events->json_out, "Print JSON instead of a table");
  events_cmd->callback([&action, events] { action = [events] { return cmd_events(*events); }; });
}

}  // namespace gaugeloop
