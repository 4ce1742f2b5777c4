// The service's state: configuration, the one run at a time, the runs and their counters.
#include "service/service.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <deque>
#include <thread>
#include <utility>

#include "acquisition/modbus_gauge.h"
#include "core/guarded_thread.h"
#include "core/utc_time.h"
#include "job/nc_push.h"
#include "plant/central_syncer.h"
#include "plant/outbox_sender.h"
#include "report/run_json.h"
#include "service/integrity_watch.h"

namespace gaugeloop {

using nlohmann::json;

// The service's events written on a thread of their own, with one connection kept open, so
// no thread that records one (the PLC trigger's above all) waits for the database.
class EventWriter {
 public:
  // `after_run_events` is called (on the writer's thread) once events of a run are written.
  explicit EventWriter(std::function<void()> after_run_events) : after_run_events_(std::move(after_run_events)) {
    thread_ = start_guarded_thread("event writer",
                                   [this] {
                                     // An exception while writing is logged and the writer goes on: the queue must
                                     // drain.
                                     while (!run_guarded(
                                         "event writer", [this] { loop(); },
                                         [](std::string_view name, std::string_view what) {
                                           spdlog::error("the {} thread was ended by an exception: {}; it starts again",
                                                         name, what);
                                         })) {
                                     }
                                   },
                                   {});
  }
  ~EventWriter() { stop(kEventDrainLimit); }

  // Queued in order; the oldest dropped when full.
  void push(std::filesystem::path db_path, EventRecord event) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (stopped_) {
      spdlog::error("event '{}' not recorded in the database: the service has stopped: {}", event.code, event.message);
      return;
    }
    if (queue_.size() >= kEventQueueLimit) {
      const EventRecord& oldest = queue_.front().event;
      ++dropped_;
      spdlog::error(
          "event '{}' of {} dropped unwritten: the database {} is locked or refusing and {} events wait, the most "
          "the service keeps; {} dropped so far",
          oldest.code, oldest.at_utc, queue_.front().db_path.string(), queue_.size(), dropped_.load());
      queue_.pop_front();
      ++settled_;
      written_.notify_all();
    }
    queue_.push_back({std::move(db_path), std::move(event)});
    ++queued_;
    wake_.notify_all();
  }

  bool flush(std::chrono::milliseconds within) {
    std::unique_lock<std::mutex> lock(mutex_);
    const std::uint64_t target = queued_;
    return written_.wait_for(lock, within, [this, target] { return settled_ >= target; });
  }

