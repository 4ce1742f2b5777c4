// The service's state: configuration, the one run at a time, the runs and their counters.
#include "service/service.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <utility>

#include "acquisition/modbus_gauge.h"
#include "job/nc_push.h"

namespace gaugeloop {

using nlohmann::json;

RunReservation& RunReservation::operator=(RunReservation&& other) noexcept {
  if (this != &other) {
    release();
    service_ = std::exchange(other.service_, nullptr);
  }
  return *this;
}

void RunReservation::release() {
  if (Service* s = std::exchange(service_, nullptr)) s->release_run();
}

GaugeFactory modbus_gauge_factory() {
  return [](const ServiceConfig& c) -> std::unique_ptr<GaugeClient> { return std::make_unique<ModbusGauge>(c.gauge); };
}

// Every field is in every answer; one that does not apply to this run is null, never an
// empty text or a 0 that reads as a figure: no table was built (a refused correction, an
// inspection, a part the table in force did not grind), or none was pushed.
json job_report_json(const JobReport& r) {
  const bool built = !r.interpolation.empty();
  const auto if_built = [built](const json& value) { return built ? value : json(nullptr); };
  const auto if_pushed = [&r](const json& value) { return r.pushed() ? value : json(nullptr); };
  return json{{"run_id", r.run_id},
              {"pushed", r.pushed()},
              {"verdict", compensation_verdict_name(r.verdict)},
              {"max_abs_error_um", r.analysis.max_abs_error_um},
              {"rms_error_um", r.analysis.rms_error_um},
              {"phase_error_deg", r.analysis.phase_error_deg},
              {"base_circle_runout_um", r.analysis.base_circle_runout_um},
              {"repeatability_um", r.analysis.repeatability_um},
              {"correction_max_um", r.correction_max_um},
              {"interpolation", if_built(r.interpolation)},
              {"table_blocks", if_built(r.table_blocks)},
              {"command_error_um", if_built(r.command_error_um)},
              {"nc_file", if_pushed(r.nc_file.string())},
              {"table_version", if_pushed(r.table_version)},
              {"not_pushed_reason", r.pushed() ? json(nullptr) : json(r.not_pushed_reason)},
              {"pending_id", r.pending_id ? json(*r.pending_id) : json(nullptr)}};
}

Service::Service(ServiceConfig config, GaugeFactory gauge)
    : gauge_factory_(std::move(gauge)), config_(std::make_shared<const ServiceConfig>(std::move(config))) {}

std::shared_ptr<const ServiceConfig> Service::config() const {
  std::lock_guard<std::mutex> lock(config_mutex_);
  return config_;
}

void Service::replace_config(ServiceConfig config) {
  std::lock_guard<std::mutex> lock(config_mutex_);
  config_ = std::make_shared<const ServiceConfig>(std::move(config));
}

Result<RunReservation> Service::reserve_run() {
  std::lock_guard<std::mutex> lock(slot_mutex_);
  if (stopping_) return make_error(ErrorCode::kRefused, "the service is stopping; no new run is started");
  if (slot_taken_) {
    return make_error(ErrorCode::kRefused, "a run is in progress; ask again when it is done (GET /api/health)");
  }
  slot_taken_ = true;
  return RunReservation(this);
}

RunReservation Service::wait_and_reserve() {
  std::unique_lock<std::mutex> lock(slot_mutex_);
  slot_free_.wait(lock, [this] { return !slot_taken_; });
  slot_taken_ = true;
  return RunReservation(this);
}

void Service::release_run() {
  {
    std::lock_guard<std::mutex> lock(slot_mutex_);
    slot_taken_ = false;
  }
  slot_free_.notify_all();
}

Result<json> Service::measure(const std::string& part_name, int lobe, const std::string& note) {
  Result<RunReservation> reservation = reserve_run();
  if (!reservation) return reservation.error();
  Result<JobReport> report = run_reserved(std::move(*reservation), part_name, lobe, note);
  if (!report) return report.error();
  return job_report_json(*report);
}

Result<JobReport> Service::run_reserved(RunReservation reservation, const std::string& part_name, int lobe,
                                        const std::string& note, std::optional<std::int64_t>* stored_run,
                                        std::optional<int> ground_with) {
  const RunReservation held = std::move(reservation);  // released when this run ends, however
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
  struct Measuring {  // the flag /api/health shows, down again however the run ends
    std::atomic<bool>& flag;
    explicit Measuring(std::atomic<bool>& f) : flag(f) { flag = true; }
    ~Measuring() { flag = false; }
  };
  Result<JobReport> report = [&] {
    const Measuring measuring(measuring_);
    spdlog::info("run requested: part {} lobe {} on {}", part_name, lobe, c->machine);
    const std::unique_ptr<GaugeClient> gauge = gauge_factory_(*c);
    return run_measure_job(*gauge, js);
  }();
  if (!report) {
    ++runs_failed_;
    spdlog::error("run failed: part {} lobe {}: {}", part_name, lobe, report.error().message);
    return report.error();
  }
  if (report->pushed()) {
    ++runs_pushed_;
    const std::string line =
        fmt::format("run {} stored: max lift error {:.2f} um; table version {} pushed to {} ({} blocks, {:.3f} um)",
                    report->run_id, report->analysis.max_abs_error_um, report->table_version, report->nc_file.string(),
                    report->table_blocks, report->command_error_um);
    spdlog::info("{}", line);
    // Faults and refusals are recorded by the job; a pushed table is recorded here.
    record_event(EventKind::kInfo, "table pushed", part_name, lobe, report->run_id, line);
  } else {
    ++runs_not_pushed_;
    spdlog::warn("run {} stored, table not pushed: {}", report->run_id, report->not_pushed_reason);
  }
  return report;
}

void Service::record_event(EventKind kind, const std::string& code, const std::string& part, int lobe,
                           std::optional<std::int64_t> run_id, const std::string& message) const {
  record_event(*config(), kind, code, part, lobe, run_id, message);
}

void Service::record_event(const ServiceConfig& c, EventKind kind, const std::string& code, const std::string& part,
                           int lobe, std::optional<std::int64_t> run_id, const std::string& message) const {
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

void Service::record_thread_fault(std::string_view thread_name, std::string_view what) const {
  ++thread_faults_;
  const std::string line = fmt::format("the {} thread was ended by an exception: {}", thread_name, what);
  spdlog::error("{}", line);
  record_event(EventKind::kFault, "internal error", "", 0, std::nullopt, line);
}

void Service::set_stopping() {
  std::lock_guard<std::mutex> lock(slot_mutex_);
  stopping_ = true;
}

void Service::stop() {
  std::unique_lock<std::mutex> lock(slot_mutex_);
  stopping_ = true;
  slot_free_.wait(lock, [this] { return !slot_taken_; });
}

Result<json> Service::approve(std::int64_t pending_id, const std::string& by, const std::string& note) {
  const RunReservation held = wait_and_reserve();  // one push at a time
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

Result<json> Service::rollback(const std::string& program, int table_version, const std::string& by) {
  const RunReservation held = wait_and_reserve();  // one push at a time
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

json Service::health() const {
  const std::shared_ptr<const ServiceConfig> c = config();
  json parts = json::array();
  for (const ServicePart& p : c->parts) parts.push_back({{"part", p.file.part.name}, {"lobe", p.file.part.lobe}});
  return {{"state", stopping_ ? "stopping" : (measuring_ ? "measuring" : "idle")},
          {"config", c->source.string()},
          {"machine", c->machine},
          {"gauge", c->gauge.transport == ModbusTransport::kRtu ? c->gauge.device
                                                                : c->gauge.host + ":" + std::to_string(c->gauge.port)},
          {"database", c->job.db_path.string()},
          {"parts", parts},
          {"config_reloads", reloads_.load()},
          {"config_reload_failures", reload_failures_.load()},
          {"thread_faults", thread_faults_.load()},
          {"plc", plc_status_ ? plc_status_() : json(nullptr)}};
}

std::string Service::metrics() const {
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
  m += "# HELP gaugeloop_service_thread_faults_total Threads of the service ended by an exception.\n";
  m += "# TYPE gaugeloop_service_thread_faults_total counter\n";
  m += "gaugeloop_service_thread_faults_total " + std::to_string(thread_faults_.load()) + "\n";
  return m;
}

}  // namespace gaugeloop
