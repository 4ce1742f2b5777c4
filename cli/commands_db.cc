// db: the run database file itself: check it is sound, back it up, upgrade its schema.
#include <spdlog/spdlog.h>

#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "cli/cli_common.h"
#include "core/number_text.h"
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

// Bytes this process has read so far (/proc/self/io `rchar`); 0 where it cannot be read.
std::uint64_t bytes_read_so_far() {
  std::ifstream io("/proc/self/io");
  std::string key;
  std::uint64_t value = 0;
  while (io >> key >> value) {
    if (key == "rchar:") return value;
  }
  return 0;
}

// "15.72 GB", "3.4 MB".
std::string size_text(std::uint64_t bytes) {
  const auto b = static_cast<double>(bytes);
  return b >= 1e9 ? format_fixed(b / 1e9, 2) + " GB" : format_fixed(b / 1e6, 1) + " MB";
}

// "under a second", "about 40 s", "about 19 min".
std::string duration_text(double seconds) {
  if (seconds < 1.0) return "under a second";
  if (seconds < 90.0) return "about " + format_fixed(seconds, 0) + " s";
  return "about " + format_fixed(seconds / 60.0, 0) + " min";
}

// The check's progress on standard error while it runs: every `every`, how much it has read of
// the file's size, and how long the rest takes at the rate so far (the page walk reads each page
// once, the checks after it read some again: a lower bound). Stopped (and joined) by its
// destructor, which prints what was read and how long it took.
class CheckProgress {
 public:
  CheckProgress(std::uint64_t file_bytes, std::chrono::seconds every)
      : file_bytes_(file_bytes), start_bytes_(bytes_read_so_far()), started_(Clock::now()) {
    thread_ = std::thread([this, every] {
      std::unique_lock<std::mutex> lock(mutex_);
      while (!wake_.wait_for(lock, every, [this] { return done_; })) report(false);
    });
  }
  ~CheckProgress() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    wake_.notify_all();
    thread_.join();
    report(true);
  }
  CheckProgress(const CheckProgress&) = delete;
  CheckProgress& operator=(const CheckProgress&) = delete;

 private:
  using Clock = std::chrono::steady_clock;
  void report(bool last) const {
    const std::uint64_t read = bytes_read_so_far() - start_bytes_;
    const double seconds = std::chrono::duration<double>(Clock::now() - started_).count();
    if (last) {
      std::fprintf(stderr, "read %s in %.1f s\n", size_text(read).c_str(), seconds);
      return;
    }
    std::string rest;
    if (read > 0 && read < file_bytes_) {
      const double left_s = static_cast<double>(file_bytes_ - read) / (static_cast<double>(read) / seconds);
      rest = "; at this rate the rest takes " + duration_text(left_s) + " or more";
    }
    std::fprintf(stderr, "  read %s of the %s file after %.0f s%s\n", size_text(read).c_str(),
                 size_text(file_bytes_).c_str(), seconds, rest.c_str());
  }

  const std::uint64_t file_bytes_;
  const std::uint64_t start_bytes_;
  const Clock::time_point started_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool done_ = false;
  std::thread thread_;
};

int cmd_check(const DbOptions& o) {
  if (Status s = require_db_file(o); !s) return report_error(s.error());
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(o.db(), ec);
  // What it will take, before it starts: every page read once or more, at the rates measured on
  // the project's machine (docs/storage.md): 160 MB/s with the file in memory, 14 MB/s from a
  // disk the file was not read from lately (the page walk reads at random).
  const double bytes = static_cast<double>(ec ? 0 : size);
  std::fprintf(stderr,
               "checking %s: %s, every page read once or more: %s if the file is in memory, %s if it must come "
               "from the disk; progress every 10 s\n",
               o.db().c_str(), size_text(ec ? 0 : size).c_str(), duration_text(bytes / 160e6).c_str(),
               duration_text(bytes / 14e6).c_str());
  Result<IntegrityReport> report = [&] {
    const CheckProgress progress(ec ? 0 : size, std::chrono::seconds(10));
    return check_database_file(o.db(), IntegrityCheck::kFull);
  }();
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
