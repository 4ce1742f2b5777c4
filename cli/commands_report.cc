// runs report and the plot of runs trend: thin wiring from the command line to
// report/cam_report.h, read-only on the run database.
#include "cli/commands_report.h"

#include <cstdio>
#include <filesystem>
#include <memory>

#include "core/atomic_file.h"
#include "report/cam_report.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

struct ReportOptions {
  DataPaths paths;
  std::int64_t id = 0;
  std::string out;
};

// The checks that need no database, so that a mistyped --out is told before anything is read:
// the extension names a format, and the directory exists.
Status check_out(const std::string& option, const fs::path& out) {
  if (Status s = check_page_file_name(out); !s) return make_error(s.error().code, option + ": " + s.error().message);
  const fs::path dir = directory_of(out);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    return make_error(ErrorCode::kInvalidInput, option + " " + out.string() + ": there is no directory " +
                                                    dir.string() + "; create it or write the file elsewhere");
  }
  return {};
}

int cmd_report(const ReportOptions& o) {
  if (Status s = check_out("--out", o.out); !s) return report_error(s.error());
  Result<RunStore> store = open_history_read_only(o.paths);
  if (!store) return report_error(store.error());
  Result<StoredRun> run = store->load_run(o.id);
  if (!run) {
    if (run.error().code != ErrorCode::kNotFound) return report_error(run.error());
    return report_error(make_error(
        ErrorCode::kNotFound, run.error().message + "; `gaugeloop runs list " + o.paths.where() + "` shows the ids"));
  }
  if (Status s = write_cam_report(*run, o.out); !s) return report_file_error(s.error());
  std::printf("report of run %lld written to %s\n", static_cast<long long>(o.id), o.out.c_str());
  return kExitOk;
}

}  // namespace

int cmd_trend_plot(const DataPaths& paths, const std::string& db_url, const RunQuery& query, const std::string& out,
                   const std::string& key) {
  if (Status s = check_out("--plot", out); !s) return report_error(s.error());
  Result<std::unique_ptr<RunHistory>> history = open_run_history(paths, db_url);
  if (!history) return report_error(history.error());
  Result<std::vector<RunCharacteristics>> runs = trend_plot_runs(**history, query, key);
  if (!runs) return report_error(runs.error());
  if (runs->empty()) {
    return report_error(make_error(ErrorCode::kNotFound, "no runs of " + query.part + " lobe " +
                                                             std::to_string(query.lobe) +
                                                             " match; `gaugeloop runs list` shows which parts and "
                                                             "lobes have runs"));
  }
  if (Status s = write_trend_plot(*runs, key, out); !s) return report_error(s.error());
  std::printf("%s of %zu runs plotted to %s\n", key.c_str(), runs->size(), out.c_str());
  return kExitOk;
}

void add_report_commands(CLI::App* runs, CommandAction& action) {
  auto report = std::make_shared<ReportOptions>();
  CLI::App* cmd = runs->add_subcommand(
      "report",
      "One run's cam report on one page: lift, velocity and acceleration error with their tolerance "
      "bands, polar view, harmonics, characteristics and verdicts.");
  add_data_options(*cmd, report->paths);
  cmd->add_option("id", report->id, "Run id (see `runs list`)")->required();
  cmd->add_option("--out", report->out, "File to write: .pdf, .svg or .png (A4 landscape)")->required();
  cmd->callback([&action, report] { action = [report] { return cmd_report(*report); }; });
}

}  // namespace gaugeloop
