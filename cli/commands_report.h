// runs report and runs trend --plot: the cam report and the trend plot of the run history,
// drawn by report/cam_report.h.
#pragma once

#include <string>

#include "cli/cli_common.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Adds `runs report ID --out F.pdf|.svg|.png` to `runs`.
void add_report_commands(CLI::App* runs, CommandAction& action);

// `runs trend --plot F [--characteristic KEY]`: plots KEY over the runs `query` selects
// (RunHistory::characteristics, oldest first) to `out`, from the grinder's file or, with
// `db_url`, the central history; read-only on either. Returns the exit code: 2 for another
// extension, a missing output directory or a key no run has.
int cmd_trend_plot(const DataPaths& paths, const std::string& db_url, const RunQuery& query, const std::string& out,
                   const std::string& key);

}  // namespace gaugeloop
