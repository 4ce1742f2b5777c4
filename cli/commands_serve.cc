// serve: the background service beside the grinder (service/daemon.h, docs/service.md).
#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>

#include "cli/cli_common.h"
#include "service/daemon.h"

namespace gaugeloop {
namespace {

struct ServeOptions {
  std::string config_path;
  bool check_only = false;
};

int cmd_serve(const ServeOptions& o) {
  if (o.check_only) {
    Result<ServiceConfig> config = read_service_config(o.config_path);
    if (!config) {
      spdlog::error("configuration refused, not starting: {}", config.error().message);
      return exit_code_for(config.error().code);
    }
    std::printf("configuration ok: %s\n", describe_service_config(*config).c_str());
    return kExitOk;
  }
  if (Status s = run_service(o.config_path); !s) return report_error(s.error());
  return kExitOk;
}

}  // namespace

void add_serve_commands(CLI::App& app, CommandAction& action) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* serve =
      app.add_subcommand("serve",
                         "Run as the service beside the grinder: measure on request (PLC handshake over Modbus, HTTP), "
                         "store, compensate, push. SIGHUP reloads the config; SIGTERM finishes the run in progress, "
                         "answers the PLC and exits. docs/service.md");
  serve->add_option("--config", o->config_path, "Service configuration (TOML), see examples/service/gaugeloop.toml")
      ->required();
  serve->add_flag("--check", o->check_only,
                  "Check the configuration (every part, template, limit, PLC part number) and exit");
  serve->callback([&action, o] { action = [o] { return cmd_serve(*o); }; });
}

}  // namespace gaugeloop
