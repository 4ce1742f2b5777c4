// db: the run database file itself: check it is sound, back it up, upgrade its schema.
#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>

#include "cli/cli_common.h"
#include "storage/db_maintenance.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

struct DbOptions {
  DataPaths paths;
  std::string db_file;  // --db: any database file, e.g. a backup; empty: as --data-dir or --config say
  fs::path db() const { return db_file.empty() ? paths.db() : fs::path(db_file); }
};

void add_db_options(CLI::App& cmd, DbOptions& o) {
  CLI::Option* config = add_data_options(cmd, o.paths);
  cmd.add_option("--db", o.db_file, "The database file itself, e.g. a backup (instead of --data-dir or --config)")
      ->excludes(config);
}

Status require_db_file(const DbOptions& o) { return require_database(o.db(), "give --data-dir, --config or --db"); }

// ---- db check ----

int cmd_check(const DbOptions& o) {
  if (Status s = require_db_file(o); !s) return report_error(s.error());
  Result<IntegrityReport> report = check_database_file(o.db(), IntegrityCheck::kFull);
  if (!report) return report_error(report.error());
  if (!report->sound()) return report_error(damaged_database(o.db(), report->problems));
  Result<int> version = database_schema_version(o.db());
  if (!version) return report_error(version.error());
  std::printf("database %s is sound (schema version %d)%s\n", o.db().c_str(), *version,
              report->constraints_checked ? ""
                                          : "; opened read-only, so its CHECK constraints were not verified: check "
                                            "it where it is writable to verify them too");
  return kExitOk;
}

// ---- db backup ----

struct BackupOptions : DbOptions {
  std::string dest;
  bool force = false;
};

int cmd_backup(const BackupOptions& o) {
  if (Status s = require_db_file(o); !s) return report_error(s.error());
  if (Status s = backup_database_file(o.db(), o.dest, o.force); !s) return report_error(s.error());
  std::printf("database %s backed up to %s (the copy is sound)\n", o.db().c_str(), o.dest.c_str());
  return kExitOk;
}

// ---- db upgrade ----

int cmd_upgrade(const DbOptions& o) {
  if (Status s = require_db_file(o); !s) return report_error(s.error());
  // Not checked whole first: the upgrade copies the file and checks the copy whole (page for
  // page the same file) before it changes anything, so a damaged file is refused without
  // reading it twice (a million-run file is read at random by the check: minutes each time).
  Result<RunStore> store = RunStore::open(o.db());
  if (!store) return report_error(store.error());
  const std::optional<SchemaUpgrade> upgrade = store->schema_upgrade();
  Result<int> version = database_schema_version(o.db());
  if (!version) return report_error(version.error());
  if (!upgrade) {
    std::printf("database %s is at schema version %d, the latest: nothing to upgrade\n", o.db().c_str(), *version);
    return kExitOk;
  }
  std::printf("database %s upgraded from schema version %d to %d; the file as it was is kept in %s\n", o.db().c_str(),
              upgrade->from_version, *version, upgrade->backup.c_str());
  return kExitOk;
}

}  // namespace

void add_db_commands(CLI::App& app, CommandAction& action) {
  CLI::App* db = app.add_subcommand(
      "db", "The run database file: check it, back it up, upgrade its schema, store the runs it refused.");
  db->require_subcommand(1);

  auto check = std::make_shared<DbOptions>();
  CLI::App* check_cmd = db->add_subcommand(
      "check",
      "Is the database sound? Reads every page (integrity_check), every reference, every run's stored numbers and "
      "every pushed program against their checksum, and the ids handed out (<db>.ids) against those it holds "
      "(commits lost with a deleted -wal); exit status 4 if it is damaged. Never writes the file: safe while "
      "gaugeloop runs.");
  add_db_options(*check_cmd, *check);
  check_cmd->callback([&action, check] { action = [check] { return cmd_check(*check); }; });

  auto backup = std::make_shared<BackupOptions>();
  CLI::App* backup_cmd = db->add_subcommand(
      "backup",
      "Copy the database to FILE with SQLite's online backup (safe while gaugeloop runs); the copy is "
      "checked, then renamed into place.");
  add_db_options(*backup_cmd, *backup);
  backup_cmd->add_option("file", backup->dest, "Where to write the copy, e.g. gaugeloop-2026-12-01.sqlite")->required();
  backup_cmd->add_flag("--force", backup->force, "Replace FILE if it exists");
  backup_cmd->callback([&action, backup] { action = [backup] { return cmd_backup(*backup); }; });

  auto upgrade = std::make_shared<DbOptions>();
  CLI::App* upgrade_cmd =
      db->add_subcommand("upgrade",
                         "Bring a database written by an older gaugeloop to this one's schema, after checking it and "
                         "backing it up to <db>.schema<N>-backup-<UTC time>. Commands that write do the same.");
  add_db_options(*upgrade_cmd, *upgrade);
  upgrade_cmd->callback([&action, upgrade] { action = [upgrade] { return cmd_upgrade(*upgrade); }; });

  add_import_unstored_command(*db, action);
}

}  // namespace gaugeloop
