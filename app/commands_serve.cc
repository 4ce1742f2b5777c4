// serve: the background service beside the grinder. One run at a time, triggered by the PLC
// (Modbus handshake), over HTTP, or by hand with `gaugeloop measure`; SIGHUP reloads the
// configuration, SIGTERM lets the run in progress finish, stores it, completes the PLC
// handshake, and exits 0. docs/service.md.
#include <signal.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "acquisition/modbus_gauge.h"
#include "acquisition/plc_link.h"
#include "app/cli_common.h"
#include "app/http_api.h"
#include "app/measure_job.h"
#include "app/nc_push.h"
#include "app/plc_handshake.h"
#include "app/service_config.h"
#include "storage/run_store.h"

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

  // The one run (or push) at a time: reserved, then released by whichever thread ends it.
  // Refused (kRefused) while another runs or the service stops: the PLC or the caller asks
  // again. Reserving before a run's thread starts lets the PLC trigger answer "not now" at
  // once, and makes a run it acknowledged certain to run, even if SIGTERM comes meanwhile.
  Status reserve_run() {
    std::lock_guard<std::mutex> lock(slot_mutex_);
    if (stopping_) return make_error(ErrorCode::kRefused, "the service is stopping; no new run is started");
    if (slot_taken_) {
      return make_error(ErrorCode::kRefused, "a run is in progress; ask again when it is done (GET /api/health)");
    }
    slot_taken_ = true;
    return {};
  }
  void release_run() {
    {
      std::lock_guard<std::mutex> lock(slot_mutex_);
      slot_taken_ = false;
    }
    slot_free_.notify_all();
  }

  // One measurement run over HTTP: run()'s report as JSON.
  Result<json> measure(const std::string& part_name, int lobe, const std::string& note) {
    if (Status s = reserve_run(); !s) return s.error();
    Result<JobReport> report = run_reserved(part_name, lobe, note);
    if (!report) return report.error();
    return report_json(*report);
  }

  // One measurement run, end to end, on a reservation (reserve_run) it releases. `stored_run`,
  // when given, receives the run's id as soon as it is stored, so a push that fails after
  // that can still name the run.
  // `ground_with`: the table version that ground the part, as the PLC said it (0: the design);
  // empty: not said.
  Result<JobReport> run_reserved(const std::string& part_name, int lobe, const std::string& note,
                                 std::optional<std::int64_t>* stored_run = nullptr,
                                 std::optional<int> ground_with = std::nullopt) {
    struct Release {
      Service* s;
      ~Release() { s->release_run(); }
    } release{this};
    const std::shared_ptr<const ServiceConfig> c = config();
    Result<const ServicePart*> part = find_part(*c, part_name, lobe);
    if (!part) {
      spdlog::warn("run not started: {}", part.error().message);
      record_event(EventKind::kRefusal, "run not started", part_name, lobe, std::nullopt, part.error().message);
      return part.error();
    }
    JobSettings js = job_for(*c, **part);
    js.note = note;
    js.ground_with_version = ground_with;
    js.ground_with_source = "plc";
    js.check_integrity = false;  // checked whole at start
    // Every step of the cycle: a log line and an event (docs/service.md, "The cycle").
    js.on_step = [this, c, part_name, lobe, stored_run](const JobStep& step) {
      if (stored_run != nullptr && step.run_id) *stored_run = step.run_id;
      spdlog::info("part {} lobe {}: {}: {}", part_name, lobe, step.code, step.message);
      record_event(*c, EventKind::kInfo, step.code, part_name, lobe, step.run_id, step.message);
    };
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
      const std::string line =
          fmt::format("run {} stored: max lift error {:.2f} um; table version {} pushed to {} ({} blocks, {:.3f} um)",
                      report->run_id, report->analysis.max_abs_error_um, report->table_version,
                      report->nc_file.string(), report->table_blocks, report->command_error_um);
      spdlog::info("{}", line);
      // Faults and refusals are recorded by the job; a pushed table is recorded here.
      record_event(EventKind::kInfo, "table pushed", part_name, lobe, report->run_id, line);
    } else {
      ++runs_not_pushed_;
      spdlog::warn("run {} stored, table not pushed: {}", report->run_id, report->not_pushed_reason);
    }
    return report;
  }

  // Keeps a step of the service in the database (`gaugeloop events`); a database that refuses
  // is logged, never fatal: the step itself was logged already.
  void record_event(EventKind kind, const std::string& code, const std::string& part, int lobe,
                    std::optional<std::int64_t> run_id, const std::string& message) const {
    record_event(*config(), kind, code, part, lobe, run_id, message);
  }
  // With the configuration a run was started with (a reload meanwhile changes nothing of it).
  void record_event(const ServiceConfig& c, EventKind kind, const std::string& code, const std::string& part, int lobe,
                    std::optional<std::int64_t> run_id, const std::string& message) const {
    EventRecord e;
    e.kind = kind;
    e.code = code;
    e.machine = c.machine;
    e.part = part;
    e.lobe = lobe;
    e.run_id = run_id;
    e.message = message;
    Result<RunStore> store = RunStore::open(c.job.db_path);
    Result<std::int64_t> id = store ? store->record_event(e) : Result<std::int64_t>(store.error());
    if (!id) spdlog::error("event '{}' not recorded in the database: {}", code, id.error().message);
  }

  // No new run is reserved from now on.
  void set_stopping() {
    std::lock_guard<std::mutex> lock(slot_mutex_);
    stopping_ = true;
  }

  // Waits for the run (or push) in progress, then takes the slot; for approvals and rollbacks,
  // which are short and wait rather than fail.
  void wait_and_reserve() {
    std::unique_lock<std::mutex> lock(slot_mutex_);
    slot_free_.wait(lock, [this] { return !slot_taken_; });
    slot_taken_ = true;
  }

  // A pending table approved over HTTP; the same as `gaugeloop nc approve` (no overwriting
  // of a hand-edited program over HTTP: that needs the command and its flag).
  Result<json> approve(std::int64_t pending_id, const std::string& by, const std::string& note) {
    wait_and_reserve();  // one push at a time
    struct Release {
      Service* s;
      ~Release() { s->release_run(); }
    } release{this};
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
    wait_and_reserve();  // one push at a time
    struct Release {
      Service* s;
      ~Release() { s->release_run(); }
    } release{this};
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
    std::unique_lock<std::mutex> lock(slot_mutex_);
    stopping_ = true;
    slot_free_.wait(lock, [this] { return !slot_taken_; });
  }

  // What the PLC trigger adds to /api/health; null when there is no [plc].
  void set_plc_status(std::function<json()> status) { plc_status_ = std::move(status); }

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
        {"config_reload_failures", reload_failures_.load()},
        {"plc", plc_status_ ? plc_status_() : json(nullptr)}};
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
  std::mutex slot_mutex_;
  std::condition_variable slot_free_;
  bool slot_taken_ = false;  // guarded by slot_mutex_: for the length of a run or a push
  std::atomic<bool> measuring_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<long long> runs_pushed_{0};
  std::atomic<long long> runs_not_pushed_{0};
  std::atomic<long long> runs_failed_{0};
  std::atomic<long long> reloads_{0};
  std::atomic<long long> reload_failures_{0};
  std::function<json()> plc_status_;  // set before any thread starts
};

