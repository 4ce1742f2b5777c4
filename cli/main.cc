// The gaugeloop command line. Each command group lives in its own commands_*.cc.
#include <spdlog/pattern_formatter.h>
#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>
#include <sys/stat.h>

#include <CLI/CLI.hpp>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>

#include "cli/cli_common.h"

namespace {

// systemd sets JOURNAL_STREAM to "<device>:<inode>" of the stream it connects to the journal;
// it holds for stderr only if stderr is still that stream (not redirected since).
bool stderr_is_the_journal() {
  const char* stream = std::getenv("JOURNAL_STREAM");
  unsigned long long dev = 0;
  unsigned long long ino = 0;
  struct stat st {};
  if (stream == nullptr || std::sscanf(stream, "%llu:%llu", &dev, &ino) != 2 || ::fstat(2, &st) != 0) return false;
  return st.st_dev == dev && st.st_ino == ino;
}

// The syslog priority journald reads from the start of a line (sd-daemon(3)): so that
// `journalctl -p warning` filters by level.
class SyslogPriority : public spdlog::custom_flag_formatter {
 public:
  void format(const spdlog::details::log_msg& msg, const std::tm&, spdlog::memory_buf_t& dest) override {
    static constexpr const char* kPriority[] = {"<7>", "<7>", "<6>", "<4>", "<3>", "<2>", "<6>"};
    const char* p = kPriority[static_cast<int>(msg.level) < 7 ? static_cast<int>(msg.level) : 6];
    dest.append(p, p + 3);
  }
  std::unique_ptr<custom_flag_formatter> clone() const override { return std::make_unique<SyslogPriority>(); }
};

}  // namespace

int main(int argc, char** argv) {
  using namespace gaugeloop;
  spdlog::set_default_logger(spdlog::stderr_color_mt("gaugeloop"));
  if (stderr_is_the_journal()) {
    auto formatter = std::make_unique<spdlog::pattern_formatter>();
    formatter->add_flag<SyslogPriority>('*').set_pattern("%*%l: %v");
    spdlog::set_formatter(std::move(formatter));
  } else {
    spdlog::set_pattern("%^%l%$: %v");
  }

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
  add_db_commands(app, action);
  add_token_commands(app, action);
  add_plant_commands(app, action);
  add_gear_commands(app, action);

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
