// serve: the background service beside the grinder. One run at a time, triggered over HTTP
// (and by hand with `gaugeloop measure`); SIGHUP reloads the configuration, SIGTERM lets the
// run in progress finish, stores it, and exits 0. docs/service.md.
#include <signal.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cstdio>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>

#include "acquisition/modbus_gauge.h"
#include "app/cli_common.h"
#include "app/http_api.h"
#include "app/measure_job.h"
#include "app/nc_push.h"
#include "app/service_config.h"

namespace gaugeloop {
namespace {

using nlohmann::json;

json report_json(const JobReport& r) {
  json j{{"run_id", r.run_id},
         {"pushed", r.pushed()},
         {"verdict", compensation_verdict_name(r.verdict)},
         {"max_abs_error_um", r.analysis.max_abs_error_um},
         {"rms_error_um", r.analysis.rms_error_um},
         {"phase_error_deg", r.analysis.phase_error_deg},
         {"base_circle_runout_um", r.analysis.base_circle_runout_um},
         {"repeatability_um", r.analysis.repeatability_um},
         {"correction_max_um", r.correction_max_um},
         {"interpolation", r.interpolation},
         {"table_blocks", r.table_blocks},
         {"command_error_um", r.command_error_um}};
  if (r.pushed()) {
    j["nc_file"] = r.nc_file.string();
    j["table_version"] = r.table_version;
  } else {
    j["not_pushed_reason"] = r.not_pushed_reason;
    j["pending_id"] = r.pending_id ? json(*r.pending_id) : json(nullptr);
  }
  return j;
}

// The service's state, shared by the HTTP threads and the signal loop.
class Service {
 public:
  explicit Service(ServiceConfig config) : config_(std::make_shared<const ServiceConfig>(std::move(config))) {}

  std::shared_ptr<const ServiceConfig> config() const {
    std::lock_guard<std::mutex> lock(config_mutex_);
    return config_;
  }

  // Takes a checked configuration into use; a run in progress finishes with the old one.
  void replace_config(ServiceConfig config) {
    std::lock_guard<std::mutex> lock(config_mutex_);
    config_ = std::make_shared<const ServiceConfig>(std::move(config));
  }

  // One measurement run, end to end. Refused (kRefused) while another runs or the service
  // stops: the PLC or the caller asks again.
  Result<json> measure(const std::string& part_name, int lobe, const std::string& note) {
    std::unique_lock<std::mutex> run_lock(run_mutex_, std::try_to_lock);
    if (!run_lock.owns_lock()) {
      return make_error(ErrorCode::kRefused, "a run is in progress; ask again when it is done (GET /api/health)");
    }
    if (stopping_) return make_error(ErrorCode::kRefused, "the service is stopping; no new run is started");
    const std::shared_ptr<const ServiceConfig> c = config();
    Result<const ServicePart*> part = find_part(*c, part_name, lobe);
    if (!part) return part.error();
    JobSettings js = job_for(*c, **part);
    js.note = note;
    measuring_ = true;
    spdlog::info("run requested: part {} lobe {} on {}", part_name, lobe, c->machine);
    ModbusGauge gauge(c->gauge);
    Result<JobReport> report = run_measure_job(gauge, js);
    measuring_ = false;
    if (!report) {
      ++runs_failed_;
      spdlog::error("run failed: part {} lobe {}: {}", part_name, lobe, report.error().message);
      return report.error();
    }
    if (report->pushed()) {
      ++runs_pushed_;
      spdlog::info("run {} stored: max lift error {:.2f} um; table version {} pushed to {} ({} blocks, {:.3f} um)",
                   report->run_id, report->analysis.max_abs_error_um, report->table_version, report->nc_file.string(),
                   report->table_blocks, report->command_error_um);
    } else {
      ++runs_not_pushed_;
      spdlog::warn("run {} stored, table not pushed: {}", report->run_id, report->not_pushed_reason);
    }
    return report_json(*report);
  }

  // A pending table approved over HTTP; the same as `gaugeloop nc approve` (no overwriting
  // of a hand-edited program over HTTP: that needs the command and its flag).
  Result<json> approve(std::int64_t pending_id, const std::string& by, const std::string& note) {
    std::lock_guard<std::mutex> one_push_at_a_time(run_mutex_);
    Result<RunStore> store = RunStore::open(config()->job.db_path);
    if (!store) return store.error();
    Result<PushOutcome> pushed = approve_pending(*store, pending_id, by, note, /*overwrite_edited=*/false);
    if (!pushed) return pushed.error();
    spdlog::info("pending table {} approved by {}: table version {} of run {} pushed to {}", pending_id, by,
                 pushed->table_version, pushed->run_id, pushed->nc_file);
    return json{{"nc_file", pushed->nc_file},
                {"table_version", pushed->table_version},
                {"run_id", pushed->run_id},
                {"decision_recorded", pushed->decision_recorded}};
  }