// The outcome the PLC is told for a run (or a refusal to start one). `stored_run`: the run's
// id if it was stored, which a failure after that (the push) still reports.
PlcCycleOutcome plc_outcome(const Result<JobReport>& r, std::optional<std::int64_t> stored_run) {
  PlcCycleOutcome o;
  if (!r) {
    o.message = r.error().message;
    if (stored_run) {
      o.run_id = static_cast<std::uint32_t>(*stored_run);
      o.message = "run " + std::to_string(*stored_run) + " is stored; " + o.message;
    }
    switch (r.error().code) {
      case ErrorCode::kGaugeUnreachable:
      case ErrorCode::kGaugeTimeout:
      case ErrorCode::kGaugeProtocol:
      case ErrorCode::kIncompleteRun:
        o.code = PlcResultCode::kGaugeFault;
        break;
      case ErrorCode::kStorage:
        o.code = PlcResultCode::kStorageFault;
        break;
      case ErrorCode::kIo:
        o.code = PlcResultCode::kNcFault;
        break;
      case ErrorCode::kNotFound:  // the part left the configuration on a reload meanwhile
        o.code = PlcResultCode::kUnknownPart;
        break;
      default:
        o.code = PlcResultCode::kOtherFault;
        break;
    }
    return o;
  }
  // Run ids beyond 32 bits are not expected in a machine's lifetime; the PLC would see them cut.
  o.run_id = static_cast<std::uint32_t>(r->run_id);
  if (r->pushed()) {
    o.code = PlcResultCode::kTablePushed;
    o.table_version = static_cast<std::uint16_t>(r->table_version);
    o.message = "table version " + std::to_string(r->table_version) + " pushed to " + r->nc_file.string();
  } else {
    o.code = r->pending_id ? PlcResultCode::kTableHeld : PlcResultCode::kTableRefused;
    o.message = "table not pushed: " + r->not_pushed_reason;
  }
  return o;
}

