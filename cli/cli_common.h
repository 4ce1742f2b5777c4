// What every gaugeloop subcommand shares: exit codes, error reporting, data paths, parts.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

#include "config/part_file.h"
#include "core/lift_table.h"
#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Exit codes, documented in README.md.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternal = 1,
  kExitBadInput = 2,
  kExitGauge = 3,
  kExitStorage = 4,
  kExitNcOutput = 5,
  kExitNotPushed = 6,  // the run is stored, but compensation held or refused its table
};

int exit_code_for(ErrorCode code);

// Logs the message (stderr, one line) and returns the exit code for its error code.
int report_error(const Error& e);

// Where a run's files go unless flags say otherwise.
struct DataPaths {
  std::string data_dir = "gaugeloop-data";
  std::string nc_dir;  // empty: <data_dir>/nc
  std::filesystem::path db() const { return std::filesystem::path(data_dir) / "gaugeloop.sqlite"; }
  std::filesystem::path nc() const {
    return nc_dir.empty() ? std::filesystem::path(data_dir) / "nc" : std::filesystem::path(nc_dir);
  }
};

void add_data_dir_option(CLI::App& cmd, DataPaths& paths);

// kNotFound "no run database at <db>; <advice>" unless the file exists.
Status require_database(const std::filesystem::path& db, std::string_view advice);

// Opens an existing run database for a decision (it writes); a missing one is not created.
Result<RunStore> open_history(const DataPaths& paths);

// Opens an existing run database for a query: read-only, never created, upgraded or written
// (RunStore::open_read_only), so it works on a read-only file or mount.
Result<RunStore> open_history_read_only(const DataPaths& paths);

// A part and its design table, from a file or (empty path) from the embedded sample.
struct LoadedPart {
  PartFile file;
  LiftTable design;
};

Result<LoadedPart> load_part(const std::string& part_path);

// The command the user chose, run after parsing; returns the exit code.
using CommandAction = std::function<int()>;

// Each group adds its subcommands to `app`; the one named on the command line sets `action`.
void add_measure_commands(CLI::App& app, CommandAction& action);  // demo, sim, measure
void add_runs_commands(CLI::App& app, CommandAction& action);     // runs ...
void add_profile_commands(CLI::App& app, CommandAction& action);  // profile
void add_nc_commands(CLI::App& app, CommandAction& action);       // nc ...
void add_serve_commands(CLI::App& app, CommandAction& action);    // serve
void add_db_commands(CLI::App& app, CommandAction& action);       // db ...
void add_token_commands(CLI::App& app, CommandAction& action);    // token new

}  // namespace gaugeloop
