// The service's state without a process, a socket or a signal: the one run at a time, a run
// measured from a scripted gauge through the real job and database, the PLC cycle runner and
// trigger against PLC registers in memory, the event writer, and a thread ended by an
// exception.
#include "service/service.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <condition_variable>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <thread>

#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "core/utc_time.h"
#include "service/plc_trigger.h"
#include "storage/run_store.h"
#include "tests/acquisition/scripted_gauge.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

// How long a test waits for what another thread does before it fails: far beyond what any
// step takes on a loaded machine; reached only when the step never comes.
constexpr std::chrono::seconds kGenerous{60};

// The PLC's registers in memory for the trigger's thread; the test plays the PLC from its
// own thread and waits for what the service writes.
class SharedPlc final : public PlcRegisters {
 public:
  struct Seen {
    PlcServiceWords words;                  // written last
    std::vector<std::uint16_t> heartbeats;  // every write's heartbeat, in order
    int connects = 0;
  };

  Status connect() override {
    std::lock_guard<std::mutex> lock(mutex_);
    ++seen_.connects;
    up_ = true;
    changed_.notify_all();
    return {};
  }
  void disconnect() override {
    std::lock_guard<std::mutex> lock(mutex_);
    up_ = false;
  }
  bool connected() const override {
    std::lock_guard<std::mutex> lock(mutex_);
    return up_;
  }
  Result<PlcRequestWords> read_request() override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (drop_next_read_) {
      drop_next_read_ = false;
      up_ = false;
      return make_error(ErrorCode::kIo, "connection reset (scripted)");
    }
    return plc_;
  }
  Status write_service_words(const PlcServiceWords& words) override {
    std::lock_guard<std::mutex> lock(mutex_);
    seen_.words = words;
    seen_.heartbeats.push_back(words.heartbeat);
    changed_.notify_all();
    return {};
  }
  std::string address() const override { return "scripted"; }

  void request(std::uint16_t part, std::uint16_t lobe) {
    std::lock_guard<std::mutex> lock(mutex_);
    plc_.part_number = part;
    plc_.lobe = lobe;
    plc_.request = plc_registers::kMeasureBit;
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    plc_.request = 0;
  }
  // Words 13-28 as the PLC program left them.
  void serial_words(const std::array<std::uint16_t, plc_registers::kSerialWords>& words) {
    std::lock_guard<std::mutex> lock(mutex_);
    plc_.serial = words;
  }
  void drop_link() {
    std::lock_guard<std::mutex> lock(mutex_);
    drop_next_read_ = true;
  }

  // True once `done(seen)` holds; false after kGenerous.
  template <typename Pred>
  bool wait_until(Pred done) {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, kGenerous, [&] { return done(seen_); });
  }
  Seen seen() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return seen_;
  }

 private:
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  PlcRequestWords plc_;
  Seen seen_;
  bool up_ = false;
  bool drop_next_read_ = false;
};

// Polls seen after `from` (an index into the heartbeats).
std::size_t polls_since(const SharedPlc::Seen& s, std::size_t from) { return s.heartbeats.size() - from; }

// Every poll wrote the heartbeat one on from the poll before: it never stood still.
void expect_counted_every_poll(const std::vector<std::uint16_t>& heartbeats) {
  for (std::size_t i = 1; i < heartbeats.size(); ++i) {
    ASSERT_EQ(static_cast<std::uint16_t>(heartbeats[i] - heartbeats[i - 1]), 1) << "poll " << i;
  }
}

// A run held in the gauge's connect until the test lets it go: a run in progress for as long
// as the test needs one.
class RunHold {
 public:
  void enter_and_wait() {
    std::unique_lock<std::mutex> lock(mutex_);
    entered_ = true;
    changed_.notify_all();
    changed_.wait(lock, [this] { return released_; });
  }
  bool wait_entered() {
    std::unique_lock<std::mutex> lock(mutex_);
    return changed_.wait_for(lock, kGenerous, [this] { return entered_; });
  }
  void release() {
    std::lock_guard<std::mutex> lock(mutex_);
    released_ = true;
    changed_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool entered_ = false;
  bool released_ = false;
};

class HeldGauge final : public GaugeClient {
 public:
  HeldGauge(std::unique_ptr<GaugeClient> inner, RunHold& hold) : inner_(std::move(inner)), hold_(hold) {}
  Status connect() override {
    hold_.enter_and_wait();
    return inner_->connect();
  }
  void disconnect() override { inner_->disconnect(); }
  bool connected() const override { return inner_->connected(); }
  Result<GaugeSnapshot> read_snapshot() override { return inner_->read_snapshot(); }
  Result<LatchState> read_latch_state() override { return inner_->read_latch_state(); }
  Result<std::vector<LatchedSample>> read_latched(int first_slot, int count) override {
    return inner_->read_latched(first_slot, count);
  }
  std::string address() const override { return inner_->address(); }

