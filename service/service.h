// The service's state, shared by the HTTP threads, the PLC trigger and the signal loop: the
// configuration in force, the one run (or push) at a time, the counters /metrics shows.
// docs/service.md.
#pragma once

#include <atomic>
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
#include "storage/run_store.h"

namespace gaugeloop {

class Service;

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

class Service {
 public:
  explicit Service(ServiceConfig config, GaugeFactory gauge = modbus_gauge_factory());

  std::shared_ptr<const ServiceConfig> config() const;
  // Takes a checked configuration into use; a run in progress finishes with the old one.
  void replace_config(ServiceConfig config);

  // The one run (or push) at a time. Refused (kRefused) while another runs or the service
  // stops: the PLC or the caller asks again. Reserving before a run's thread starts lets the
  // PLC trigger answer "not now" at once, and makes a run it acknowledged certain to run,
  // even if SIGTERM comes meanwhile.
  Result<RunReservation> reserve_run();
  // Waits for the run (or push) in progress, then reserves; for approvals and rollbacks,
  // which are short and wait rather than fail.
  RunReservation wait_and_reserve();

  // One measurement run over HTTP: run_reserved's report as JSON (job_report_json).
  Result<nlohmann::json> measure(const std::string& part_name, int lobe, const std::string& note);

  // One measurement run, end to end, on a reservation it ends. `stored_run`, when given,
  // receives the run's id as soon as it is stored, so a push that fails after that can still
  // name the run. `ground_with`: the table version that ground the part, as the PLC said it
  // (0: the design); empty: not said.
  Result<JobReport> run_reserved(RunReservation reservation, const std::string& part_name, int lobe,
                                 const std::string& note, std::optional<std::int64_t>* stored_run = nullptr,
                                 std::optional<int> ground_with = std::nullopt);

  // A pending table approved over HTTP; the same as `gaugeloop nc approve` (no overwriting
  // of a hand-edited program over HTTP: that needs the command and its flag).
  Result<nlohmann::json> approve(std::int64_t pending_id, const std::string& by, const std::string& note);

  // `program`: a program name (CAM_INTAKE_L1, with or without .SPF) in the configured NC
  // directory, or the NC file's path.
  Result<nlohmann::json> rollback(const std::string& program, int table_version, const std::string& by);

  // Keeps a step of the service in the database (`gaugeloop events`); a database that refuses
  // is logged, never fatal: the step itself was logged already.
  void record_event(EventKind kind, const std::string& code, const std::string& part, int lobe,
                    std::optional<std::int64_t> run_id, const std::string& message) const;
  // With the configuration a run was started with (a reload meanwhile changes nothing of it).
  void record_event(const ServiceConfig& c, EventKind kind, const std::string& code, const std::string& part, int lobe,
                    std::optional<std::int64_t> run_id, const std::string& message) const;

  // A thread of the service ended by an exception: logged, kept as a fault event, counted.
  void record_thread_fault(std::string_view thread_name, std::string_view what) const;

  // No new run is reserved from now on.
  void set_stopping();
  // Waits for a run in progress to end; no new run starts after this.
  void stop();

  // What the PLC trigger adds to /api/health; null when there is no [plc]. Set before any
  // thread starts.
  void set_plc_status(std::function<nlohmann::json()> status) { plc_status_ = std::move(status); }

  nlohmann::json health() const;
  std::string metrics() const;  // Prometheus lines of the service's counters
  void count_reload(bool ok) { ok ? ++reloads_ : ++reload_failures_; }

 private:
  friend class RunReservation;
  void release_run();

  GaugeFactory gauge_factory_;
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
  mutable std::atomic<long long> thread_faults_{0};
  std::function<nlohmann::json()> plc_status_;
};

}  // namespace gaugeloop
