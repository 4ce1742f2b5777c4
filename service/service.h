// The service's state, shared by the HTTP threads, the PLC trigger and the signal loop: the
// configuration in force, the one run (or push) at a time, the counters /metrics shows.
// docs/service.md.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "acquisition/gauge_client.h"
#include "config/service_config.h"
#include "core/result.h"
#include "job/measure_job.h"
#include "service/http_api.h"
#include "storage/run_store.h"

namespace gaugeloop {

class Service;
class EventWriter;
class CentralSyncer;
class IntegrityWatch;
class OutboxSender;

// The one run (or push) at a time, held: whoever holds it may run; it is released when the
// holder ends it, on whichever thread (destruction, or moving it on to a worker thread and
// ending it there). Move-only.
class RunReservation {
 public:
  RunReservation() = default;
  RunReservation(RunReservation&& other) noexcept : service_(std::exchange(other.service_, nullptr)) {}
  RunReservation& operator=(RunReservation&& other) noexcept;
  RunReservation(const RunReservation&) = delete;
  RunReservation& operator=(const RunReservation&) = delete;
  ~RunReservation() { release(); }

  bool held() const { return service_ != nullptr; }
  void release();  // idempotent

 private:
  friend class Service;
  explicit RunReservation(Service* service) : service_(service) {}
  Service* service_ = nullptr;
};

// The gauge a run reads: a Modbus client built from the configuration in force (the service),
// or a scripted one (tests).
using GaugeFactory = std::function<std::unique_ptr<GaugeClient>(const ServiceConfig& config)>;
GaugeFactory modbus_gauge_factory();

// The JSON the HTTP API answers for a run it triggered (docs/http_api.md, POST /api/measure).
nlohmann::json job_report_json(const JobReport& report);

// How many events wait for the database at most: a database locked for long (a backup, a
// person's `sqlite3` session) must not grow the service's memory. Beyond it the oldest waiting
// event is dropped, counted and logged. A PLC cycle makes about eight events, so this holds a
// few hundred cycles, far beyond a lock anyone holds on purpose.
inline constexpr std::size_t kEventQueueLimit = 2000;
// Events written in one transaction at the most: a burst costs one commit, not one an event.
// A batch taken by the writer is out of the queue: the service holds at most
// kEventQueueLimit + kEventBatch events.
inline constexpr std::size_t kEventBatch = 256;
// How long stop() waits for the waiting events to be written. An attempt that has begun may
// take the database's busy timeout (5 s) more before the writer ends.
inline constexpr std::chrono::seconds kEventDrainLimit{10};

class Service {
 public:
  explicit Service(ServiceConfig config, GaugeFactory gauge = modbus_gauge_factory());
  ~Service();  // stop()s: waits for the run in progress and writes the waiting events
  Service(const Service&) = delete;
  Service& operator=(const Service&) = delete;

  std::shared_ptr<const ServiceConfig> config() const;
  // Takes a checked configuration into use; a run in progress finishes with the old one.
  void replace_config(ServiceConfig config);

  // The one run (or push) at a time. Refused (kRefused) while another runs or the service
  // stops: the PLC or the caller asks again. Reserving before a run's thread starts lets the
  // PLC trigger answer "not now" at once, and makes a run it acknowledged certain to run,
  // even if SIGTERM comes meanwhile.
  Result<RunReservation> reserve_run();
  // Waits for the run (or push) in progress, then reserves; for approvals and rollbacks,
  // which are short and wait rather than fail. Refused (kRefused) once the service stops,
  // also for a caller that was waiting then.
  Result<RunReservation> wait_and_reserve();
  // True while a run or a push holds the one slot, whoever started it (HTTP, PLC). Any thread.
  bool run_in_progress() const;

  // One measurement run over HTTP: run_reserved's report as JSON (job_report_json). Returns
  // once the run's events are written too (flush_events), so the caller that is answered
  // finds them in the database.
  // `serial` and `operator_name` are stored with the run (empty: not given), and so is
  // `part_temperature_c` as given by a person (checked_part_temperature_c's already; empty:
  // not given).
  Result<nlohmann::json> measure(const std::string& part_name, int lobe, const std::string& note,
                                 const std::string& serial = {}, const std::string& operator_name = {},
                                 std::optional<double> part_temperature_c = std::nullopt);

  // One measurement run, end to end, on a reservation it ends. `stored_run`, when given,
  // receives the run's id as soon as it is stored, so a push that fails after that can still
  // name the run. `ground_with`: the table version that ground the part, as the PLC said it
  // (0: the design); empty: not said. `serial`, `operator_name`, `part_temperature`: stored
  // with the run (empty: not given).
  Result<JobReport> run_reserved(RunReservation reservation, const std::string& part_name, int lobe,
                                 const std::string& note, std::optional<std::int64_t>* stored_run = nullptr,
                                 std::optional<int> ground_with = std::nullopt, const std::string& serial = {},
                                 const std::string& operator_name = {},
                                 std::optional<PartTemperature> part_temperature = std::nullopt);

  // A pending table approved over HTTP; the same as `gaugeloop nc approve` (no overwriting
  // of a hand-edited program over HTTP: that needs the command and its flag).
  Result<nlohmann::json> approve(std::int64_t pending_id, const std::string& by, const std::string& note);
  // Rejects pending table `pending_id` (the table in force stays), holding the push slot as
  // approve does, so a rejection never lands between an approval's check and its write.
  // kNotFound for an unknown id, kRefused for a table no longer pending or while stopping.
  Result<nlohmann::json> reject(std::int64_t pending_id, const std::string& by, const std::string& note);

  // `program`: a program name (CAM_INTAKE_L1, with or without .SPF) in the configured NC
  // directory, or the NC file's path.
  Result<nlohmann::json> rollback(const std::string& program, int table_version, const std::string& by);