 private:
  std::unique_ptr<GaugeClient> inner_;
  RunHold& hold_;
};

PlcSettings fast_plc() {
  PlcSettings s;
  s.poll_interval = std::chrono::milliseconds(2);
  return s;
}

// The events of the database, oldest first.
std::vector<StoredEvent> stored_events(const fs::path& db) {
  Result<RunStore> store = RunStore::open_read_only(db);
  EXPECT_TRUE(store.ok()) << store.error().message;
  if (!store) return {};
  EventQuery q;
  q.limit = 100000;
  Result<std::vector<StoredEvent>> events = store->list_events(q);
  EXPECT_TRUE(events.ok()) << events.error().message;
  if (!events) return {};
  std::sort(events->begin(), events->end(), [](const StoredEvent& a, const StoredEvent& b) { return a.id < b.id; });
  return *events;
}

class ServiceStateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
    std::ofstream(dir_ / "gaugeloop.toml")
        << "machine = \"grinder-7\"\n"
        << "[gauge]\nconfig = \"" << (examples / "gauges" / "simulator.toml").string() << "\"\nmode = \"live\"\n"
        << "[[part]]\nfile = \"" << (examples / "intake_flat.toml").string() << "\"\nplc_part_number = 1\n"
        << "[nc]\ndir = \"nc\"\ntemplate = \"" << (examples / "sinumerik" / "cam_table.spf").string() << "\"\n"
        << "[database]\npath = \"gaugeloop.sqlite\"\n";
    Result<ServiceConfig> c = read_service_config(dir_ / "gaugeloop.toml");
    ASSERT_TRUE(c.ok()) << c.error().message;
    config_ = std::move(*c);
    // The scripted spindle moves per request, not with the clock: nothing to wait for.
    PollerSettings& p = config_.job.poller;
    p.backoff_initial = std::chrono::milliseconds(0);
    p.backoff_max = std::chrono::milliseconds(0);
    // The gauge reads what a flat follower on the design lobe reads: the part is on design.
    const ServicePart& part = config_.parts.front();
    Result<PeriodicSpline> lift = PeriodicSpline::fit(part.design.angle_deg, part.design.lift_mm);
    ASSERT_TRUE(lift.ok()) << lift.error().message;
    Result<DesignReading> reading = DesignReading::of_lobe(*lift, part.file.part);
    ASSERT_TRUE(reading.ok()) << reading.error().message;
    reading_ = std::make_shared<DesignReading>(std::move(*reading));
  }

  // A gauge on the design lobe for every run, counting the runs that asked for one.
  GaugeFactory design_gauge() {
    return [this](const ServiceConfig&) -> std::unique_ptr<GaugeClient> {
      ++gauges_made_;
      auto g = std::make_unique<testing::ScriptedGauge>();
      g->step_deg = 0.25;
      g->lift_mm = [r = reading_](double u) { return r->at(u); };
      return g;
    };
  }

  GaugeFactory held_gauge(RunHold& hold) {
    return [&hold, good = design_gauge()](const ServiceConfig& c) -> std::unique_ptr<GaugeClient> {
      return std::make_unique<HeldGauge>(good(c), hold);
    };
  }

  fs::path db() const { return dir_ / "gaugeloop.sqlite"; }

  testing::TempDir tmp_;
  fs::path dir_;
  ServiceConfig config_;
  std::shared_ptr<DesignReading> reading_;
  int gauges_made_ = 0;
};

TEST_F(ServiceStateTest, OneRunAtATimeAndTheReservationEndsWithItsHolder) {
  Service service(config_, design_gauge());
  Result<RunReservation> first = service.reserve_run();
  ASSERT_TRUE(first.ok());
  Result<RunReservation> second = service.reserve_run();
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.error().code, ErrorCode::kRefused);
  EXPECT_NE(second.error().message.find("a run is in progress"), std::string::npos) << second.error().message;
  {
    RunReservation moved = std::move(*first);  // moving hands the run on, it does not end it
    EXPECT_FALSE(first->held());
    EXPECT_TRUE(moved.held());
    EXPECT_FALSE(service.reserve_run().ok());
  }
  Result<RunReservation> third = service.reserve_run();
  ASSERT_TRUE(third.ok()) << "released when its holder ended";
  third->release();
  third->release();  // idempotent
  EXPECT_TRUE(service.reserve_run().ok());
}

TEST_F(ServiceStateTest, NoRunStartsOnceTheServiceStops) {
  Service service(config_, design_gauge());
  service.set_stopping();
  Result<RunReservation> r = service.reserve_run();
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("stopping"), std::string::npos) << r.error().message;
  EXPECT_EQ(service.health()["state"], "stopping");
  service.stop();  // nothing running: returns at once
}

