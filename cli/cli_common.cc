// Exit codes, error reporting, data paths and part loading for the subcommands.
#include "cli/cli_common.h"

#include <spdlog/spdlog.h>

#include <cstdlib>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli/embedded_defaults.h"
#include "core/text_file.h"
#include "plant/central_history.h"

namespace gaugeloop {

void print_json(const nlohmann::json& j) { std::cout << j.dump(2) << "\n"; }

int exit_code_for(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidInput:
    case ErrorCode::kNotFound:
    case ErrorCode::kRefused:
      return kExitBadInput;
    case ErrorCode::kGaugeUnreachable:
    case ErrorCode::kGaugeTimeout:
    case ErrorCode::kGaugeProtocol:
    case ErrorCode::kIncompleteRun:
      return kExitGauge;
    case ErrorCode::kStorage:
      return kExitStorage;
    case ErrorCode::kIo:
      return kExitNcOutput;
    case ErrorCode::kInternal:
      return kExitInternal;
  }
  return kExitInternal;
}

int report_error(const Error& e) {
  spdlog::error("{}", e.message);
  return exit_code_for(e.code);
}

int report_file_error(const Error& e) {
  const int code = report_error(e);
  return e.code == ErrorCode::kIo ? kExitOutputFile : code;
}

std::string default_data_dir() {
  const char* env = std::getenv("GAUGELOOP_DATA_DIR");
  return env != nullptr && *env != '\0' ? std::string(env) : std::string("gaugeloop-data");
}

void add_data_dir_option(CLI::App& cmd, DataPaths& paths) {
  cmd.add_option("--data-dir", paths.data_dir,
                 "Directory holding the run database gaugeloop.sqlite (default: $GAUGELOOP_DATA_DIR if set, else "
                 "gaugeloop-data)")
      ->capture_default_str();
}

CLI::Option* add_data_options(CLI::App& cmd, DataPaths& paths) {
  add_data_dir_option(cmd, paths);
  // Read while parsing, so db() and nc() are plain paths afterwards; a validator's message
  // fails the command line like any bad option.
  CLI::Validator read_config(
      [&paths](std::string& file) -> std::string {
        Result<ServiceDataPaths> read = read_service_data_paths(file);
        if (!read) return read.error().message;
        paths.from_config = std::move(*read);
        return {};
      },
      "FILE");
  return cmd
      .add_option("--config", paths.config,
                  "The service's config (e.g. /etc/gaugeloop/gaugeloop.toml): its [database] path and [nc] dir, "
                  "instead of --data-dir")
      ->check(read_config)
      ->excludes("--data-dir");
}

Result<std::string> load_main_template(const std::string& path, std::string& name) {
  if (path.empty()) {
    name = "embedded:cam_main.mpf";
    return std::string(embedded::kNcMainTemplate);
  }
  Result<std::string> text = read_regular_file(path, "NC main program template");
  if (!text) {
    Error e = text.error();
    e.message += " (--main-template)";
    return e;
  }
  name = path;
  return std::string(without_utf8_bom(*text));
}

Result<LoadedPart> load_part(const std::string& part_path) {
  Result<PartFile> pf = part_path.empty() ? parse_part_toml(embedded::kDemoPartToml, "embedded:intake_flat.toml", "")
                                          : read_part_file(part_path);
  if (!pf) return pf.error();
  if (pf->pin) return LoadedPart{std::move(*pf), LiftTable{}};  // a pin has no lift table
  Result<LiftTable> design = part_path.empty()
                                 ? parse_lift_table_csv(embedded::kDemoLiftCsv, "embedded:intake_flat.csv")
                                 : read_lift_table_csv(pf->part.lift_table);
  if (!design) return design.error();
  return LoadedPart{std::move(*pf), std::move(*design)};
}

Result<LoadedPart> load_lobe_part(const std::string& part_path, std::string_view command) {
  Result<LoadedPart> lp = load_part(part_path);
  if (lp && lp->file.pin) {
    return make_error(ErrorCode::kInvalidInput,
                      part_path + ": part " + lp->file.part.name + " is a crankpin; `" + std::string(command) +
                          "` takes cam lobes. For a pin: `gaugeloop demo --part " + part_path +
                          "` grinds and measures it on the virtual grinder, `gaugeloop measure --part " + part_path +
                          "` measures it from a gauge (docs/crankpins.md)");
  }
  return lp;
}

Status require_database(const std::filesystem::path& db, std::string_view advice) {
  if (std::filesystem::exists(db)) return {};
  return make_error(ErrorCode::kNotFound, "no run database at " + db.string() + "; " + std::string(advice));
}

namespace {

std::string make_one(const DataPaths& paths) {
  if (!paths.config.empty()) {
    return "the service has stored no run yet, or [database] path in " + paths.config +
           " is not the database it writes";
  }
  return "run `gaugeloop demo` or `gaugeloop measure` first, or give --data-dir or --config";
}

}  // namespace

Result<RunStore> open_history(const DataPaths& paths) {
  if (Status s = require_database(paths.db(), make_one(paths)); !s) return s.error();
  Result<RunStore> store = RunStore::open(paths.db());
  if (store) store->set_nc_dir(paths.nc());
  return store;
}

Result<RunStore> open_history_read_only(const DataPaths& paths) {
  if (Status s = require_database(paths.db(), make_one(paths)); !s) return s.error();
  Result<RunStore> store = RunStore::open_read_only(paths.db());
  if (store) store->set_nc_dir(paths.nc());
  return store;
}

CLI::Option* add_central_db_option(CLI::App& cmd, std::string& url, CLI::Option* config) {
  CLI::Option* db =
      cmd.add_option("--db", url,
                     "Read the plant's central history at this URL (postgresql://USER@HOST:PORT/DATABASE) "
                     "instead of the grinder's file: every machine synced there")
          ->excludes("--data-dir");
  if (config != nullptr) db->excludes(config);
  return db;
}

Result<std::unique_ptr<RunHistory>> open_run_history(const DataPaths& paths, const std::string& db_url) {
  if (!db_url.empty()) {
    Result<CentralHistory> central = CentralHistory::open(db_url);
    if (!central) {
      Error e = central.error();
      e.message += " (--db)";
      return e;
    }
    return std::unique_ptr<RunHistory>(std::make_unique<CentralHistory>(std::move(*central)));
  }
  Result<RunStore> store = open_history_read_only(paths);
  if (!store) return store.error();
  return std::unique_ptr<RunHistory>(std::make_unique<RunStore>(std::move(*store)));
}

}  // namespace gaugeloop