// Runs a PLC request's cycle on a thread of its own, so the handshake keeps polling (and the
// heartbeat counting) while the lobe is measured. Used by the PLC trigger's thread only.
class ServiceCycleRunner final : public PlcCycleRunner {
 public:
  explicit ServiceCycleRunner(Service& service) : service_(service) {}
  ~ServiceCycleRunner() override {
    if (worker_.joinable()) worker_.join();
  }

  std::optional<PlcCycleOutcome> start(const PlcRequestWords& request) override {
    const std::uint16_t part_number = request.part_number;
    const std::uint16_t lobe = request.lobe;
    const std::optional<int> ground_with = request.ground_with_version();
    const std::shared_ptr<const ServiceConfig> c = service_.config();
    Result<const ServicePart*> part = find_plc_part(*c, part_number, lobe);
    if (!part) return PlcCycleOutcome{PlcResultCode::kUnknownPart, 0, 0, part.error().message};
    if (Status s = service_.reserve_run(); !s) return PlcCycleOutcome{PlcResultCode::kNotNow, 0, 0, s.error().message};
    if (worker_.joinable()) worker_.join();
    finished_ = false;
    const std::string name = (*part)->file.part.name;
    const std::string note = "PLC request: part number " + std::to_string(part_number);
    worker_ = std::thread([this, name, lobe, note, ground_with] {
      std::optional<std::int64_t> stored_run;
      Result<JobReport> report = service_.run_reserved(name, lobe, note, &stored_run, ground_with);
      PlcCycleOutcome o = plc_outcome(report, stored_run);
      std::lock_guard<std::mutex> lock(mutex_);
      outcome_ = std::move(o);
      finished_ = true;
    });
    return std::nullopt;
  }

  std::optional<PlcCycleOutcome> poll() override {
    std::unique_lock<std::mutex> lock(mutex_);
    if (!finished_) return std::nullopt;
    finished_ = false;
    std::optional<PlcCycleOutcome> o = std::move(outcome_);
    outcome_.reset();
    lock.unlock();
    worker_.join();
    return o;
  }

 private:
  Service& service_;
  std::thread worker_;
  std::mutex mutex_;
  bool finished_ = false;                   // guarded by mutex_
  std::optional<PlcCycleOutcome> outcome_;  // guarded by mutex_
};

// The PLC trigger: polls the handshake block every poll interval on a thread of its own, logs
// each step once and keeps it as an event. stop() returns once no cycle is in progress and
// its outcome is in the PLC's registers (or the link is down and cannot carry it).
class PlcTrigger {
 public:
  PlcTrigger(Service& service, PlcSettings settings)
      : service_(service),
        settings_(std::move(settings)),
        link_(settings_.link),
        runner_(service_),
        handshake_(link_, runner_) {}
  ~PlcTrigger() { stop(); }

  void start() {
    thread_ = std::thread([this] { loop(); });
  }

  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  std::string address() const { return link_.address(); }

  json status() const {
    return {{"address", address()},
            {"connected", connected_.load()},
            {"state", std::string(plc_state_name(static_cast<PlcState>(state_.load())))},
            {"requests", requests_.load()}};
  }

  std::string metrics() const {
    std::string m;
    m += "# HELP gaugeloop_plc_connected 1 while the link to the PLC's handshake registers is up.\n";
    m += "# TYPE gaugeloop_plc_connected gauge\n";
    m += "gaugeloop_plc_connected " + std::string(connected_ ? "1" : "0") + "\n";
    m += "# HELP gaugeloop_plc_requests_total PLC requests taken (runs started or refused).\n";
    m += "# TYPE gaugeloop_plc_requests_total counter\n";
    m += "gaugeloop_plc_requests_total " + std::to_string(requests_.load()) + "\n";
    return m;
  }