  // Waits at most `within` for the queue to be written, then ends the writer (an attempt
  // under way ends first) and logs what was lost. Idempotent.
  void stop(std::chrono::milliseconds within) {
    {
      std::unique_lock<std::mutex> lock(mutex_);
      if (stopped_) return;
      written_.wait_for(lock, within, [this] { return settled_ >= queued_; });
      stopped_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
    std::lock_guard<std::mutex> lock(mutex_);
    if (!queue_.empty()) {
      spdlog::error("stopping: {} events not recorded in the database {} ({}), the first '{}' of {}: {}", queue_.size(),
                    queue_.front().db_path.string(), last_error_, queue_.front().event.code,
                    queue_.front().event.at_utc, queue_.front().event.message);
      settled_ += queue_.size();
      queue_.clear();
    }
    written_.notify_all();
  }

  long long dropped() const { return dropped_; }

 private:
  struct Item {
    std::filesystem::path db_path;
    EventRecord event;
  };

  // Writes the oldest events, up to kEventBatch of one database in one transaction, until they
  // are written (or refused for good), then the next. The events being written are out of the
  // queue: a full queue drops only events still waiting.
  void loop() {
    std::unique_lock<std::mutex> lock(mutex_);
    for (;;) {
      wake_.wait(lock, [this] { return stopped_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopped with nothing left
      std::vector<Item> batch;
      while (!queue_.empty() && batch.size() < kEventBatch &&
             (batch.empty() || queue_.front().db_path == batch.front().db_path)) {
        batch.push_back(std::move(queue_.front()));
        queue_.pop_front();
      }
      for (;;) {
        lock.unlock();
        Status written = write(batch);
        if (!written.ok() && written.error().code != ErrorCode::kStorage && batch.size() > 1) {
          // One of them is refused (a bad code or time): the others one by one, that one logged.
          written = Status{};
          for (const Item& item : batch) {
            if (Status one = write({item}); !one.ok()) {
              spdlog::error("event '{}' not recorded in the database: {}", item.event.code, one.error().message);
            }
          }
        }
        lock.lock();
        if (written.ok() || written.error().code != ErrorCode::kStorage) {
          if (!written.ok()) {
            spdlog::error("event '{}' not recorded in the database: {}", batch.front().event.code,
                          written.error().message);
          }
          if (failures_ > 0) {
            spdlog::info("events written to the database {} again after {} failed attempts",
                         batch.front().db_path.string(), failures_);
            failures_ = 0;
          }
          settled_ += batch.size();
          written_.notify_all();
          // Events of a run written after the run's own sync: the plant hears of them now, not at
          // the next interval.
          const bool of_a_run =
              written.ok() && std::any_of(batch.begin(), batch.end(), [](const Item& i) { return i.event.run_id; });
          if (of_a_run && after_run_events_) {
            lock.unlock();
            after_run_events_();
            lock.lock();
          }
          break;
        }
        // Busy or refusing: the same events again after a pause (the database's busy timeout
        // has waited already), until stop() gives up, which finds them first in the queue.
        last_error_ = written.error().message;
        if (failures_++ == 0) {
          spdlog::warn("events wait for the database: '{}' not written yet: {}; retrying", batch.front().event.code,
                       last_error_);
        }
        if (!stopped_) wake_.wait_for(lock, std::chrono::milliseconds(200), [this] { return stopped_; });
        if (stopped_) {
          for (auto it = batch.rbegin(); it != batch.rend(); ++it) queue_.push_front(std::move(*it));
          return;
        }
      }
    }
  }

  Status write(const std::vector<Item>& items) {
    if (!store_ || store_path_ != items.front().db_path) {
      store_.reset();
      Result<RunStore> opened = RunStore::open(items.front().db_path);
      if (!opened) return opened.error();
      store_.emplace(std::move(*opened));
      store_path_ = items.front().db_path;
    }
    Status written;
    if (items.size() == 1) {
      Result<std::int64_t> id = store_->record_event(items.front().event);
      if (!id) written = id.error();
    } else {
      std::vector<EventRecord> events;
      events.reserve(items.size());
      for (const Item& item : items) events.push_back(item.event);
      written = store_->record_events(events);
    }
    if (!written.ok() && written.error().code == ErrorCode::kStorage) store_.reset();  // opened again next time
    return written;
  }

  std::mutex mutex_;
  std::condition_variable wake_;     // the writer: an event queued, or stop
  std::condition_variable written_;  // flush and stop: an event written or dropped
  std::deque<Item> queue_;           // guarded by mutex_, oldest first
  std::uint64_t queued_ = 0;         // guarded by mutex_: events ever queued
  std::uint64_t settled_ = 0;        // guarded by mutex_: of those, written, refused or dropped
  bool stopped_ = false;             // guarded by mutex_
  std::string last_error_;           // guarded by mutex_
  long long failures_ = 0;           // writer thread: failed attempts in a row
  std::atomic<long long> dropped_{0};
  std::optional<RunStore> store_;  // writer thread only
  std::filesystem::path store_path_;
  std::function<void()> after_run_events_;
  std::thread thread_;
};

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
              {"pending_id", r.pending_id ? json(*r.pending_id) : json(nullptr)},
              {"history_warning", r.history_warning.empty() ? json(nullptr) : json(r.history_warning)},
              {"tolerance_verdict", verdict_name(r.tolerance_verdict)},
              {"characteristics", characteristics_json(r.characteristics, part_kind_of(r.characteristics))}};
}

Service::Service(ServiceConfig config, GaugeFactory gauge)
    : gauge_factory_(std::move(gauge)),
      config_(std::make_shared<const ServiceConfig>(std::move(config))),
      events_(std::make_unique<EventWriter>([this] {
        if (CentralSyncer* central = central_.load()) central->notify();
      })) {}

Service::~Service() { stop(); }

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
  if (!database_damaged_.empty()) return make_error(ErrorCode::kStorage, database_damaged_);
  if (slot_taken_) {
    return make_error(ErrorCode::kRefused, "a run is in progress; ask again when it is done (GET /api/health)");
  }
  slot_taken_ = true;
  return RunReservation(this);
}

Result<RunReservation> Service::wait_and_reserve() {
  std::unique_lock<std::mutex> lock(slot_mutex_);
  slot_free_.wait(lock, [this] { return stopping_ || !slot_taken_; });
  if (stopping_) return make_error(ErrorCode::kRefused, "the service is stopping; nothing new is pushed");
  if (!database_damaged_.empty()) return make_error(ErrorCode::kStorage, database_damaged_);
  slot_taken_ = true;
  return RunReservation(this);
}

bool Service::run_in_progress() const {
  std::lock_guard<std::mutex> lock(slot_mutex_);
  return slot_taken_;
}

void Service::set_database_damaged(const std::string& message) {
  {
    std::lock_guard<std::mutex> lock(slot_mutex_);
    database_damaged_ = message;
  }
  record_event(EventKind::kFault, "database damaged", "", 0, std::nullopt, message);
}

void Service::release_run() {
  {
    std::lock_guard<std::mutex> lock(slot_mutex_);
    slot_taken_ = false;
  }
  slot_free_.notify_all();
}

