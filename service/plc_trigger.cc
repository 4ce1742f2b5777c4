// The PLC trigger and the cycle runner it starts runs with.
#include "service/plc_trigger.h"

#include <spdlog/spdlog.h>

#include <utility>

#include "core/guarded_thread.h"

namespace gaugeloop {

using nlohmann::json;

namespace {
constexpr const char* kStoppingMessage = "the service is stopping; no new run is started";
}  // namespace

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

Result<PlcIdentity> plc_identity(const PlcRequestWords& request, int base_address) {
  namespace r = plc_registers;
  PlcIdentity who;
  Result<std::string> serial = decode_plc_text(request.serial, r::kSerialFirst, base_address, "serial number");
  if (!serial) return serial.error();
  Result<std::string> operator_name =
      decode_plc_text(request.operator_name, r::kOperatorFirst, base_address, "operator");
  if (!operator_name) return operator_name.error();
  // The run store's rule, as the CLI and the HTTP API apply it: the decoded text passes it
  // today (printable ASCII, 32 characters at most) and stays held to it should it change.
  const std::string serial_words = "serial number (words " + std::to_string(r::kSerialFirst) + "-" +
                                   std::to_string(r::kSerialFirst + r::kSerialWords - 1) + ")";
  if (Status s = check_run_identity("the PLC's " + serial_words, *serial); !s) return s.error();
  const std::string operator_words = "operator (words " + std::to_string(r::kOperatorFirst) + "-" +
                                     std::to_string(r::kOperatorFirst + r::kOperatorWords - 1) + ")";
  if (Status s = check_run_identity("the PLC's " + operator_words, *operator_name); !s) return s.error();
  who.serial = std::move(*serial);
  who.operator_name = std::move(*operator_name);
  return who;
}

Result<std::optional<PartTemperature>> plc_part_temperature(const PlcRequestWords& request, int base_address) {
  Result<std::optional<double>> c = decode_plc_part_temperature(request.part_temperature, base_address);
  if (!c) return c.error();
  if (!*c) return std::optional<PartTemperature>();
  return std::optional<PartTemperature>(PartTemperature{**c, PartTemperatureSource::kPlc});
}

// ---- ServiceCycleRunner ----

ServiceCycleRunner::~ServiceCycleRunner() {
  if (worker_.joinable()) worker_.join();
}

std::optional<PlcCycleOutcome> ServiceCycleRunner::start(const PlcRequestWords& request) {
  const std::uint16_t part_number = request.part_number;
  const std::uint16_t lobe = request.lobe;
  const std::optional<int> ground_with = request.ground_with_version();
  // Stopping comes first: every request is told "not now", whatever it asks for.
  if (service_.stopping()) return PlcCycleOutcome{PlcResultCode::kNotNow, 0, 0, kStoppingMessage};
  const std::shared_ptr<const ServiceConfig> c = service_.config();
  Result<const ServicePart*> part = find_plc_part(*c, part_number, lobe);
  if (!part) return PlcCycleOutcome{PlcResultCode::kUnknownPart, 0, 0, part.error().message};
  Result<PlcIdentity> identity = plc_identity(request, base_address_);
  if (!identity) return PlcCycleOutcome{PlcResultCode::kBadIdentity, 0, 0, identity.error().message};
  Result<std::optional<PartTemperature>> temperature = plc_part_temperature(request, base_address_);
  if (!temperature) return PlcCycleOutcome{PlcResultCode::kBadPartTemperature, 0, 0, temperature.error().message};
  Result<RunReservation> reservation = service_.reserve_run();
  if (!reservation) {
    // A damaged database refuses every run until a person restores it: a fault, not "ask again".
    const PlcResultCode code =
        reservation.error().code == ErrorCode::kStorage ? PlcResultCode::kStorageFault : PlcResultCode::kNotNow;
    return PlcCycleOutcome{code, 0, 0, reservation.error().message};
  }
  if (worker_.joinable()) worker_.join();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    finished_ = false;
  }
  const std::string name = (*part)->file.part.name;
  const std::string note = "PLC request: part number " + std::to_string(part_number);
  // The reservation travels into the worker, which ends it with the run.
  auto held = std::make_shared<RunReservation>(std::move(*reservation));
  worker_ = start_guarded_thread(
      "measuring",
      [this, held, name, lobe, note, ground_with, who = std::move(*identity), temperature = *temperature] {
        std::optional<std::int64_t> stored_run;
        Result<JobReport> report = service_.run_reserved(std::move(*held), name, lobe, note, &stored_run, ground_with,
                                                         who.serial, who.operator_name, temperature);
        finish(plc_outcome(report, stored_run));
      },
      [this, held](std::string_view thread_name, std::string_view what) {
        held->release();
        service_.record_thread_fault(thread_name, what);
        finish(PlcCycleOutcome{PlcResultCode::kOtherFault, 0, 0, "internal error: " + std::string(what)});
      });
  return std::nullopt;
}

void ServiceCycleRunner::finish(PlcCycleOutcome outcome) {
  std::lock_guard<std::mutex> lock(mutex_);
  outcome_ = std::move(outcome);
  finished_ = true;
}

std::optional<PlcCycleOutcome> ServiceCycleRunner::poll() {
  std::unique_lock<std::mutex> lock(mutex_);
  if (!finished_) return std::nullopt;
  finished_ = false;
  std::optional<PlcCycleOutcome> o = std::move(outcome_);
  outcome_.reset();
  lock.unlock();
  worker_.join();
  return o;
}

// ---- PlcTrigger ----