  // `program`: a program name (CAM_INTAKE_L1, with or without .SPF) in the configured NC
  // directory, or the NC file's path.
  Result<json> rollback(const std::string& program, int table_version, const std::string& by) {
    std::lock_guard<std::mutex> one_push_at_a_time(run_mutex_);
    const std::shared_ptr<const ServiceConfig> c = config();
    std::filesystem::path file(program);
    if (!file.has_parent_path()) {
      std::string name = program;
      if (name.size() > 4 && (name.ends_with(".SPF") || name.ends_with(".spf"))) name.resize(name.size() - 4);
      file = c->job.nc_dir / (name + ".SPF");
    }
    Result<RunStore> store = RunStore::open(c->job.db_path);
    if (!store) return store.error();
    Result<PushOutcome> pushed =
        rollback_to_version(*store, std::filesystem::absolute(file).lexically_normal().string(), table_version, by);
    if (!pushed) return pushed.error();
    spdlog::info("rollback by {}: {} table version {} is the table of version {} (run {})", by, pushed->nc_file,
                 pushed->table_version, table_version, pushed->run_id);
    return json{{"nc_file", pushed->nc_file}, {"table_version", pushed->table_version}, {"run_id", pushed->run_id}};
  }

  // Waits for a run in progress to end; no new run starts after this.
  void stop() {
    stopping_ = true;
    std::lock_guard<std::mutex> wait_for_run(run_mutex_);
  }

  json health() const {
    const std::shared_ptr<const ServiceConfig> c = config();
    json parts = json::array();
    for (const ServicePart& p : c->parts) parts.push_back({{"part", p.file.part.name}, {"lobe", p.file.part.lobe}});
    return {
        {"state", stopping_ ? "stopping" : (measuring_ ? "measuring" : "idle")},
        {"config", c->source.string()},
        {"machine", c->machine},
        {"gauge", c->gauge.transport == ModbusTransport::kRtu ? c->gauge.device
                                                              : c->gauge.host + ":" + std::to_string(c->gauge.port)},
        {"database", c->job.db_path.string()},
        {"parts", parts},
        {"config_reloads", reloads_.load()},
        {"config_reload_failures", reload_failures_.load()}};
  }

  std::string metrics() const {
    std::string m;
    m += "# HELP gaugeloop_service_runs_total Runs this service process ended, by outcome.\n";
    m += "# TYPE gaugeloop_service_runs_total counter\n";
    m += "gaugeloop_service_runs_total{outcome=\"pushed\"} " + std::to_string(runs_pushed_.load()) + "\n";
    m += "gaugeloop_service_runs_total{outcome=\"not_pushed\"} " + std::to_string(runs_not_pushed_.load()) + "\n";
    m += "gaugeloop_service_runs_total{outcome=\"failed\"} " + std::to_string(runs_failed_.load()) + "\n";
    m += "# HELP gaugeloop_service_measuring 1 while a run is being measured.\n";
    m += "# TYPE gaugeloop_service_measuring gauge\n";
    m += "gaugeloop_service_measuring " + std::string(measuring_ ? "1" : "0") + "\n";
    m += "# HELP gaugeloop_service_config_reloads_total Configuration reloads (SIGHUP), by result.\n";
    m += "# TYPE gaugeloop_service_config_reloads_total counter\n";
    m += "gaugeloop_service_config_reloads_total{result=\"ok\"} " + std::to_string(reloads_.load()) + "\n";
    m += "gaugeloop_service_config_reloads_total{result=\"failed\"} " + std::to_string(reload_failures_.load()) + "\n";
    return m;
  }

  void count_reload(bool ok) { ok ? ++reloads_ : ++reload_failures_; }

