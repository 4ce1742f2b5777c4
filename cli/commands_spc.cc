// runs spc, runs shaft: what a quality engineer asks of the run history, as text and --json.
#include "cli/commands_spc.h"

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <tuple>

#include "config/shaft_file.h"
#include "core/number_text.h"
#include "report/run_json.h"
#include "report/shaft.h"
#include "report/spc.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

using nlohmann::json;

// ---- runs spc ----

// The window of `runs spc` unless --last says otherwise: 25 subgroups of 5, a usual capability
// study. Wider windows than kSpcLargeWindow say what they read.
constexpr int kSpcDefaultRuns = 125;
constexpr int kSpcLargeWindow = 1000;

// Said of a window wider than kSpcLargeWindow; empty otherwise.
std::string large_window_note(int runs) {
  if (runs <= kSpcLargeWindow) return {};
  return "summed up over " + std::to_string(runs) + " runs, each with its characteristics; a window this wide takes " +
         "a moment on a long history: --last " + std::to_string(kSpcDefaultRuns) +
         " (the default) or --since narrows it";
}

struct SpcOptions {
  DataPaths paths;
  std::string db_url;  // --db: the central history instead of the file
  RunQuery query;
  std::string since, until;
  bool json_out = false;
};

int cmd_spc(const SpcOptions& o) {
  RunQuery q = o.query;
  if (Status t = set_time_bounds(o.since, o.until, q.since_utc, q.until_utc); !t) return report_error(t.error());
  Result<std::unique_ptr<RunHistory>> history = open_run_history(o.paths, o.db_url);
  if (!history) return report_error(history.error());
  Result<CharacteristicSummaries> runs = (*history)->characteristic_summaries(q);
  if (!runs) return report_error(runs.error());
  const std::vector<SpcFigure> figures = spc_figures(*runs);
  if (o.json_out) {
    json out = {{"part", q.part},
                {"lobe", q.lobe},
                {"machine", q.machine.empty() ? json() : json(q.machine)},
                {"runs", runs->runs},
                {"first_started_utc", runs->runs == 0 ? json() : json(runs->first_started_utc)},
                {"last_started_utc", runs->runs == 0 ? json() : json(runs->last_started_utc)},
                {"characteristics", json::array()}};
    for (const SpcFigure& f : figures) out["characteristics"].push_back(spc_figure_json(f));
    const std::string note = large_window_note(runs->runs);
    out["note"] = note.empty() ? json() : json(note);
    print_json(out);
    return kExitOk;
  }
  const std::string what = q.part + " lobe " + std::to_string(q.lobe) + (q.machine.empty() ? "" : " on " + q.machine);
  if (runs->runs == 0) {
    std::printf("(no runs of %s match; `gaugeloop runs list` shows which parts and lobes have runs)\n", what.c_str());
    return kExitOk;
  }
  std::printf("SPC of %s: %d run%s, %s to %s (UTC)\n", what.c_str(), runs->runs, runs->runs == 1 ? "" : "s",
              runs->first_started_utc.c_str(), runs->last_started_utc.c_str());
  if (figures.empty()) {
    std::printf(
        "(none of these runs carries characteristics: they were measured before tolerances were judged, or the "
        "part file gives no tolerances)\n");
    return kExitOk;
  }
  std::fputs(spc_table_text(figures).c_str(), stdout);
  if (const std::string note = large_window_note(runs->runs); !note.empty()) std::printf("note: %s\n", note.c_str());
  return kExitOk;
}

// ---- runs shaft ----

struct ShaftOptions {
  DataPaths paths;
  std::string serial;
  std::string shaft_file;
  bool json_out = false;
};

// Without a shaft file: every run of the serial, by lobe and part, newest first within each.
int print_serial_runs(const RunStore& store, const ShaftOptions& o) {
  RunQuery q;
  q.serial = o.serial;
  q.limit = 100000;
  Result<std::vector<RunSummary>> runs = store.list_runs(q);
  if (!runs) return report_error(runs.error());
  std::stable_sort(runs->begin(), runs->end(), [](const RunSummary& a, const RunSummary& b) {
    return std::tie(a.lobe, a.part) < std::tie(b.lobe, b.part);
  });
  if (o.json_out) {
    json out = {{"serial", o.serial}, {"runs", json::array()}};
    for (const RunSummary& r : *runs) {
      json j = run_summary_json(r);
      j["verdict"] = verdict_name(r.verdict);
      out["runs"].push_back(std::move(j));
    }
    print_json(out);
    return kExitOk;
  }
  if (runs->empty()) {
    std::printf("(no runs of serial %s; `gaugeloop runs list` shows the serials measured)\n", o.serial.c_str());
    return kExitOk;
  }
  std::printf("serial %s, by lobe, newest first (no shaft file: no index errors; give --shaft FILE)\n",
              o.serial.c_str());
  std::printf("%4s  %-20s  %6s  %-20s  %-10s  %-10s  %9s\n", "lobe", "part", "run", "started (UTC)", "machine",
              "verdict", "phase deg");
  for (std::size_t i = 0; i < runs->size(); ++i) {
    const RunSummary& r = (*runs)[i];
    const bool newest = i == 0 || (*runs)[i - 1].lobe != r.lobe || (*runs)[i - 1].part != r.part;
    std::printf("%4d  %-20s  %6lld  %-20s  %-10s  %-10s  %9s%s\n", r.lobe, r.part.c_str(), static_cast<long long>(r.id),
                r.started_utc.c_str(), r.machine.c_str(), std::string(verdict_name(r.verdict)).c_str(),
                r.phase_error_deg ? format_signed_fixed(*r.phase_error_deg, 3).c_str() : "-",
                newest ? "" : "  (older)");
  }
  return kExitOk;
}