Result<json> Service::measure(const std::string& part_name, int lobe, const std::string& note,
                              const std::string& serial, const std::string& operator_name,
                              std::optional<double> part_temperature_c) {
  Result<RunReservation> reservation = reserve_run();
  if (!reservation) return reservation.error();
  std::optional<PartTemperature> temperature;
  if (part_temperature_c) temperature = PartTemperature{*part_temperature_c, PartTemperatureSource::kOperator};
  Result<JobReport> report = run_reserved(std::move(*reservation), part_name, lobe, note, nullptr, std::nullopt, serial,
                                          operator_name, temperature);
  if (!flush_events()) spdlog::warn("the run's events still wait for the database; they are written later");
  if (!report) return report.error();
  return job_report_json(*report);
}

Result<JobReport> Service::run_reserved(RunReservation reservation, const std::string& part_name, int lobe,
                                        const std::string& note, std::optional<std::int64_t>* stored_run,
                                        std::optional<int> ground_with, const std::string& serial,
                                        const std::string& operator_name,
                                        std::optional<PartTemperature> part_temperature) {
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
  js.serial = serial;
  js.operator_name = operator_name;
  js.part_temperature = part_temperature;
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
  // The run and its push queued their broker messages in their own transactions (a failed
  // push may still have stored the run): the sender and the sync look now rather than at
  // their next turn.
  tell_plant();
  if (!report) {
    ++runs_failed_;
    spdlog::error("run failed: part {} lobe {}: {}", part_name, lobe, report.error().message);
    return report.error();
  }
  if (report->pushed()) {
    ++runs_pushed_;
    const std::string line =
        fmt::format("run {} stored: raw max lift error {:.2f} um; table version {} pushed to {} ({} blocks, {:.3f} um)",
                    report->run_id, report->analysis.max_abs_error_um, report->table_version, report->nc_file.string(),
                    report->table_blocks, report->command_error_um);
    spdlog::info("{}", line);
    // Faults and refusals are recorded by the job; a pushed table is recorded here.
    record_event(EventKind::kInfo, "table pushed", part_name, lobe, report->run_id, line);
  } else {
    ++runs_not_pushed_;
    spdlog::warn("run {} stored, table not pushed: {}", report->run_id, report->not_pushed_reason);
  }
  if (!report->history_warning.empty()) spdlog::error("{}", report->history_warning);
  return report;
}

void Service::record_event(EventKind kind, const std::string& code, const std::string& part, int lobe,
                           std::optional<std::int64_t> run_id, const std::string& message) const {
  record_event(*config(), kind, code, part, lobe, run_id, message);
}

void Service::record_event(const ServiceConfig& c, EventKind kind, const std::string& code, const std::string& part,
                           int lobe, std::optional<std::int64_t> run_id, const std::string& message) const {
  EventRecord e;
  e.at_utc = utc_now();  // when it happened, not when the database takes it
  e.kind = kind;
  e.code = code;
  e.machine = c.machine;
  e.part = part;
  e.lobe = lobe;
  e.run_id = run_id;
  e.message = message;
  events_->push(c.job.db_path, std::move(e));
}

bool Service::flush_events(std::chrono::milliseconds within) const { return events_->flush(within); }

void Service::count_reload(bool ok) {
  if (!flush_events()) spdlog::warn("the reload's event still waits for the database; it is written later");
  ok ? ++reloads_ : ++reload_failures_;
}

void Service::record_thread_fault(std::string_view thread_name, std::string_view what) const {
  ++thread_faults_;
  const std::string line = fmt::format("the {} thread was ended by an exception: {}", thread_name, what);
  spdlog::error("{}", line);
  record_event(EventKind::kFault, "internal error", "", 0, std::nullopt, line);
}

void Service::set_stopping() {
  {
    std::lock_guard<std::mutex> lock(slot_mutex_);
    stopping_ = true;
  }
  slot_free_.notify_all();  // a push waiting for the slot is refused now
}

void Service::stop() {
  {
    std::unique_lock<std::mutex> lock(slot_mutex_);
    stopping_ = true;
    slot_free_.notify_all();  // a push waiting for the slot is refused now
    slot_free_.wait(lock, [this] { return !slot_taken_; });
  }
  events_->stop(kEventDrainLimit);
}