TEST_F(ServiceStateTest, ARunIsMeasuredStoredPushedAndCounted) {
  Service service(config_, design_gauge());
  Result<nlohmann::json> r = service.measure("intake_flat", 1, "from the test");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(gauges_made_, 1);
  ASSERT_TRUE((*r)["run_id"].is_number_integer());
  const std::int64_t run_id = (*r)["run_id"];
  // On design, the lift error is the live mode's interpolation only: the cubic between polls
  // h = 0.25 deg apart errs by about h^4/24 |H''''|, under 0.001 um even at 1 deg on the
  // sample lobes (acquisition/poller.h); 0.01 um leaves room for the analysis' rounding.
  EXPECT_LT((*r)["max_abs_error_um"].get<double>(), 0.01);
  EXPECT_TRUE((*r)["pushed"].get<bool>()) << r->dump();
  EXPECT_EQ((*r)["table_version"], 1);

  Result<RunStore> store = RunStore::open_read_only(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  Result<StoredRun> run = store->load_run(run_id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->summary.machine, "grinder-7");
  EXPECT_EQ(run->summary.note, "from the test");

  // Each step of the cycle is an event of the run, and the pushed table one more.
  Result<std::vector<StoredEvent>> events = store->list_events(EventQuery{});
  ASSERT_TRUE(events.ok()) << events.error().message;
  std::vector<std::string> codes;
  for (const StoredEvent& e : *events) codes.push_back(e.event.code);
  for (const char* code : {"acquired", "analysed", "compensated", "stored", "table pushed"}) {
    EXPECT_NE(std::find(codes.begin(), codes.end(), code), codes.end()) << code;
  }
  const std::string metrics = service.metrics();
  EXPECT_NE(metrics.find("gaugeloop_service_runs_total{outcome=\"pushed\"} 1\n"), std::string::npos) << metrics;
  EXPECT_EQ(service.health()["state"], "idle");
  EXPECT_TRUE(service.reserve_run().ok()) << "the run's reservation ended with it";
}

TEST_F(ServiceStateTest, ANewProgramIsPreviewedWrittenOnceAndTheFirstRunBuildsOnIt) {
  Service service(config_, design_gauge());
  const fs::path nc_file = dir_ / "nc" / "CAM_INTAKE_L1.SPF";
  Result<NewProgramPreview> preview = service.preview_program("intake_flat", 1);
  ASSERT_TRUE(preview.ok()) << preview.error().message;
  const nlohmann::json& p = preview->body;
  EXPECT_EQ(p["program"], "CAM_INTAKE_L1");
  EXPECT_EQ(p["profile"]["c_deg"].size(), 360u);
  EXPECT_EQ(preview->page.command_error_um.size(), 360u);
  EXPECT_LE(p["table"]["command_error_um"].get<double>(), p["command_error_bound_um"].get<double>());
  int chosen = 0;
  for (const nlohmann::json& c : p["choices"]) chosen += c.value("chosen", false) ? 1 : 0;
  EXPECT_EQ(chosen, 1) << p["choices"].dump();
  EXPECT_GT(p["cycle_time_s"].get<double>(), 0.0);
  EXPECT_FALSE(fs::exists(nc_file)) << "a preview writes nothing";
  Result<NewProgramPreview> unknown = service.preview_program("exhaust_roller", 1);
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::kNotFound);

  Result<nlohmann::json> written = service.new_program("intake_flat", 1, "anna", false);
  ASSERT_TRUE(written.ok()) << written.error().message;
  EXPECT_EQ((*written)["table_version"], 1);
  EXPECT_EQ((*written)["table"]["blocks"], p["table"]["blocks"]) << "what was previewed is what was written";
  EXPECT_TRUE(fs::exists(nc_file));
  Result<nlohmann::json> again = service.new_program("intake_flat", 1, "anna", false);
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code, ErrorCode::kRefused);
  EXPECT_NE(again.error().message.find("\"replace\": true"), std::string::npos) << again.error().message;
  Result<nlohmann::json> replaced = service.new_program("intake_flat", 1, "anna", true);
  ASSERT_TRUE(replaced.ok()) << replaced.error().message;
  EXPECT_EQ((*replaced)["table_version"], 2);
  EXPECT_TRUE(service.reserve_run().ok()) << "the push slot was released";

  Result<nlohmann::json> run = service.measure("intake_flat", 1, "");
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ((*run)["table_version"], 3) << "the first run's table follows the new program's versions";
  Result<RunStore> store = RunStore::open_read_only(db());
  ASSERT_TRUE(store.ok()) << store.error().message;
  PushQuery q;
  q.nc_file = fs::absolute(nc_file).lexically_normal().string();
  Result<std::vector<NcPush>> pushes = store->list_pushes(q);
  ASSERT_TRUE(pushes.ok()) << pushes.error().message;
  ASSERT_EQ(pushes->size(), 3u);
  int without_run = 0;
  for (const NcPush& push : *pushes) without_run += push.run_id == 0 ? 1 : 0;
  EXPECT_EQ(without_run, 2) << "the new programs have no run behind them";
}

// Once the database is found damaged, every run and push is refused with what to do, also on
// the PLC's side (a storage fault, not "ask again"), and the damage is kept as a fault event.
TEST_F(ServiceStateTest, ADamagedDatabaseRefusesRunsPushesAndThePlc) {
  Service service(config_, design_gauge());
  service.set_database_damaged("database x is damaged: page 3; put the last sound backup in its place");
  Result<RunReservation> run = service.reserve_run();
  ASSERT_FALSE(run.ok());
  EXPECT_EQ(run.error().code, ErrorCode::kStorage);
  EXPECT_NE(run.error().message.find("last sound backup"), std::string::npos);
  Result<nlohmann::json> rollback = service.rollback("CAM_INTAKE_L1", 1, "anna");
  ASSERT_FALSE(rollback.ok());
  EXPECT_EQ(rollback.error().code, ErrorCode::kStorage);
  EXPECT_EQ(gauges_made_, 0);
  ServiceCycleRunner runner(service);
  PlcRequestWords request;
  request.part_number = 1;
  request.lobe = 1;
  const std::optional<PlcCycleOutcome> outcome = runner.start(request);
  ASSERT_TRUE(outcome.has_value()) << "answered at once";
  EXPECT_EQ(outcome->code, PlcResultCode::kStorageFault) << outcome->message;
  ASSERT_TRUE(service.flush_events());
  bool recorded = false;
  for (const StoredEvent& e : stored_events(db())) recorded = recorded || e.event.code == "database damaged";
  EXPECT_TRUE(recorded);
}

