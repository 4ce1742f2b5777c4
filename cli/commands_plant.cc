// plant sync: copies the grinder's run history into the plant's central history (docs/plant.md).
#include <unistd.h>

#include <cstdio>
#include <memory>

#include "cli/cli_common.h"
#include "plant/central_history.h"
#include "plant/central_sync.h"

namespace gaugeloop {
namespace {

struct SyncOptions {
  DataPaths paths;
  std::string to;
  std::string machine;  // empty: the config's machine with --config, else this computer's host name
  CentralSyncOptions sync;
};

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof name - 1) != 0) return {};
  return name;
}

int cmd_sync(const SyncOptions& o) {
  const std::string machine = !o.machine.empty()        ? o.machine
                              : !o.paths.config.empty() ? o.paths.from_config.machine
                                                        : host_name();
  // Reading is all a sync does to the grinder's file: it works beside a running service.
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<CentralSyncCounts> synced = sync_to_central(*store, o.to, machine, o.sync);
  if (!synced) return report_error(synced.error());
  Result<CentralUrl> url = parse_central_url(o.to);  // parsed once already: for the password-free form
  std::printf("synced %s (machine %s) to the central history at %s\n", synced->source.c_str(), machine.c_str(),
              url ? url->shown.c_str() : "");
  auto line = [](const char* what, const CentralSyncTableCounts& c) {
    std::printf("  %-10s %lld copied, %lld already there (up to id %lld", what, static_cast<long long>(c.inserted),
                static_cast<long long>(c.already_there), static_cast<long long>(c.last_local_id));
    if (c.resumed_after > 0) {
      std::printf("; resumed after id %lld, where a sync from the start stopped",
                  static_cast<long long>(c.resumed_after));
    }
    std::printf(")\n");
  };
  line("runs", synced->runs);
  line("NC pushes", synced->pushes);
  line("events", synced->events);
  if (synced->pruned > 0) {
    std::printf(
        "  %lld runs pruned on the grinder since they were copied: marked pruned, their raw revolutions "
        "deleted\n",
        static_cast<long long>(synced->pruned));
  }
  if (!synced->caught_up) {
    std::printf("stopped after %d batches (--max-batches): run the sync again to copy the rest\n", synced->batches);
  }
  return kExitOk;
}

}  // namespace

void add_plant_commands(CLI::App& app, CommandAction& action) {
  CLI::App* plant = app.add_subcommand("plant", "The plant of many grinders: the central history in PostgreSQL.");
  plant->require_subcommand(1);

  auto sync = std::make_shared<SyncOptions>();
  CLI::App* sync_cmd = plant->add_subcommand(
      "sync",
      "Copy this grinder's runs, NC pushes and events into the central history, from where the last sync stopped. "
      "Each record once, by its UUID; a sync stopped anywhere resumes.");
  add_data_options(*sync_cmd, sync->paths);
  sync_cmd->add_option("--to", sync->to, "The central history: postgresql://USER@HOST:PORT/DATABASE")->required();
  sync_cmd->add_option(
      "--machine", sync->machine,
      "The grinder's name in the central history, the same at every sync (default: the machine of --config, "
      "else the host name)");
  sync_cmd->add_option("--batch-size", sync->sync.batch_size, "Records per transaction")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  sync_cmd->add_option("--max-batches", sync->sync.max_batches, "Stop after this many transactions (0: no limit)")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000000));
  sync_cmd->add_flag("--from-start", sync->sync.from_start,
                     "Read the file from its first record again (after it was replaced or restored from a backup); "
                     "records already there are found by UUID and not copied twice, and one stopped part-way resumes "
                     "where it stopped");
  sync_cmd->add_flag("--programs", sync->sync.programs,
                     "Copy each NC push's program text too (nc_pushes.program_text), and give it to pushes copied "
                     "before without it");
  sync_cmd->add_flag("--per-degree", sync->sync.per_degree,
                     "Copy each run's per-degree tables (design, mean, spread, error, correction, residual) and its "
                     "raw revolutions unless pruned, and give them to runs copied before without them");
  sync_cmd->callback([&action, sync] { action = [sync] { return cmd_sync(*sync); }; });
}

}  // namespace gaugeloop