 private:
  mutable std::mutex config_mutex_;
  std::shared_ptr<const ServiceConfig> config_;
  std::mutex run_mutex_;  // held for the length of a run
  std::atomic<bool> measuring_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<long long> runs_pushed_{0};
  std::atomic<long long> runs_not_pushed_{0};
  std::atomic<long long> runs_failed_{0};
  std::atomic<long long> reloads_{0};
  std::atomic<long long> reload_failures_{0};
};

std::string describe(const ServiceConfig& c) {
  std::string parts;
  for (const ServicePart& p : c.parts) {
    parts += (parts.empty() ? "" : ", ") + p.file.part.name + " lobe " + std::to_string(p.file.part.lobe);
  }
  return c.source.string() + ": machine " + c.machine + ", parts " + parts + ", database " + c.job.db_path.string() +
         ", NC directory " + c.job.nc_dir.string();
}

struct ServeOptions {
  std::string config_path;
  bool check_only = false;
};

int cmd_serve(const ServeOptions& o) {
  // Block the signals before any thread starts, so only the loop below receives them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  Result<ServiceConfig> config = read_service_config(o.config_path);
  if (!config) {
    spdlog::error("configuration refused, not starting: {}", config.error().message);
    return exit_code_for(config.error().code);
  }
  if (o.check_only) {
    std::printf("configuration ok: %s\n", describe(*config).c_str());
    return kExitOk;
  }
  const std::optional<HttpSettings> http_settings = config->http;
  const std::filesystem::path db_path = config->job.db_path;
  Service service(std::move(*config));
  spdlog::info("starting: {}", describe(*service.config()));

  std::unique_ptr<HttpApi> http;
  if (http_settings) {
    HttpWrites writes;
    writes.trigger_measure = [&service](const std::string& part, int lobe, const std::string& note) {
      return service.measure(part, lobe, note);
    };
    writes.approve = [&service](std::int64_t id, const std::string& by, const std::string& note) {
      return service.approve(id, by, note);
    };
    writes.rollback = [&service](const std::string& program, int version, const std::string& by) {
      return service.rollback(program, version, by);
    };
    HttpStatus status;
    status.health = [&service] { return service.health(); };
    status.extra_metrics = [&service] { return service.metrics(); };
    Result<std::unique_ptr<HttpApi>> started = HttpApi::start(*http_settings, db_path, writes, status);
    if (!started) {
      spdlog::error("HTTP API not started, not starting: {}", started.error().message);
      return exit_code_for(started.error().code);
    }
    http = std::move(*started);
    // One line on stdout for whoever started us (tests, scripts) to find the port.
    std::printf("listening on http://%s:%d\n", http_settings->host.c_str(), http->port());
    std::fflush(stdout);
    spdlog::info("HTTP API on http://{}:{} ({})", http_settings->host, http->port(),
                 http_settings->token.empty() ? "read-only: no token configured" : "writes need the token");
  } else {
    spdlog::warn("no [http] table: nothing can trigger a run but `gaugeloop measure`");
  }

  for (;;) {
    int sig = 0;
    if (sigwait(&signals, &sig) != 0) continue;
    if (sig == SIGHUP) {
      Result<ServiceConfig> fresh = read_service_config(o.config_path);
      if (!fresh) {
        service.count_reload(false);
        spdlog::error("reload refused, keeping the configuration in use: {}", fresh.error().message);
        continue;
      }
      if (fresh->http.has_value() != http_settings.has_value() ||
          (fresh->http && (fresh->http->host != http_settings->host || fresh->http->port != http_settings->port ||
                           fresh->http->token != http_settings->token))) {
        spdlog::warn("reload: [http] changes take effect when the service restarts");
      }
      if (fresh->job.db_path != db_path) {
        spdlog::warn("reload: [database] path changes take effect when the service restarts");
        fresh->job.db_path = db_path;
      }
      service.count_reload(true);
      spdlog::info("reloaded: {}", describe(*fresh));
      service.replace_config(std::move(*fresh));
      continue;
    }
    spdlog::info("{} received: letting the run in progress finish", sig == SIGTERM ? "SIGTERM" : "SIGINT");
    service.stop();
    if (http) http->stop();
    spdlog::info("stopped");
    return kExitOk;
  }
}

}  // namespace

void add_serve_commands(CLI::App& app, CommandAction& action) {
  auto o = std::make_shared<ServeOptions>();
  CLI::App* serve =
      app.add_subcommand("serve",
                         "Run as the service beside the grinder: measure on request (HTTP), store, compensate, push. "
                         "SIGHUP reloads the config; SIGTERM finishes the run in progress and exits. docs/service.md");
  serve->add_option("--config", o->config_path, "Service configuration (TOML), see examples/service/gaugeloop.toml")
      ->required();
  serve->add_flag("--check", o->check_only, "Check the configuration (every part, template, limit) and exit");
  serve->callback([&action, o] { action = [o] { return cmd_serve(*o); }; });
}

}  // namespace gaugeloop