TEST_F(ServiceStateTest, AnUnknownPartIsRefusedBeforeTheGaugeAndKeptAsAnEvent) {
  Service service(config_, design_gauge());
  Result<nlohmann::json> r = service.measure("exhaust_roller", 1, "");
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFound);
  EXPECT_NE(r.error().message.find("intake_flat lobe 1"), std::string::npos)
      << "lists the parts: " << r.error().message;
  EXPECT_EQ(gauges_made_, 0);
  EXPECT_TRUE(service.reserve_run().ok());
}

// The PLC's cycle on the worker thread: started, polled to its end, told as the PLC reads it.
std::optional<PlcCycleOutcome> wait_for_outcome(ServiceCycleRunner& runner) {
  for (;;) {
    if (std::optional<PlcCycleOutcome> o = runner.poll()) return o;
    std::this_thread::yield();  // the worker ends by itself; no deadline is asserted
  }
}

TEST_F(ServiceStateTest, APlcCycleRunsOnAWorkerAndEndsWithTheTablePushed) {
  Service service(config_, design_gauge());
  ServiceCycleRunner runner(service);
  PlcRequestWords request;
  request.part_number = 1;
  request.lobe = 1;
  ASSERT_FALSE(runner.start(request).has_value()) << "the run started";
  EXPECT_FALSE(service.reserve_run().ok()) << "the worker holds the run";
  const std::optional<PlcCycleOutcome> o = wait_for_outcome(runner);
  ASSERT_TRUE(o.has_value());
  EXPECT_EQ(o->code, PlcResultCode::kTablePushed) << o->message;
  EXPECT_NE(o->run_id, 0u);
  EXPECT_EQ(o->table_version, 1);
  EXPECT_TRUE(service.reserve_run().ok());
}

TEST_F(ServiceStateTest, APlcRequestForAPartNotConfiguredIsAnsweredAtOnce) {
  Service service(config_, design_gauge());
  ServiceCycleRunner runner(service);
  PlcRequestWords request;
  request.part_number = 9;
  request.lobe = 1;
  const std::optional<PlcCycleOutcome> o = runner.start(request);
  ASSERT_TRUE(o.has_value());
  EXPECT_EQ(o->code, PlcResultCode::kUnknownPart);
  EXPECT_EQ(gauges_made_, 0);
}

// The serial number and operator as a PLC program writes them (words 13-36).
PlcRequestWords plc_request(std::string_view serial, std::string_view operator_name) {
  PlcRequestWords request;
  request.part_number = 1;
  request.lobe = 1;
  request.request = plc_registers::kMeasureBit;
  EXPECT_TRUE(encode_plc_text(serial, request.serial).ok());
  EXPECT_TRUE(encode_plc_text(operator_name, request.operator_name).ok());
  return request;
}

TEST_F(ServiceStateTest, APlcRunKeepsTheSerialNumberAndOperatorThePlcWrote) {
  Service service(config_, design_gauge());
  ServiceCycleRunner runner(service);
  const std::string full_serial = "0123456789ABCDEFGHIJKLMNOPQRSTUV";  // 32: no NUL in the words
  ASSERT_FALSE(runner.start(plc_request(full_serial, "anna")).has_value());
  const std::optional<PlcCycleOutcome> first = wait_for_outcome(runner);
  ASSERT_TRUE(first.has_value());
  ASSERT_EQ(first->code, PlcResultCode::kTablePushed) << first->message;
  // All words 0: neither given.
  ASSERT_FALSE(runner.start(plc_request("", "")).has_value());
  const std::optional<PlcCycleOutcome> second = wait_for_outcome(runner);
  ASSERT_TRUE(second.has_value());
  ASSERT_EQ(second->code, PlcResultCode::kTablePushed) << second->message;

  Result<RunStore> store = RunStore::open_read_only(db());
  ASSERT_TRUE(store.ok()) << store.error().message;
  Result<StoredRun> with = store->load_run(first->run_id);
  ASSERT_TRUE(with.ok()) << with.error().message;
  EXPECT_EQ(with->summary.serial, full_serial);
  EXPECT_EQ(with->summary.operator_name, "anna");
  Result<StoredRun> without = store->load_run(second->run_id);
  ASSERT_TRUE(without.ok()) << without.error().message;
  EXPECT_EQ(without->summary.serial, "");
  EXPECT_EQ(without->summary.operator_name, "");
  RunQuery by_serial;
  by_serial.serial = full_serial;
  Result<std::vector<RunSummary>> found = store->list_runs(by_serial);
  ASSERT_TRUE(found.ok()) << found.error().message;
  ASSERT_EQ(found->size(), 1u) << "`runs list --serial` finds the PLC's run";
  EXPECT_EQ(found->front().id, first->run_id);
}

