// runs: queries of the run history.
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>

#include "app/cli_common.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

int cmd_runs_list(const DataPaths& paths, const RunQuery& query, bool json) {
  if (!std::filesystem::exists(paths.db())) {
    return report_error(make_error(ErrorCode::kNotFound,
                                   "no run database at " + paths.db().string() +
                                       "; run `gaugeloop demo` or `gaugeloop measure` first, or give --data-dir"));
  }
  Result<RunStore> store = RunStore::open(paths.db());
  if (!store) return report_error(store.error());
  Result<std::vector<RunSummary>> runs = store->list_runs(query);
  if (!runs) return report_error(runs.error());
  if (json) {
    nlohmann::json out = nlohmann::json::array();
    for (const RunSummary& r : *runs) {
      out.push_back({{"id", r.id},
                     {"started_utc", r.started_utc},
                     {"machine", r.machine},
                     {"part", r.part},
                     {"lobe", r.lobe},
                     {"status", r.status},
                     {"revolutions", r.revolutions},
                     {"degrees_captured", r.degrees_captured},
                     {"max_abs_error_um", r.max_abs_error_um},
                     {"rms_error_um", r.rms_error_um},
                     {"repeatability_um", r.repeatability_um},
                     {"nc_file", r.nc_file}});
    }
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  std::printf("%6s  %-20s  %-10s  %-24s %4s  %4s  %8s  %8s  %8s  %s\n", "run", "started (UTC)", "machine", "part",
              "lobe", "revs", "max um", "rms um", "rep um", "status");
  for (const RunSummary& r : *runs) {
    std::printf("%6lld  %-20s  %-10s  %-24s %4d  %4d  %8.2f  %8.2f  %8.2f  %s\n", static_cast<long long>(r.id),
                r.started_utc.c_str(), r.machine.c_str(), r.part.c_str(), r.lobe, r.revolutions, r.max_abs_error_um,
                r.rms_error_um, r.repeatability_um, r.status.c_str());
  }
  if (runs->empty()) std::printf("(no runs)\n");
  return kExitOk;
}

}  // namespace

void add_runs_commands(CLI::App& app, CommandAction& action) {
  CLI::App* runs = app.add_subcommand("runs", "Query the run history.");
  runs->require_subcommand(1);

  struct ListOptions {
    DataPaths paths;
    RunQuery query;
    bool json = false;
  };
  auto list = std::make_shared<ListOptions>();
  CLI::App* runs_list = runs->add_subcommand("list", "List runs, newest first.");
  add_data_dir_option(*runs_list, list->paths);
  runs_list->add_option("--limit", list->query.limit, "Most runs to show")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  runs_list->add_option("--part", list->query.part, "Only runs of this part");
  runs_list->add_flag("--json", list->json, "Print JSON instead of a table");
  runs_list->callback(
      [&action, list] { action = [list] { return cmd_runs_list(list->paths, list->query, list->json); }; });
}

}  // namespace gaugeloop
