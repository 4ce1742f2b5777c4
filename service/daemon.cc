// The service process: start, reload on SIGHUP, stop on SIGTERM.
#include "service/daemon.h"

#include <signal.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <cstdio>
#include <memory>
#include <optional>

#include "acquisition/plc_link.h"
#include "job/nc_push.h"
#include "plant/central_history.h"
#include "plant/central_syncer.h"
#include "plant/outbox_sender.h"
#include "service/http_api.h"
#include "service/integrity_watch.h"
#include "service/plc_trigger.h"
#include "service/service.h"
#include "service/systemd_notify.h"
#include "storage/db_maintenance.h"

namespace gaugeloop {

namespace {

// The [plc] settings that need a restart, as one text to compare; empty without [plc].
std::string plc_text(const std::optional<PlcSettings>& p) {
  if (!p) return "";
  const ModbusSettings& l = p->link.link;
  return ModbusPlcLink(p->link).address() + " unit " + std::to_string(l.unit_id) + " base " +
         std::to_string(p->link.base_address) + " poll " + std::to_string(p->poll_interval.count()) + " timeout " +
         std::to_string(l.response_timeout.count());
}

Error not_starting(const Error& e, const std::string& what) {
  return Error{e.code, what + ", not starting: " + e.message};
}

// The database's header and schema checked (a file that is no database refused), upgraded if
// older (checked whole first: an upgrade reads it all anyway), and the pushes a power cut
// interrupted finished, before anything else reads the tables. The whole file is checked
// beside the service (IntegrityWatch), so a large one does not keep the grinder waiting.
Status prepare_database(const std::filesystem::path& db_path, const std::filesystem::path& nc_dir) {
  Result<RunStore> store = [&]() -> Result<RunStore> {
    if (!std::filesystem::exists(db_path)) return RunStore::open(db_path);
    if (Status h = check_database_header(db_path); !h) return h.error();
    Result<int> version = database_schema_version(db_path);
    if (!version) return version.error();
    if (*version < latest_database_schema_version()) return open_checked_for_writing(db_path);
    return RunStore::open(db_path);
  }();
  if (!store) return not_starting(Error{ErrorCode::kInvalidInput, store.error().message}, "database refused");
  if (const std::optional<SchemaUpgrade> upgrade = store->schema_upgrade()) {
    spdlog::info("database {} upgraded from schema version {}; the file as it was is kept in {}", db_path.string(),
                 upgrade->from_version, upgrade->backup.string());
  }
  store->set_nc_dir(nc_dir);
  Result<ReconcileReport> reconciled = reconcile_all_pushes(*store);
  if (!reconciled) return not_starting(reconciled.error(), "interrupted pushes could not be reconciled");
  for (const std::string& line : reconciled->messages) spdlog::warn("reconciled: {}", line);
  return {};
}

// The [plant.mqtt] settings that need a restart, as one text to compare; empty without it.
// The password is compared, never logged.
std::string mqtt_text(const std::optional<MqttSettings>& m) {
  if (!m) return "";
  return m->host + ":" + std::to_string(m->port) + " site " + m->site + " client " + m->client_id + " user " +
         m->username + " " + m->password + " tls " + m->ca_file.string() + " " + m->cert_file.string() + " " +
         m->key_file.string() + " keepalive " + std::to_string(m->keepalive_s) + " bound " +
         std::to_string(m->max_depth);
}

std::string central_text(const std::optional<CentralSyncSettings>& c) {
  if (!c) return "";
  return c->url + " every " + std::to_string(c->interval.count()) + " s, batches of " + std::to_string(c->batch_size) +
         (c->programs ? ", with program texts" : "") + (c->per_degree ? ", with per-degree tables" : "");
}

Result<std::unique_ptr<HttpApi>> start_http(Service& service, PlcTrigger* plc, const HttpSettings& settings,
                                            const std::filesystem::path& db_path) {
  HttpWrites writes;
  writes.trigger_measure = [&service](const std::string& part, int lobe, const std::string& note,
                                      const std::string& serial, const std::string& operator_name,
                                      std::optional<double> part_temperature_c) {
    return service.measure(part, lobe, note, serial, operator_name, part_temperature_c);
  };
  writes.approve = [&service](std::int64_t id, const std::string& by, const std::string& note) {
    return service.approve(id, by, note);
  };
  writes.reject = [&service](std::int64_t id, const std::string& by, const std::string& note) {
    return service.reject(id, by, note);
  };
  writes.rollback = [&service](const std::string& program, int version, const std::string& by) {
    return service.rollback(program, version, by);
  };
  writes.new_program = [&service](const std::string& part, int lobe, const std::string& by, bool replace) {
    return service.new_program(part, lobe, by, replace);
  };
  HttpStatus status;
  status.program_preview = [&service](const std::string& part, int lobe) {
    return service.preview_program(part, lobe);
  };
  status.health = [&service] { return service.health(); };
  status.extra_metrics = [&service, plc] { return service.metrics() + (plc ? plc->metrics() : ""); };
  status.shafts = [&service] { return service.config()->shafts; };  // a reload's shaft files at once
  Result<std::unique_ptr<HttpApi>> started = HttpApi::start(settings, db_path, writes, status);
  if (!started) return not_starting(started.error(), "HTTP API not started");
  // One line on stdout for whoever started us (tests, scripts) to find the port.
  const char* const scheme = settings.tls_cert.empty() ? "http" : "https";
  std::printf("listening on %s://%s:%d\n", scheme, settings.host.c_str(), (*started)->port());
  std::fflush(stdout);
  spdlog::info("HTTP API on {}://{}:{} ({})", scheme, settings.host, (*started)->port(),
               settings.token.empty() ? "read-only: no token configured" : "writes need the token");
  return started;
}

// What the service started with and keeps until it restarts.
struct StartedWith {
  std::optional<HttpSettings> http;
  std::optional<PlcSettings> plc;
  std::filesystem::path db_path;
  std::optional<MqttSettings> mqtt;
  std::string machine;
  std::optional<CentralSyncSettings> central;
};

// SIGHUP: a configuration that reads and checks whole replaces the one in force; what needs a
// restart ([plc], [http] but its token, the database path) is said, and the database path
// kept. A new token is in force at once (`http`, if the API runs, gets it; `started` keeps it).
void reload(Service& service, const std::filesystem::path& config_path, StartedWith& started, HttpApi* http) {
  Result<ServiceConfig> fresh = read_service_config(config_path);
  if (!fresh) {
    spdlog::error("reload refused, keeping the configuration in use: {}", fresh.error().message);
    service.record_event(EventKind::kFault, "config reload refused", "", 0, std::nullopt,
                         "reload refused, keeping the configuration in use: " + fresh.error().message);
    service.count_reload(false);  // after the event: once /api/health counts it, it is stored
    return;
  }
  if (plc_text(fresh->plc) != plc_text(started.plc)) {
    spdlog::warn("reload: [plc] changes take effect when the service restarts");
  }
  if (mqtt_text(fresh->mqtt) != mqtt_text(started.mqtt) || fresh->machine != started.machine) {
    spdlog::warn("reload: [plant.mqtt] and machine changes reach the broker when the service restarts");
  }
  if (central_text(fresh->central) != central_text(started.central)) {
    spdlog::warn("reload: [plant.central] changes take effect when the service restarts");
  }
  std::optional<HttpSettings>& was = started.http;
  if (fresh->http.has_value() != was.has_value() ||
      (fresh->http &&
       (fresh->http->host != was->host || fresh->http->port != was->port || fresh->http->tls_cert != was->tls_cert ||
        fresh->http->tls_key != was->tls_key || fresh->http->history_url != was->history_url))) {
    spdlog::warn("reload: [http] changes take effect when the service restarts");
  }
  if (fresh->http && was && http != nullptr && fresh->http->token != was->token) {
    // Never the token itself in the log: the journal is readable by more people than the file.
    http->set_token(fresh->http->token);
    was->token = fresh->http->token;
    spdlog::info("reload: HTTP token replaced{}", was->token.empty() ? "; no token now, the API is read-only" : "");
  }
  if (fresh->job.db_path != started.db_path) {
    spdlog::warn("reload: [database] path changes take effect when the service restarts");
    fresh->job.db_path = started.db_path;
  }
  const std::string line = "reloaded: " + describe_service_config(*fresh);
  spdlog::info("{}", line);
  service.replace_config(std::move(*fresh));
  service.record_event(EventKind::kInfo, "config reload", "", 0, std::nullopt, line);
  service.count_reload(true);  // last: once /api/health counts it, it is in force and stored
}

}  // namespace

Status configure_plant_outbox(const std::filesystem::path& db_path, const std::optional<MqttSettings>& mqtt) {
  Result<RunStore> store = RunStore::open(db_path);
  if (!store) return Error{store.error().code, "database refused, not starting: " + store.error().message};
  Result<OutboxCounts> counts = store->outbox_counts();
  if (!counts)
    return Error{counts.error().code, "the outbox could not be read, not starting: " + counts.error().message};
  if (!mqtt && !counts->settings.enabled) return {};
  const OutboxSettings wanted{mqtt.has_value(), mqtt ? mqtt->max_depth : counts->settings.max_depth};
  if (Status s = store->configure_outbox(wanted); !s)
    return Error{s.error().code, "the outbox could not be set, not starting: " + s.error().message};
  if (!mqtt) {
    spdlog::info("no [plant.mqtt]: the outbox is off; {} messages queued before stay in it", counts->depth);
  } else if (counts->depth > 0) {
    spdlog::info("outbox: {} messages wait for the broker since {}", counts->depth, counts->oldest_utc);
  }
  return {};
}

std::string describe_service_config(const ServiceConfig& c) {
  std::string parts;
  for (const ServicePart& p : c.parts) {
    parts += (parts.empty() ? "" : ", ") + p.file.part.name + " lobe " + std::to_string(p.file.part.lobe);
  }
  std::string plc = "none";
  if (c.plc) {
    std::string numbers;
    for (const ServicePart& p : c.parts) {
      if (!p.plc_part_number) continue;
      numbers += (numbers.empty() ? "" : ", ") + std::to_string(*p.plc_part_number) + " lobe " +
                 std::to_string(p.file.part.lobe) + " = " + p.file.part.name;
    }
    plc = ModbusPlcLink(c.plc->link).address() + " base " + std::to_string(c.plc->link.base_address) +
          " (part numbers " + numbers + ")";
  }
  const std::string broker = c.mqtt ? c.mqtt->host + ":" + std::to_string(c.mqtt->port) + " (site " + c.mqtt->site +
                                          (c.mqtt->ca_file.empty() ? "" : ", TLS") + ")"
                                    : std::string("none");
  std::string central = "none";
  if (c.central) {
    const Result<CentralUrl> url = parse_central_url(c.central->url);  // checked by the config reader
    central = url ? url->shown : c.central->url;
  }
  return c.source.string() + ": machine " + c.machine + ", parts " + parts + ", database " + c.job.db_path.string() +
         ", NC directory " + c.job.nc_dir.string() + ", PLC " + plc + ", plant broker " + broker +
         ", central history " + central +
         (c.http && !c.http->history_url.empty() ? " (the pages' run lists read it)" : "");
}

Status run_service(const std::filesystem::path& config_path) {
  // Block the signals before any thread starts, so only the loop below receives them.
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  sigaddset(&signals, SIGHUP);
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);

