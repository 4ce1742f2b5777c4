// What every gaugeloop subcommand shares: exit codes, error reporting, data paths, parts.
#pragma once

#include <CLI/CLI.hpp>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>

#include "config/part_file.h"
#include "config/service_config.h"
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
  kExitNotPushed = 6,   // the run is stored, but compensation held or refused its table
  kExitOutputFile = 7,  // a report, export or plot asked for could not be written
};

int exit_code_for(ErrorCode code);

// Logs the message (stderr, one line) and returns the exit code for its error code.
int report_error(const Error& e);

// report_error for writing a file the user asked for (a report, an export, a plot): an I/O
// error exits kExitOutputFile, not the NC output's code; any other as report_error.
int report_file_error(const Error& e);

// The data directory when no --data-dir is given: $GAUGELOOP_DATA_DIR if set and not empty,
// else "gaugeloop-data" (relative to the working directory).
std::string default_data_dir();

// Where a run's files go unless flags say otherwise: the data directory, or the database and
// NC directory of the service's config (--config).
struct DataPaths {
  std::string data_dir = default_data_dir();
  std::string nc_dir;            // --nc-dir; empty: the config's [nc] dir with --config, else <data_dir>/nc
  std::string config;            // --config: the service's config file; empty: none given
  ServiceDataPaths from_config;  // read from `config` while the command line is parsed
  std::filesystem::path db() const {
    return config.empty() ? std::filesystem::path(data_dir) / "gaugeloop.sqlite" : from_config.db_path;
  }
  std::filesystem::path nc() const {
    if (!nc_dir.empty()) return nc_dir;
    return config.empty() ? std::filesystem::path(data_dir) / "nc" : from_config.nc_dir;
  }
  // "--config FILE" or "--data-dir DIR": what the user gave, for the hints in messages.
  std::string where() const { return config.empty() ? "--data-dir " + data_dir : "--config " + config; }
};

// --data-dir, whose default is default_data_dir().
void add_data_dir_option(CLI::App& cmd, DataPaths& paths);

// --data-dir as above, and --config FILE instead of it: the database and NC directory the
// service with that config uses (read_service_data_paths; a config that cannot be read fails
// the command line, exit status 2). Returns the --config option, for more exclusions.
CLI::Option* add_data_options(CLI::App& cmd, DataPaths& paths);

// kNotFound "no run database at <db>; <advice>" unless the file exists.
Status require_database(const std::filesystem::path& db, std::string_view advice);

// Opens an existing run database for a decision (it writes); a missing one is not created.
Result<RunStore> open_history(const DataPaths& paths);

// Opens an existing run database for a query: read-only, never created, upgraded or written
// (RunStore::open_read_only), so it works on a read-only file or mount.
Result<RunStore> open_history_read_only(const DataPaths& paths);

// --db URL on a query command: the plant's central history (postgresql://...) instead of the
// grinder's file; excludes --data-dir and `config` (the --config option, if the command has one).
CLI::Option* add_central_db_option(CLI::App& cmd, std::string& url, CLI::Option* config);

// The history a query command reads: the central history at `db_url` if given (kInvalidInput
// for a URL it cannot use, kStorage for a server it cannot reach), else the grinder's file,
// read-only as open_history_read_only opens it.
Result<std::unique_ptr<RunHistory>> open_run_history(const DataPaths& paths, const std::string& db_url);

// A part and its design table, from a file or (empty path) from the embedded sample.
struct LoadedPart {
  PartFile file;
  LiftTable design;
};

Result<LoadedPart> load_part(const std::string& part_path);

// load_part for a command that knows only cam lobes (`command`, e.g. "gaugeloop sim"): a pin
// part is refused (kInvalidInput) saying which commands take a pin.
Result<LoadedPart> load_lobe_part(const std::string& part_path, std::string_view command);

// The main program's template from `path` (`--main-template`), or (empty path) the embedded
// examples/sinumerik/cam_main.mpf; `name` is set for messages.
Result<std::string> load_main_template(const std::string& path, std::string& name);

// `j` on stdout, indented by 2, with a newline: what every --json prints.
void print_json(const nlohmann::json& j);

// The command the user chose, run after parsing; returns the exit code.
using CommandAction = std::function<int()>;

// Each group adds its subcommands to `app`; the one named on the command line sets `action`.
void add_measure_commands(CLI::App& app, CommandAction& action);        // demo, sim, measure
void add_runs_commands(CLI::App& app, CommandAction& action);           // runs ...
void add_profile_commands(CLI::App& app, CommandAction& action);        // profile
void add_nc_commands(CLI::App& app, CommandAction& action);             // nc ...
void add_serve_commands(CLI::App& app, CommandAction& action);          // serve
void add_db_commands(CLI::App& app, CommandAction& action);             // db ...
void add_import_unstored_command(CLI::App& db, CommandAction& action);  // db import-unstored (commands_measure.cc)
void add_token_commands(CLI::App& app, CommandAction& action);          // token new
void add_plant_commands(CLI::App& app, CommandAction& action);          // plant sync
void add_gear_commands(CLI::App& app, CommandAction& action);           // gear coupling

}  // namespace gaugeloop