TEST_F(ServiceStateTest, APlcOperatorThatIsNotTextIsRefusedAtOnce) {
  Service service(config_, design_gauge());
  ServiceCycleRunner runner(service, 2000);
  // "anna" and the CR LF a badge reader ends its line with: words 29, 30, then 31.
  PlcRequestWords request = plc_request("A123", "anna");
  request.operator_name[2] = 0x0d0a;
  const std::optional<PlcCycleOutcome> o = runner.start(request);
  ASSERT_TRUE(o.has_value()) << "refused before a run starts";
  EXPECT_EQ(o->code, PlcResultCode::kBadIdentity);
  EXPECT_FALSE(plc_result_is_done(o->code)) << "answered with fault";
  EXPECT_NE(o->message.find("PLC operator: word 31 (holding register 2031), high byte, is 0x0D"), std::string::npos)
      << o->message;
  EXPECT_EQ(gauges_made_, 0);
  EXPECT_TRUE(service.reserve_run().ok()) << "no run reserved";
}

// Word 37, the part temperature in 0.1 deg C: 214 is kept with the run as 21.4 given by the
// PLC, a negative one as it is, 0x8000 is not given (no settings line).
TEST_F(ServiceStateTest, APlcRunKeepsThePartTemperatureThePlcWrote) {
  Service service(config_, design_gauge());
  ServiceCycleRunner runner(service);
  std::vector<std::int64_t> runs;
  for (std::uint16_t word :
       {std::uint16_t{214}, static_cast<std::uint16_t>(-15), plc_registers::kPartTemperatureNotGiven}) {
    PlcRequestWords request = plc_request("", "");
    request.part_temperature = word;
    ASSERT_FALSE(runner.start(request).has_value()) << word;
    const std::optional<PlcCycleOutcome> o = wait_for_outcome(runner);
    ASSERT_TRUE(o.has_value());
    ASSERT_TRUE(plc_result_is_done(o->code)) << o->message;
    runs.push_back(o->run_id);
  }
  Result<RunStore> store = RunStore::open_read_only(db());
  ASSERT_TRUE(store.ok()) << store.error().message;
  auto settings_of = [&](std::int64_t id) {
    Result<StoredRun> r = store->load_run(id);
    EXPECT_TRUE(r.ok()) << r.error().message;
    return r ? r->settings : std::string();
  };
  EXPECT_NE(settings_of(runs[0]).find("\npart.temperature_c = 21.4\npart.temperature_source = plc\n"),
            std::string::npos)
      << settings_of(runs[0]);
  EXPECT_NE(settings_of(runs[1]).find("\npart.temperature_c = -1.5\n"), std::string::npos) << settings_of(runs[1]);
  EXPECT_EQ(settings_of(runs[2]).find("part.temperature"), std::string::npos) << "not given: no line";
}

// A part temperature beyond -40.0..150.0 deg C (a word left unset, a scale slipped) refuses the
// request at once with its own result code, the message naming the word, its register and the value.
TEST_F(ServiceStateTest, APlcPartTemperatureOutOfRangeIsRefusedAtOnce) {
  Service service(config_, design_gauge());
  ServiceCycleRunner runner(service, 2000);
  struct Case {
    std::uint16_t word;
    std::string said;
  };
  const Case cases[] = {
      {1501, "word 37 (holding register 2037) is 1501, 150.1 deg C, outside -40.0 to 150.0 deg C"},
      {static_cast<std::uint16_t>(-401), "is -401, -40.1 deg C"},
      {0x7FFF, "is 32767, 3276.7 deg C"},
      {0x8001, "is -32767, -3276.7 deg C"},
  };
  for (const Case& c : cases) {
    PlcRequestWords request = plc_request("A123", "anna");
    request.part_temperature = c.word;
    const std::optional<PlcCycleOutcome> o = runner.start(request);
    ASSERT_TRUE(o.has_value()) << "refused before a run starts: " << c.word;
    EXPECT_EQ(o->code, PlcResultCode::kBadPartTemperature);
    EXPECT_FALSE(plc_result_is_done(o->code)) << "answered with fault";
    EXPECT_NE(o->message.find("PLC part temperature: "), std::string::npos) << o->message;
    EXPECT_NE(o->message.find(c.said), std::string::npos) << o->message;
    EXPECT_NE(o->message.find("-32768 (0x8000) when it has none"), std::string::npos) << o->message;
  }
  // The range's ends are temperatures.
  for (std::uint16_t word : {static_cast<std::uint16_t>(-400), std::uint16_t{1500}}) {
    Result<std::optional<double>> t = decode_plc_part_temperature(word, 0);
    ASSERT_TRUE(t.ok()) << t.error().message;
    ASSERT_TRUE(t->has_value());
  }
  EXPECT_EQ(plc_result_name(PlcResultCode::kBadPartTemperature), "bad part temperature");
  EXPECT_EQ(gauges_made_, 0);
  EXPECT_TRUE(service.reserve_run().ok()) << "no run reserved";
}