int cmd_shaft(const ShaftOptions& o) {
  if (Status s = check_run_identity("serial", o.serial); !s) return report_error(s.error());
  std::optional<ShaftFile> shaft;
  if (!o.shaft_file.empty()) {
    Result<ShaftFile> read = read_shaft_file(o.shaft_file);
    if (!read) return report_error(read.error());
    shaft = std::move(*read);
  }
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  if (!shaft) return print_serial_runs(*store, o);
  Result<ShaftRecord> record = load_shaft_record(*store, shaft->layout, o.serial);
  if (!record) return report_error(record.error());
  if (o.json_out) {
    json out = shaft_record_json(*record);
    out["notes"] = shaft->notes;
    print_json(out);
    return kExitOk;
  }
  std::fputs(shaft_record_text(*record).c_str(), stdout);
  for (const std::string& note : shaft->notes) std::printf("note: %s\n", note.c_str());
  return kExitOk;
}

}  // namespace

void add_spc_commands(CLI::App* runs, CommandAction& action) {
  auto spc = std::make_shared<SpcOptions>();
  spc->query.limit = kSpcDefaultRuns;
  CLI::App* spc_cmd = runs->add_subcommand(
      "spc", "Mean, standard deviation, Cp, Cpk and the count out of tolerance per characteristic of one lobe.");
  add_central_db_option(*spc_cmd, spc->db_url, add_data_options(*spc_cmd, spc->paths));
  spc_cmd->add_option("--part", spc->query.part, "The part")->required();
  spc_cmd->add_option("--lobe", spc->query.lobe, "The lobe")->required()->check(CLI::Range(1, 1000));
  spc_cmd->add_option("--last", spc->query.limit, "Only the newest this many runs")
      ->capture_default_str()
      ->check(CLI::Range(1, 1000000));
  spc_cmd->add_option("--machine", spc->query.machine, "Only runs on this machine");
  spc_cmd
      ->add_option("--status", spc->query.status,
                   "Only runs whose table was pushed (pushed) or not (measured: held, inspected)")
      ->check(CLI::IsMember({"measured", "pushed"}));
  spc_cmd
      ->add_option("--ground-with-from", spc->query.ground_with_from,
                   "Only parts ground with this table version of the lobe's program or a later one (leaves out "
                   "the parts ground before the correction it brought)")
      ->check(CLI::Range(1, 1000000));
  spc_cmd->add_option("--since", spc->since, "Only from this UTC date or time on, e.g. 2026-11-22 or 2026-11-22T08:30");
  spc_cmd->add_option("--until", spc->until, "Only up to this UTC date or time, inclusive (2026-11-22: the whole day)");
  spc_cmd->add_flag("--json", spc->json_out, "Print JSON instead of a table");
  spc_cmd->callback([&action, spc] { action = [spc] { return cmd_spc(*spc); }; });

  auto shaft = std::make_shared<ShaftOptions>();
  CLI::App* shaft_cmd = runs->add_subcommand(
      "shaft", "The runs of one serial as a camshaft: each lobe's verdict and, with --shaft, its index error.");
  add_data_options(*shaft_cmd, shaft->paths);
  shaft_cmd->add_option("serial", shaft->serial, "The shaft's serial number, as measure --serial recorded it")
      ->required();
  shaft_cmd->add_option("--shaft", shaft->shaft_file,
                        "Shaft file naming the lobes and their nominal angles (e.g. examples/camshaft.toml)");
  shaft_cmd->add_flag("--json", shaft->json_out, "Print JSON instead of a table");
  shaft_cmd->callback([&action, shaft] { action = [shaft] { return cmd_shaft(*shaft); }; });
}

}  // namespace gaugeloop
