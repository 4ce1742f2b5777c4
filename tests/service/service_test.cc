// The service's state without a process, a socket or a signal: the one run at a time, a run
// measured from a scripted gauge through the real job and database, the PLC cycle runner, and
// a thread ended by an exception.
#include "service/service.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <thread>

#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "service/plc_trigger.h"
#include "storage/run_store.h"
#include "tests/acquisition/scripted_gauge.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

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

}  // namespace
}  // namespace gaugeloop