  // The first program of configured part `part_name` lobe (or pin) `lobe`, previewed: nothing
  // is written. The last preview is kept for the configuration in force, so the page's JSON and
  // its picture cost one computation; previews are computed one at a time. kNotFound for a part
  // the service does not know; the refusals of nc new's preview.
  Result<NewProgramPreview> preview_program(const std::string& part_name, int lobe);
  // Writes it, as `gaugeloop nc new` (job/nc_new.h), holding the push slot as approve does:
  // refused (kRefused) over a program with a history unless `replace`.
  Result<nlohmann::json> new_program(const std::string& part_name, int lobe, const std::string& by, bool replace);

  // Keeps a step of the service in the database (`gaugeloop events`), without waiting for the
  // database: the event is stamped now and queued; the service's event writer (a thread with
  // one connection open) writes the events in the order they were recorded. A database that
  // is busy is retried; one that refuses otherwise is logged, never fatal: the step itself was
  // logged already. A full queue (kEventQueueLimit) drops its oldest event, counted and
  // logged. After stop() an event is logged as not recorded. Any thread.
  void record_event(EventKind kind, const std::string& code, const std::string& part, int lobe,
                    std::optional<std::int64_t> run_id, const std::string& message) const;
  // With the configuration a run was started with (a reload meanwhile changes nothing of it).
  void record_event(const ServiceConfig& c, EventKind kind, const std::string& code, const std::string& part, int lobe,
                    std::optional<std::int64_t> run_id, const std::string& message) const;

  // Waits until every event recorded before the call is written (or dropped), at most
  // `within`; false when the database held them longer. For tests and for answers that must
  // find their events stored.
  bool flush_events(std::chrono::milliseconds within = kEventDrainLimit) const;

  // A thread of the service ended by an exception: logged, kept as a fault event, counted.
  void record_thread_fault(std::string_view thread_name, std::string_view what) const;

  // No new run or push is reserved from now on (reserve_run, wait_and_reserve refuse); a run
  // in progress goes on. /api/health says "stopping" from here on. Any thread; idempotent.
  void set_stopping();
  bool stopping() const { return stopping_; }
  // set_stopping(), then waits for the run in progress to end, then for the waiting events
  // to be written (at most kEventDrainLimit; what could not be written is logged). Events
  // recorded after this are logged only. Idempotent.
  void stop();

  // What the PLC trigger adds to /api/health; null when there is no [plc]. Set before any
  // thread starts.
  void set_plc_status(std::function<nlohmann::json()> status) { plc_status_ = std::move(status); }

  // The plant broker's sender ([plant.mqtt]); null: none. Set before any thread starts, and it
  // must outlive the service's threads. /api/health gets its "outbox", /metrics its series,
  // and it is told after every run, push and state change.
  void set_outbox(OutboxSender* sender) { outbox_ = sender; }
  // The sync into the plant's central history ([plant.central]); null: none. As set_outbox:
  // /api/health gets its "central", /metrics its series, and it is told after every run and push,
  // and when events of a run are written (the event writer's thread may already run: atomic).
  void set_central_sync(CentralSyncer* syncer) { central_ = syncer; }
  // The run database's full check beside the service (service/integrity_watch.h); null: none.
  // As set_outbox: /api/health gets its "integrity", /metrics its series.
  void set_integrity_watch(IntegrityWatch* watch) { integrity_ = watch; }
  // The full check found the database damaged: from now on every run and push is refused with
  // `message` (what is wrong and what to do), the grinder goes on without gaugeloop's tables.
  void set_database_damaged(const std::string& message);
  // A state change for the plant's broker ("started", "stopping", "plc link down"...): queued
  // in the outbox by the sender's thread. Nothing without a sender. Any thread.
  void plant_state(const std::string& state, const std::string& detail = {}) const;

  nlohmann::json health() const;
  std::string metrics() const;  // Prometheus lines of the service's counters
  // Counted after the reload's event is written (flush_events; unless the database holds it
  // beyond kEventDrainLimit): whoever sees the count in /api/health finds the event stored.
  void count_reload(bool ok);

 private:
  friend class RunReservation;
  void release_run();
  void tell_plant() const;  // a run or push was stored: the outbox sender and the sync look now

  GaugeFactory gauge_factory_;
  mutable std::mutex config_mutex_;
  std::shared_ptr<const ServiceConfig> config_;
  mutable std::mutex slot_mutex_;
  std::condition_variable slot_free_;
  bool slot_taken_ = false;  // guarded by slot_mutex_: for the length of a run or a push
  std::atomic<bool> measuring_{false};
  std::atomic<bool> stopping_{false};
  std::atomic<long long> runs_pushed_{0};
  std::atomic<long long> runs_not_pushed_{0};
  std::atomic<long long> runs_failed_{0};
  std::atomic<long long> reloads_{0};
  std::atomic<long long> reload_failures_{0};
  mutable std::atomic<long long> thread_faults_{0};
  std::function<nlohmann::json()> plc_status_;
  OutboxSender* outbox_ = nullptr;
  std::atomic<CentralSyncer*> central_{nullptr};
  IntegrityWatch* integrity_ = nullptr;
  std::string database_damaged_;  // guarded by slot_mutex_: why runs and pushes are refused
  struct CachedPreview {
    std::shared_ptr<const ServiceConfig> config;  // the configuration it was computed with
    std::string part;
    int lobe = 0;
    NewProgramPreview preview;
  };
  std::mutex preview_mutex_;                   // one preview computed at a time
  std::optional<CachedPreview> last_preview_;  // guarded by preview_mutex_
  std::unique_ptr<EventWriter> events_;        // last: its thread ends first
};

}  // namespace gaugeloop