namespace {

// The main programs an approval or a rollback renders: the lobes' ([nc] main_template), and
// for a crankpin ground C-X its own ([nc] pin_main_template), for a correction layer its own
// ([nc] layer_main_template).
MainProgramSource main_program_for_pushes(const ServiceConfig& c) {
  MainProgramSource m = main_program_source(c.job);
  m.pin_cx_template_text = c.nc_pin_main_template;
  m.pin_cx_template_name = c.nc_pin_main_template_name;
  m.layer_template_text = c.nc_layer_main_template;
  m.layer_template_name = c.nc_layer_main_template_name;
  m.speed_template_text = c.nc_main_speed_template;
  m.speed_template_name = c.nc_main_speed_template_name;
  return m;
}

// Approvals and rejections come over the HTTP API: a pending table that is not there says where
// the ids are.
Error with_pending_ids_hint(Error e) {
  if (e.code == ErrorCode::kNotFound) e.message += "; GET /api/nc/pending lists the ids";
  return e;
}

}  // namespace

Result<json> Service::approve(std::int64_t pending_id, const std::string& by, const std::string& note) {
  const Result<RunReservation> held = wait_and_reserve();  // one push at a time
  if (!held) return held.error();
  Result<RunStore> store = RunStore::open(config()->job.db_path);
  if (!store) return store.error();
  store->set_nc_dir(config()->job.nc_dir);
  Result<PushOutcome> pushed =
      approve_pending(*store, pending_id, by, note, /*overwrite_edited=*/false, main_program_for_pushes(*config()));
  if (!pushed) return with_pending_ids_hint(pushed.error());
  spdlog::info("pending table {} approved by {}: table version {} of run {} pushed to {}", pending_id, by,
               pushed->table_version, pushed->run_id, pushed->nc_file);
  tell_plant();
  return json{{"nc_file", pushed->nc_file},
              {"table_version", pushed->table_version},
              {"run_id", pushed->run_id},
              {"decision_recorded", pushed->decision_recorded}};
}

Result<json> Service::reject(std::int64_t pending_id, const std::string& by, const std::string& note) {
  const Result<RunReservation> held = wait_and_reserve();  // not between an approval's check and its push
  if (!held) return held.error();
  Result<RunStore> store = RunStore::open(config()->job.db_path);
  if (!store) return store.error();
  store->set_nc_dir(config()->job.nc_dir);
  Result<PendingTable> table = store->load_pending(pending_id);
  if (!table) return with_pending_ids_hint(table.error());
  if (Status s = store->reject_pending(pending_id, by, note); !s) return s.error();
  spdlog::info("pending table {} of {} rejected by {}; the table in force stays", pending_id, table->nc_file, by);
  return json{{"rejected", pending_id}, {"nc_file", table->nc_file}, {"by", by}};
}

Result<json> Service::rollback(const std::string& program, int table_version, const std::string& by) {
  const Result<RunReservation> held = wait_and_reserve();  // one push at a time
  if (!held) return held.error();
  const std::shared_ptr<const ServiceConfig> c = config();
  std::filesystem::path file(program);
  if (!file.has_parent_path()) {
    std::string name = program;
    if (name.size() > 4 && (name.ends_with(".SPF") || name.ends_with(".spf"))) name.resize(name.size() - 4);
    file = c->job.nc_dir / (name + ".SPF");
  }
  Result<RunStore> store = RunStore::open(c->job.db_path);
  if (!store) return store.error();
  store->set_nc_dir(c->job.nc_dir);
  Result<PushOutcome> pushed = rollback_to_version(*store, std::filesystem::absolute(file).lexically_normal().string(),
                                                   table_version, by, main_program_for_pushes(*c));
  if (!pushed) return pushed.error();
  spdlog::info("rollback by {}: {} table version {} is the table of version {} (run {})", by, pushed->nc_file,
               pushed->table_version, table_version, pushed->run_id);
  tell_plant();
  return json{{"nc_file", pushed->nc_file}, {"table_version", pushed->table_version}, {"run_id", pushed->run_id}};
}

json Service::health() const {
  CentralSyncer* const central = central_.load();
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
          {"plc", plc_status_ ? plc_status_() : json(nullptr)},
          {"outbox", outbox_ != nullptr ? outbox_->health() : json(nullptr)},
          {"central", central != nullptr ? central->health() : json(nullptr)},
          {"integrity", integrity_ != nullptr ? integrity_->health() : json(nullptr)}};
}

void Service::tell_plant() const {
  if (outbox_ != nullptr) outbox_->notify();
  if (CentralSyncer* central = central_.load()) central->notify();
}

void Service::plant_state(const std::string& state, const std::string& detail) const {
  if (outbox_ != nullptr) outbox_->queue_state(state, detail);
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
  m += "# HELP gaugeloop_service_events_dropped_total Events dropped unwritten: the database held them too long.\n";
  m += "# TYPE gaugeloop_service_events_dropped_total counter\n";
  m += "gaugeloop_service_events_dropped_total " + std::to_string(events_->dropped()) + "\n";
  if (outbox_ != nullptr) m += outbox_->metrics();
  if (CentralSyncer* central = central_.load()) m += central->metrics();
  if (integrity_ != nullptr) m += integrity_->metrics();
  return m;
}

}  // namespace gaugeloop