TEST_F(ServiceStateTest, AnExceptionOnTheWorkerIsAFaultForThePlcAndTheServiceGoesOn) {
  int calls = 0;
  Service service(config_, [&calls, good = design_gauge()](const ServiceConfig& c) -> std::unique_ptr<GaugeClient> {
    if (++calls == 1) throw std::runtime_error("scripted failure");
    return good(c);
  });
  ServiceCycleRunner runner(service);
  PlcRequestWords request;
  request.part_number = 1;
  request.lobe = 1;
  ASSERT_FALSE(runner.start(request).has_value());
  std::optional<PlcCycleOutcome> o = wait_for_outcome(runner);
  ASSERT_TRUE(o.has_value());
  EXPECT_EQ(o->code, PlcResultCode::kOtherFault);
  EXPECT_NE(o->message.find("scripted failure"), std::string::npos) << o->message;
  EXPECT_EQ(service.health()["thread_faults"], 1);
  EXPECT_EQ(service.health()["state"], "idle") << "the measuring flag fell with the exception";
  ASSERT_TRUE(service.flush_events());

  Result<RunStore> store = RunStore::open_read_only(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  Result<std::vector<StoredEvent>> events = store->list_events(EventQuery{});
  ASSERT_TRUE(events.ok()) << events.error().message;
  bool recorded = false;
  for (const StoredEvent& e : *events)
    recorded |= e.event.code == "internal error" && e.event.kind == EventKind::kFault;
  EXPECT_TRUE(recorded);

  // The run was released: the next request runs.
  ASSERT_FALSE(runner.start(request).has_value());
  o = wait_for_outcome(runner);
  ASSERT_TRUE(o.has_value());
  EXPECT_EQ(o->code, PlcResultCode::kTablePushed) << o->message;
}

TEST_F(ServiceStateTest, NoPushStartsOnceTheServiceStops) {
  Service service(config_, design_gauge());
  service.set_stopping();
  for (const Result<nlohmann::json>& r :
       {service.approve(1, "anna", ""), service.reject(1, "anna", ""), service.rollback("CAM_INTAKE_L1", 1, "anna")}) {
    ASSERT_FALSE(r.ok());
    EXPECT_EQ(r.error().code, ErrorCode::kRefused) << r.error().message;
    EXPECT_NE(r.error().message.find("stopping"), std::string::npos) << r.error().message;
  }
  EXPECT_FALSE(service.wait_and_reserve().ok());
}

// A rejection through the service: the table leaves pending, the table in force stays; an
// unknown id and a second decision are refused, nothing written.
TEST_F(ServiceStateTest, ARejectionLeavesTheTableInForceAndIsRefusedTwice) {
  std::int64_t pending_id = 0;
  {
    Result<RunStore> store = RunStore::open(dir_ / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    Result<std::int64_t> run = store->insert_run(testing::sample_run("intake_flat", 1, "grinder-7", utc_now(), 4.0));
    ASSERT_TRUE(run.ok()) << run.error().message;
    PendingTable pending;
    pending.run_id = *run;
    pending.nc_file = (dir_ / "nc" / "CAM_INTAKE_L1.SPF").string();
    pending.program_text = "; a table\nM17\n";
    pending.reason = "approval required";
    Result<std::int64_t> p = store->add_pending(pending);
    ASSERT_TRUE(p.ok()) << p.error().message;
    pending_id = *p;
  }
  Service service(config_, design_gauge());
  Result<nlohmann::json> unknown = service.reject(pending_id + 7, "anna", "");
  ASSERT_FALSE(unknown.ok());
  EXPECT_EQ(unknown.error().code, ErrorCode::kNotFound) << unknown.error().message;
  EXPECT_NE(unknown.error().message.find("GET /api/nc/pending lists the ids"), std::string::npos)
      << unknown.error().message;

  Result<nlohmann::json> rejected = service.reject(pending_id, "anna", "flank error from a worn wheel");
  ASSERT_TRUE(rejected.ok()) << rejected.error().message;
  EXPECT_EQ((*rejected)["rejected"], pending_id);
  EXPECT_EQ((*rejected)["by"], "anna");
  Result<RunStore> store = RunStore::open_read_only(dir_ / "gaugeloop.sqlite");
  ASSERT_TRUE(store.ok());
  Result<PendingTable> after = store->load_pending(pending_id);
  ASSERT_TRUE(after.ok()) << after.error().message;
  EXPECT_EQ(after->status, PendingStatus::kRejected);
  EXPECT_EQ(after->decided_by, "anna");
  EXPECT_FALSE(fs::exists(dir_ / "nc" / "CAM_INTAKE_L1.SPF")) << "a rejection writes nothing to the control";

  Result<nlohmann::json> again = service.reject(pending_id, "ben", "");
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(again.error().code, ErrorCode::kRefused) << again.error().message;
  EXPECT_EQ(gauges_made_, 0);
}

// SIGTERM while a run started over HTTP finishes, in the order service/daemon.cc stops: the
// PLC is polled on and every request answered "not now" until that run has ended.
TEST_F(ServiceStateTest, WhileStoppingEveryPlcRequestIsToldNotNowUntilTheLastRunHasEnded) {
  RunHold hold;
  Service service(config_, held_gauge(hold));
  auto owned = std::make_unique<SharedPlc>();
  SharedPlc& plc = *owned;
  PlcTrigger trigger(service, fast_plc(), std::move(owned));
  trigger.start();
  ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return s.heartbeats.size() >= 2; }));

  Result<nlohmann::json> http_run = make_error(ErrorCode::kInternal, "not run");
  std::thread http([&] { http_run = service.measure("intake_flat", 1, "over HTTP"); });
  ASSERT_TRUE(hold.wait_entered());

  service.set_stopping();
  std::atomic<bool> trigger_stopped{false};
  std::thread stopper([&] {
    trigger.stop();
    trigger_stopped = true;
    service.stop();
  });
  struct Joined {  // a failed assertion below still ends the run and both threads
    std::function<void()> end;
    ~Joined() { end(); }
  } const joined{[&] {
    hold.release();
    if (http.joinable()) http.join();
    if (stopper.joinable()) stopper.join();
  }};
  EXPECT_EQ(service.health()["state"], "stopping");

  // A configured part and an unknown one: both "not now", at once, with the heartbeat going.
  for (const std::uint16_t part : {std::uint16_t{1}, std::uint16_t{9}}) {
    plc.request(part, 1);
    ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return s.words.ack && s.words.fault; }))
        << "part number " << part << ": no answer while stopping";
    const SharedPlc::Seen answered = plc.seen();
    EXPECT_EQ(answered.words.result_code, PlcResultCode::kNotNow) << "part number " << part;
    EXPECT_FALSE(answered.words.done);
    EXPECT_FALSE(answered.words.busy);
    EXPECT_EQ(answered.words.run_id, 0u);
    plc.clear();
    ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return !s.words.ack && !s.words.fault; }));
  }
  const std::size_t before = plc.seen().heartbeats.size();
  ASSERT_TRUE(plc.wait_until([before](const SharedPlc::Seen& s) { return polls_since(s, before) >= 5; }));
  EXPECT_FALSE(trigger_stopped) << "the run started over HTTP still runs";

  joined.end();
  ASSERT_TRUE(http_run.ok()) << http_run.error().message;
  EXPECT_TRUE((*http_run)["pushed"].get<bool>()) << http_run->dump();
  expect_counted_every_poll(plc.seen().heartbeats);

  // Both refusals are events, with the reason, written before stop() returned.
  int refused = 0;
  for (const StoredEvent& e : stored_events(db())) {
    if (e.event.code == "plc request" && e.event.message.find("refused: the service is stopping") != std::string::npos)
      ++refused;
  }
  EXPECT_EQ(refused, 2);
}