  Result<ServiceConfig> config = read_service_config(config_path);
  if (!config) return not_starting(config.error(), "configuration refused");
  StartedWith started{config->http, config->plc, config->job.db_path, config->mqtt, config->machine, config->central};
  const std::optional<HttpSettings>& http_settings = started.http;
  const std::optional<PlcSettings>& plc_settings = started.plc;
  const std::filesystem::path& db_path = started.db_path;
  // Taken away now, left again by a clean stop: missing at the next start means this run of the
  // service did not end cleanly, and the database is checked whole at once.
  const bool stopped_cleanly = take_clean_shutdown_marker(db_path);
  if (Status s = prepare_database(db_path, config->job.nc_dir); !s) return s;
  if (Status s = configure_plant_outbox(db_path, started.mqtt); !s) return s;
  // Before the service, so that it outlives every thread that tells it something; its end
  // publishes the offline state.
  std::atomic<const Service*> fault_sink{nullptr};  // the plant threads' faults, while the service exists
  const auto on_fault = [&fault_sink](std::string_view name, std::string_view what) {
    if (const Service* s = fault_sink.load()) {
      s->record_thread_fault(name, what);
    } else {
      spdlog::error("the {} thread was ended by an exception: {}", name, what);
    }
  };
  std::unique_ptr<OutboxSender> outbox;
  if (started.mqtt) {
    outbox = std::make_unique<OutboxSender>(db_path, *started.mqtt, started.machine, on_fault);
    spdlog::info("plant broker: {}:{} as {}, topics gaugeloop/{}/{}/...", started.mqtt->host, started.mqtt->port,
                 started.mqtt->client_id, started.mqtt->site, started.machine);
  }
  std::unique_ptr<CentralSyncer> central;
  if (started.central) {
    central = std::make_unique<CentralSyncer>(db_path, *started.central, started.machine, on_fault);
    spdlog::info("central history: {} synced every {} s and after each run, as machine {}", central->status().url,
                 started.central->interval.count(), started.machine);
  }
  Service service(std::move(*config));
  struct ForgetService {  // before the service ends, the sender's faults go back to the log
    std::atomic<const Service*>& sink;
    ~ForgetService() { sink = nullptr; }
  } forget_service{fault_sink};
  if (outbox || central) fault_sink = &service;
  if (central) service.set_central_sync(central.get());
  if (outbox) {
    service.set_outbox(outbox.get());
    service.plant_state("started", describe_service_config(*service.config()));
  }
  spdlog::info("starting: {}", describe_service_config(*service.config()));
  IntegrityWatch integrity(
      IntegrityWatch::Settings{db_path, !stopped_cleanly, std::chrono::hours(service.config()->integrity_check_hours)},
      [&service](const std::string& message) { service.set_database_damaged(message); }, on_fault);
  service.set_integrity_watch(&integrity);
  if (!stopped_cleanly) spdlog::info("the last stop was not clean: the database is checked whole beside the service");

