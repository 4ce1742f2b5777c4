// The gaugeloop command line. Each command group lives in its own commands_*.cc.
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <exception>

#include "app/cli_common.h"

int main(int argc, char** argv) {
  using namespace gaugeloop;
  spdlog::set_default_logger(spdlog::stderr_color_mt("gaugeloop"));
  spdlog::set_pattern("%^%l%$: %v");

  CLI::App app{
      "gaugeloop: measures cam lobes with an in-process gauge over Modbus, compensates the wheel path\n"
      "and writes the Sinumerik 840D curve table. Every run is kept in a SQLite database."};
  app.set_version_flag("--version", GAUGELOOP_VERSION);
  app.require_subcommand(1);

  CommandAction action;
  add_measure_commands(app, action);
  add_runs_commands(app, action);
  add_profile_commands(app, action);
  add_nc_commands(app, action);
  add_serve_commands(app, action);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    // --help and --version exit 0; a bad command line is bad input, exit 2 (README).
    return app.exit(e) == 0 ? kExitOk : kExitBadInput;
  }
  if (!action) return kExitBadInput;  // require_subcommand makes this unreachable

  try {
    return action();
  } catch (const std::exception& e) {
    // The one boundary for programmer errors and library exceptions on the main thread.
    spdlog::critical("internal error: {}; please report it with the command line used", e.what());
    return kExitInternal;
  }
}