// A serial number with a byte that is not text, through the trigger as the PLC sees it:
// fault with result code 9, an event naming the register and the byte, nothing measured.
TEST_F(ServiceStateTest, APlcSerialWithAControlOrNonAsciiByteIsAFaultNamingTheRegister) {
  Service service(config_, design_gauge());
  auto owned = std::make_unique<SharedPlc>();
  SharedPlc& plc = *owned;
  PlcSettings settings = fast_plc();
  settings.link.base_address = 1000;
  PlcTrigger trigger(service, settings, std::move(owned));
  trigger.start();
  // Seen low first: a request already high when the trigger starts is not a new one.
  ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return s.heartbeats.size() >= 2; }));
  struct Case {
    std::uint16_t word_15;  // the serial's third word: characters 5 and 6
    std::string named;
  };
  const Case cases[] = {
      {('C' << 8) | 0x07, "word 15 (holding register 1015), low byte, is 0x07"},  // BEL
      {0xE94B, "word 15 (holding register 1015), high byte, is 0xE9"},            // Latin-1 e acute
  };
  for (const Case& c : cases) {
    std::array<std::uint16_t, plc_registers::kSerialWords> words{};
    words[0] = ('S' << 8) | 'N';
    words[1] = ('-' << 8) | '4';
    words[2] = c.word_15;
    words[3] = ('7' << 8) | '7';
    plc.serial_words(words);
    plc.request(1, 1);
    ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return s.words.ack && (s.words.fault || s.words.done); }))
        << c.named;
    const SharedPlc::Seen answered = plc.seen();
    EXPECT_TRUE(answered.words.fault) << c.named;
    EXPECT_EQ(answered.words.result_code, PlcResultCode::kBadIdentity) << c.named;
    EXPECT_EQ(answered.words.run_id, 0u);
    plc.clear();
    ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return !s.words.ack && !s.words.fault; }));
  }
  trigger.stop();
  ASSERT_TRUE(service.flush_events(kGenerous));
  EXPECT_EQ(gauges_made_, 0) << "nothing measured";

  std::vector<std::string> refusals;
  for (const StoredEvent& e : stored_events(db())) {
    if (e.event.code == "plc request" && e.event.message.find("refused") != std::string::npos)
      refusals.push_back(e.event.message);
  }
  ASSERT_EQ(refusals.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_NE(refusals[i].find("PLC serial number: " + cases[i].named), std::string::npos) << refusals[i];
  }
  Result<RunStore> store = RunStore::open_read_only(db());
  ASSERT_TRUE(store.ok()) << store.error().message;
  Result<std::vector<RunSummary>> runs = store->list_runs(RunQuery{});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  EXPECT_TRUE(runs->empty()) << "no run stored";
}

