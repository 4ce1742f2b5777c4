// `runs spc` and `runs shaft`: process capability per characteristic, and the shaft record of
// one serial number.
#pragma once

#include <CLI/CLI.hpp>

#include "cli/cli_common.h"

namespace gaugeloop {

// Adds `spc` and `shaft` under `runs` (the `runs` subcommand of add_runs_commands).
void add_spc_commands(CLI::App* runs, CommandAction& action);

}  // namespace gaugeloop