PlcTrigger::PlcTrigger(Service& service, PlcSettings settings, std::unique_ptr<PlcRegisters> plc)
    : service_(service),
      settings_(std::move(settings)),
      link_(plc ? std::move(plc) : std::make_unique<ModbusPlcLink>(settings_.link)),
      runner_(service_, settings_.link.base_address),
      handshake_(*link_, runner_) {}

PlcTrigger::~PlcTrigger() { stop(); }

void PlcTrigger::start() {
  const ThreadFault fault = [this](std::string_view name, std::string_view what) {
    service_.record_thread_fault(name, what);
  };
  thread_ = start_guarded_thread(
      "PLC trigger",
      [this, fault] {
        // A poll that threw is recorded; the trigger polls on after an interval, unless it
        // is stopping (a poll that keeps throwing must not hold the service's exit).
        while (!run_guarded(
            "PLC trigger", [this] { loop(); }, fault)) {
          if (!wait_poll_interval()) return;
        }
      },
      fault);
}

void PlcTrigger::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool PlcTrigger::wait_poll_interval() {
  std::unique_lock<std::mutex> lock(mutex_);
  wake_.wait_for(lock, settings_.poll_interval, [this] { return stop_; });
  return !stop_;
}

json PlcTrigger::status() const {
  return {{"address", address()},
          {"connected", connected_.load()},
          {"state", std::string(plc_state_name(static_cast<PlcState>(state_.load())))},
          {"requests", requests_.load()}};
}

std::string PlcTrigger::metrics() const {
  std::string m;
  m += "# HELP gaugeloop_plc_connected 1 while the link to the PLC's handshake registers is up.\n";
  m += "# TYPE gaugeloop_plc_connected gauge\n";
  m += "gaugeloop_plc_connected " + std::string(connected_ ? "1" : "0") + "\n";
  m += "# HELP gaugeloop_plc_requests_total PLC requests taken (runs started or refused).\n";
  m += "# TYPE gaugeloop_plc_requests_total counter\n";
  m += "gaugeloop_plc_requests_total " + std::to_string(requests_.load()) + "\n";
  return m;
}

bool PlcTrigger::alive(std::chrono::steady_clock::duration within) const {
  const std::chrono::steady_clock::rep last = last_poll_.load();
  if (last == 0) return false;
  return std::chrono::steady_clock::now() -
             std::chrono::steady_clock::time_point(std::chrono::steady_clock::duration(last)) <=
         within;
}

void PlcTrigger::loop() {
  for (;;) {
    last_poll_ = std::chrono::steady_clock::now().time_since_epoch().count();
    const std::vector<PlcEvent> events = handshake_.step();
    for (PlcEvent e : events) report(e);
    connected_ = handshake_.connected();
    state_ = static_cast<int>(handshake_.state());
    std::unique_lock<std::mutex> lock(mutex_);
    // A stopping service may still finish a run started over HTTP: the PLC is answered
    // "not now" (and sees the heartbeat) until it has ended.
    const bool run_left = service_.stopping() && service_.run_in_progress();
    if (stop_ && !run_left && handshake_.state() != PlcState::kBusy) {
      if (handshake_.outcome_delivered()) break;
      if (!handshake_.connected()) {
        spdlog::error("PLC at {}: stopping with the outcome of the last request undelivered (link down): {}", address(),
                      handshake_.last_link_error());
        break;
      }
    }
    wake_.wait_for(lock, settings_.poll_interval);
  }
}

std::string PlcTrigger::request_text() const {
  const PlcRequestWords& r = handshake_.request();
  return "PLC request part number " + std::to_string(r.part_number) + " lobe " + std::to_string(r.lobe);
}

std::string PlcTrigger::part_name() const {
  const PlcRequestWords& r = handshake_.request();
  Result<const ServicePart*> p = find_plc_part(*service_.config(), r.part_number, r.lobe);
  return p ? (*p)->file.part.name : std::string();
}

void PlcTrigger::report(PlcEvent e) {
  const int lobe = handshake_.request().lobe;
  switch (e) {
    case PlcEvent::kConnected:
      spdlog::info("PLC link up at {}{}", address(), link_down_ ? " again" : "");
      if (link_down_) {
        service_.record_event(EventKind::kInfo, "plc link up", "", 0, std::nullopt,
                              "PLC link at " + address() + " up again");
        service_.plant_state("plc link up", "PLC link at " + address() + " up again");
      }
      link_down_ = false;
      break;
    case PlcEvent::kConnectFailed:
      if (!link_down_) {  // once per loss, not once per attempt
        spdlog::warn("PLC link down: {}; retrying with backoff", handshake_.last_link_error());
        service_.record_event(EventKind::kFault, "plc link down", "", 0, std::nullopt, handshake_.last_link_error());
        service_.plant_state("plc link down", handshake_.last_link_error());
      }
      link_down_ = true;
      break;
    case PlcEvent::kLinkLost:
      if (!link_down_) {
        spdlog::warn("PLC link lost: {}; reconnecting with backoff", handshake_.last_link_error());
        service_.record_event(EventKind::kFault, "plc link down", "", 0, std::nullopt, handshake_.last_link_error());
        service_.plant_state("plc link down", handshake_.last_link_error());
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
      const std::string line = request_text() + ": " + (done ? "done" : "fault") + ", result code " +
                               std::to_string(static_cast<int>(o.code)) + " (" + std::string(plc_result_name(o.code)) +
                               ")" + (o.run_id != 0 ? ", run " + std::to_string(o.run_id) : std::string()) + ": " +
                               o.message;
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

}  // namespace gaugeloop
