// `runs export --format dfq`: the AQDEF file of one run, a time range or a shaft
// (docs/aqdef.md). `runs export` keeps its CSV; these options and the DFQ path live here.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <memory>
#include <string>

#include "cli/cli_common.h"
#include "report/dfq.h"

namespace gaugeloop {

struct DfqExportRequest {
  std::string format = "csv";  // "csv" or "dfq"
  std::int64_t run = 0;        // --run; 0: not given
  std::string part;
  int lobe = 0;
  std::string machine;
  std::string serial;
  std::string since, until;
  int harmonics = 0;
  std::string operation = DfqOptions{}.operation;
};

// Adds --format and the DFQ selection options (--run, --part, --lobe, --machine, --serial,
// --since, --until, --harmonics, --operation) to `runs export`.
std::shared_ptr<DfqExportRequest> add_dfq_export_options(CLI::App& export_cmd);

// True when the command line chose the DFQ export.
inline bool wants_dfq(const DfqExportRequest& r) { return r.format == "dfq"; }

// The DFQ export: `positional_id` is `runs export ID` (0: not given), `out` its --out (empty:
// standard output). Exit 2 for a selection that matches no run or runs without
// characteristics, or a CSV-only option given with --format dfq.
int cmd_export_dfq(const DfqExportRequest& r, const DataPaths& paths, std::int64_t positional_id,
                   const std::string& out);

// The CSV export takes no DFQ selection: kExitBadInput with a message if one was given.
int refuse_dfq_options_for_csv(const DfqExportRequest& r);

}  // namespace gaugeloop