// Holds the run database with an exclusive lock from a second connection, as a backup or a
// person's sqlite3 session would, until released.
class DatabaseLock {
 public:
  explicit DatabaseLock(const fs::path& db) {
    if (sqlite3_open(db.c_str(), &db_) == SQLITE_OK) {
      locked_ = sqlite3_exec(db_, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr) == SQLITE_OK;
    }
  }
  ~DatabaseLock() {
    release();
    sqlite3_close(db_);
  }
  bool locked() const { return locked_; }
  void release() {
    if (locked_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
    locked_ = false;
  }

 private:
  sqlite3* db_ = nullptr;
  bool locked_ = false;
};

// The PLC's link lost and back, and a request refused, while the database is locked: the
// trigger polls on, the heartbeat one on at every poll, and the events are written once the
// lock is gone, in order, stamped when they happened.
TEST_F(ServiceStateTest, TheHeartbeatCountsEveryPollWhileTheDatabaseIsLocked) {
  Service service(config_, design_gauge());
  service.record_event(EventKind::kInfo, "test", "", 0, std::nullopt, "the database made before the lock");
  ASSERT_TRUE(service.flush_events());
  auto owned = std::make_unique<SharedPlc>();
  SharedPlc& plc = *owned;
  PlcTrigger trigger(service, fast_plc(), std::move(owned));
  trigger.start();
  ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return s.heartbeats.size() >= 2; }));

  DatabaseLock lock(db());
  ASSERT_TRUE(lock.locked());
  plc.drop_link();  // "plc link down", then "plc link up" after the reconnect backoff
  ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return s.connects >= 2; }));
  plc.request(9, 1);  // no such part: refused at once, "plc request", then "plc fault"
  ASSERT_TRUE(plc.wait_until([](const SharedPlc::Seen& s) { return s.words.ack && s.words.fault; }));
  EXPECT_EQ(plc.seen().words.result_code, PlcResultCode::kUnknownPart);
  plc.clear();
  // Held for 10 s, twice SQLite's busy timeout, so the writer's own wait for the lock runs out
  // and it retries, while the trigger polls on: a condition of the test, not a wait for an event.
  const std::size_t before = plc.seen().heartbeats.size();
  const auto held_until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  ASSERT_TRUE(plc.wait_until([before, held_until](const SharedPlc::Seen& s) {
    return polls_since(s, before) >= 50 && std::chrono::steady_clock::now() >= held_until;
  })) << "the trigger stopped polling while the database was locked";
  EXPECT_FALSE(service.flush_events(std::chrono::milliseconds(0))) << "the events wait for the lock";
  const std::string before_release = utc_now();

  lock.release();
  ASSERT_TRUE(service.flush_events(kGenerous));
  trigger.stop();
  expect_counted_every_poll(plc.seen().heartbeats);

  std::vector<std::string> codes;
  for (const StoredEvent& e : stored_events(db())) {
    if (e.event.code == "test") continue;
    codes.push_back(e.event.code);
    EXPECT_LE(e.event.at_utc, before_release) << e.event.code << ": stamped when written, not when it happened";
  }
  EXPECT_EQ(codes, (std::vector<std::string>{"plc link down", "plc link up", "plc request", "plc fault"}));
  EXPECT_NE(service.metrics().find("gaugeloop_service_events_dropped_total 0\n"), std::string::npos);
}

// A database locked for longer than the queue holds: the oldest waiting events are dropped and
// counted, memory stays bounded, and the newest are written in order once it is free.
TEST_F(ServiceStateTest, AFullEventQueueDropsItsOldestAndCountsThem) {
  Service service(config_, design_gauge());
  service.record_event(EventKind::kInfo, "test", "", 0, std::nullopt, "the database made before the lock");
  ASSERT_TRUE(service.flush_events());
  DatabaseLock lock(db());
  ASSERT_TRUE(lock.locked());
  const int total = static_cast<int>(kEventQueueLimit) + 10;
  for (int i = 0; i < total; ++i) {
    service.record_event(EventKind::kInfo, "step", "", 0, std::nullopt, std::to_string(i));
  }
  lock.release();
  ASSERT_TRUE(service.flush_events(kGenerous));

  std::vector<int> written;
  for (const StoredEvent& e : stored_events(db())) {
    if (e.event.code == "step") written.push_back(std::stoi(e.event.message));
  }
  // Those being written when the queue filled (the batch the writer had taken, if any) are kept too.
  ASSERT_GE(written.size(), kEventQueueLimit);
  ASSERT_LE(written.size(), kEventQueueLimit + kEventBatch);
  EXPECT_TRUE(std::is_sorted(written.begin(), written.end()));
  EXPECT_EQ(written.back(), total - 1) << "the newest are kept";
  const std::string dropped = std::to_string(total - static_cast<int>(written.size()));
  EXPECT_NE(service.metrics().find("gaugeloop_service_events_dropped_total " + dropped + "\n"), std::string::npos)
      << service.metrics();
}

}  // namespace
}  // namespace gaugeloop