 private:
  void loop() {
    for (;;) {
      const std::vector<PlcEvent> events = handshake_.step();
      for (PlcEvent e : events) report(e);
      connected_ = handshake_.connected();
      state_ = static_cast<int>(handshake_.state());
      std::unique_lock<std::mutex> lock(mutex_);
      if (stop_ && handshake_.state() != PlcState::kBusy) {
        if (handshake_.outcome_delivered()) break;
        if (!handshake_.connected()) {
          spdlog::error("PLC at {}: stopping with the outcome of the last request undelivered (link down): {}",
                        address(), handshake_.last_link_error());
          break;
        }
      }
      wake_.wait_for(lock, settings_.poll_interval);
    }
  }

  std::string request_text() const {
    const PlcRequestWords& r = handshake_.request();
    return "PLC request part number " + std::to_string(r.part_number) + " lobe " + std::to_string(r.lobe);
  }

  // The configured part the request names, for the events; empty when none.
  std::string part_name() const {
    const PlcRequestWords& r = handshake_.request();
    Result<const ServicePart*> p = find_plc_part(*service_.config(), r.part_number, r.lobe);
    return p ? (*p)->file.part.name : std::string();
  }

  void report(PlcEvent e) {
    const int lobe = handshake_.request().lobe;
    switch (e) {
      case PlcEvent::kConnected:
        spdlog::info("PLC link up at {}{}", address(), link_down_ ? " again" : "");
        if (link_down_)
          service_.record_event(EventKind::kInfo, "plc link up", "", 0, std::nullopt,
                                "PLC link at " + address() + " up again");
        link_down_ = false;
        break;
      case PlcEvent::kConnectFailed:
        if (!link_down_) {  // once per loss, not once per attempt
          spdlog::warn("PLC link down: {}; retrying with backoff", handshake_.last_link_error());
          service_.record_event(EventKind::kFault, "plc link down", "", 0, std::nullopt, handshake_.last_link_error());
        }
        link_down_ = true;
        break;
      case PlcEvent::kLinkLost:
        if (!link_down_) {
          spdlog::warn("PLC link lost: {}; reconnecting with backoff", handshake_.last_link_error());
          service_.record_event(EventKind::kFault, "plc link down", "", 0, std::nullopt, handshake_.last_link_error());
        }
        link_down_ = true;
        break;
      case PlcEvent::kRequestAccepted: {
        ++requests_;
        const std::string part = part_name();
        spdlog::info("{} ({} lobe {}): acknowledged, measuring", request_text(), part, lobe);
        service_.record_event(EventKind::kInfo, "plc request", part, lobe, std::nullopt,
                              request_text() + ": acknowledged, measuring");
        break;
      }
      case PlcEvent::kRequestRefused:
        ++requests_;
        spdlog::warn("{}: refused: {}", request_text(), handshake_.outcome()->message);
        service_.record_event(EventKind::kInfo, "plc request", part_name(), lobe, std::nullopt,
                              request_text() + ": refused: " + handshake_.outcome()->message);
        break;
      case PlcEvent::kCycleEnded:
        break;  // the run logged its own outcome; the PLC is told at kOutcomeWritten
      case PlcEvent::kOutcomeWritten: {
        const PlcCycleOutcome& o = *handshake_.outcome();
        const bool done = plc_result_is_done(o.code);
        const std::string line =
            request_text() + ": " + (done ? "done" : "fault") + ", result code " +
            std::to_string(static_cast<int>(o.code)) + " (" + std::string(plc_result_name(o.code)) + ")" +
            (o.run_id != 0 ? ", run " + std::to_string(o.run_id) : std::string()) + ": " + o.message;
        if (done) {
          spdlog::info("{}", line);
        } else {
          spdlog::warn("{}", line);
        }
        service_.record_event(EventKind::kInfo, done ? "plc done" : "plc fault", part_name(), lobe,
                              o.run_id != 0 ? std::optional<std::int64_t>(o.run_id) : std::nullopt, line);
        break;
      }
      case PlcEvent::kCleared:
        spdlog::info("{}: cleared by the PLC; ready", request_text());
        break;
      case PlcEvent::kClearedEarly:
        spdlog::warn("{}: the PLC cleared the request while busy; the run goes on and is stored", request_text());
        break;
    }
  }