  // Before the HTTP API, which reports its status; started after it.
  std::unique_ptr<PlcTrigger> plc;
  if (plc_settings) {
    plc = std::make_unique<PlcTrigger>(service, *plc_settings);
    service.set_plc_status([p = plc.get()] { return p->status(); });
  }
  std::unique_ptr<HttpApi> http;
  if (http_settings) {
    Result<std::unique_ptr<HttpApi>> api = start_http(service, plc.get(), *http_settings, db_path);
    if (!api) return api.error();
    http = std::move(*api);
  }
  if (plc) {
    spdlog::info("PLC trigger: handshake block at holding register {} of {}, polled every {} ms",
                 plc_settings->link.base_address, plc->address(), plc_settings->poll_interval.count());
    plc->start();
  }
  if (!http && !plc) spdlog::warn("no [http] and no [plc] table: nothing can trigger a run but `gaugeloop measure`");
  notify_started(http.get(), plc.get());
  // After the PLC trigger and the HTTP API it watches; destroyed before them.
  std::unique_ptr<Watchdog> watchdog = start_service_watchdog(http.get(), plc.get(), plc_settings);

  for (;;) {
    int sig = 0;
    if (sigwait(&signals, &sig) != 0) continue;
    if (sig == SIGHUP) {
      notify_reloading();
      reload(service, config_path, started, http.get());
      notify_started(http.get(), plc.get());  // the file taken or refused, the service runs on
      continue;
    }
    spdlog::info("{} received: letting the run in progress finish", sig == SIGTERM ? "SIGTERM" : "SIGINT");
    notify_stopping();
    // systemd times the stop from here (TimeoutStopSec), no longer the watchdog.
    watchdog.reset();
    service.set_stopping();  // no new run or push; /api/health says "stopping"
    service.plant_state("stopping");
    // The PLC is polled on, and told "not now" (code 7) for every request, until the last
    // run has ended, whoever started it, and the outcome of its own is in its registers.
    if (plc) plc->stop();
    service.stop();  // the run in progress if no PLC waited for it, then the events still waiting
    if (http) http->stop();
    integrity.stop();
    service.set_integrity_watch(nullptr);
    leave_clean_shutdown_marker(db_path);
    spdlog::info("stopped");
    return {};
  }
}

}  // namespace gaugeloop