  Service& service_;
  const PlcSettings settings_;
  ModbusPlcLink link_;  // the trigger thread's only
  ServiceCycleRunner runner_;
  PlcHandshake handshake_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;       // guarded by mutex_
  bool link_down_ = false;  // trigger thread only
  std::atomic<bool> connected_{false};
  std::atomic<int> state_{0};
  std::atomic<long long> requests_{0};
};

std::string describe(const ServiceConfig& c) {
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
  return c.source.string() + ": machine " + c.machine + ", parts " + parts + ", database " + c.job.db_path.string() +
         ", NC directory " + c.job.nc_dir.string() + ", PLC " + plc;
}

// The [plc] settings that need a restart, as one text to compare; empty without [plc].
std::string plc_text(const std::optional<PlcSettings>& p) {
  if (!p) return "";
  const ModbusSettings& l = p->link.link;
  return ModbusPlcLink(p->link).address() + " unit " + std::to_string(l.unit_id) + " base " +
         std::to_string(p->link.base_address) + " poll " + std::to_string(p->poll_interval.count()) + " timeout " +
         std::to_string(l.response_timeout.count());
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
  const std::optional<PlcSettings> plc_settings = config->plc;
  const std::filesystem::path db_path = config->job.db_path;
  {
    Result<RunStore> store = open_checked_for_writing(db_path);
    if (!store) {
      spdlog::error("database refused, not starting: {}", store.error().message);
      return kExitBadInput;
    }
    // Pushes a power cut interrupted are finished before anything else reads the tables.
    Result<ReconcileReport> reconciled = reconcile_all_pushes(*store);
    if (!reconciled) {
      spdlog::error("interrupted pushes could not be reconciled, not starting: {}", reconciled.error().message);
      return exit_code_for(reconciled.error().code);
    }
    for (const std::string& line : reconciled->messages) spdlog::warn("reconciled: {}", line);
  }
  Service service(std::move(*config));
  spdlog::info("starting: {}", describe(*service.config()));

  // Before the HTTP API, which reports its status; started after it.
  std::unique_ptr<PlcTrigger> plc;
  if (plc_settings) {
    plc = std::make_unique<PlcTrigger>(service, *plc_settings);
    service.set_plc_status([p = plc.get()] { return p->status(); });
  }

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
    status.extra_metrics = [&service, p = plc.get()] { return service.metrics() + (p ? p->metrics() : ""); };
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
  }
  if (plc) {
    spdlog::info("PLC trigger: handshake block at holding register {} of {}, polled every {} ms",
                 plc_settings->link.base_address, plc->address(), plc_settings->poll_interval.count());
    plc->start();
  }
  if (!http && !plc) spdlog::warn("no [http] and no [plc] table: nothing can trigger a run but `gaugeloop measure`");

  for (;;) {
    int sig = 0;
    if (sigwait(&signals, &sig) != 0) continue;
    if (sig == SIGHUP) {
      Result<ServiceConfig> fresh = read_service_config(o.config_path);
      if (!fresh) {
        spdlog::error("reload refused, keeping the configuration in use: {}", fresh.error().message);
        service.record_event(EventKind::kFault, "config reload refused", "", 0, std::nullopt,
                             "reload refused, keeping the configuration in use: " + fresh.error().message);
        service.count_reload(false);  // after the event: once /api/health counts it, it is stored
        continue;
      }
      if (plc_text(fresh->plc) != plc_text(plc_settings)) {
        spdlog::warn("reload: [plc] changes take effect when the service restarts");
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
      const std::string line = "reloaded: " + describe(*fresh);
      spdlog::info("{}", line);
      service.replace_config(std::move(*fresh));
      service.record_event(EventKind::kInfo, "config reload", "", 0, std::nullopt, line);
      service.count_reload(true);  // last: once /api/health counts it, it is in force and stored
      continue;
    }
    spdlog::info("{} received: letting the run in progress finish", sig == SIGTERM ? "SIGTERM" : "SIGINT");
    service.set_stopping();
    if (plc) plc->stop();  // after the run in progress, done or fault is written to the PLC
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
