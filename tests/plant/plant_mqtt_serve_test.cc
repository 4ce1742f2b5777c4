// `gaugeloop serve` with [plant.mqtt], as a process: its states reach the broker (started,
// online, stopping, offline on SIGTERM; the last will when killed), /api/health shows the
// outbox, and the run database's outbox is on.
#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "storage/run_store.h"
#include "tests/support/mosquitto_broker.h"
#include "tests/support/raw_http.h"
#include "tests/support/service_process.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::Subscriber;
using testing::wait_until;

class PlantServeTest : public ::testing::Test {
 protected:
  void SetUp() override {
    broker_ = std::make_unique<testing::MosquittoBroker>(dir_ / "broker");
    ASSERT_TRUE(broker_->started());
    const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
    std::ofstream(dir_ / "gaugeloop.toml")
        << "machine = \"grinder-3\"\n"
        << "[gauge]\nconfig = \"" << (examples / "gauges" / "simulator.toml").string() << "\"\n"
        << "[[part]]\nfile = \"" << (examples / "intake_flat.toml").string() << "\"\n"
        << "[nc]\ndir = \"nc\"\ntemplate = \"" << (examples / "sinumerik" / "cam_table.spf").string() << "\"\n"
        << "[database]\npath = \"runs.sqlite\"\n[http]\nport = 0\n"
        << "[plant.mqtt]\nhost = \"127.0.0.1\"\nport = " << broker_->port() << "\nsite = \"plant-a\"\n";
  }
  std::vector<std::string> states(const Subscriber& sub) const {
    std::vector<std::string> out;
    for (const testing::Received& r : sub.of("/state")) out.push_back(r.payload.value("state", ""));
    return out;
  }
  static bool has(const std::vector<std::string>& v, const std::string& s) {
    return std::find(v.begin(), v.end(), s) != v.end();
  }
  std::string log() const {
    std::ifstream in(dir_ / "serve.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  }

  testing::TempDir dir_;
  std::unique_ptr<testing::MosquittoBroker> broker_;
};

TEST_F(PlantServeTest, TheServiceSaysItsStatesAndHealthShowsTheOutbox) {
  Subscriber sub(broker_->port(), "gaugeloop/plant-a/grinder-3/state");
  testing::ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  ASSERT_TRUE(wait_until([&] { return has(states(sub), "online") && has(states(sub), "started"); })) << log();

  const std::string answer =
      testing::raw_http(port, "GET /api/health HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n");
  const std::size_t body = answer.find("\r\n\r\n");
  ASSERT_NE(body, std::string::npos) << answer;
  const nlohmann::json health = nlohmann::json::parse(answer.substr(body + 4), nullptr, false);
  ASSERT_TRUE(health.contains("outbox")) << answer;
  EXPECT_EQ(health["outbox"]["dropped_total"], 0);
  EXPECT_TRUE(health["outbox"]["depth"].is_number_integer()) << health.dump();

  Result<RunStore> store = RunStore::open_read_only(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok()) << store.error().message;
  Result<OutboxCounts> counts = store->outbox_counts();
  ASSERT_TRUE(counts.ok());
  EXPECT_TRUE(counts->settings.enabled) << "turned on at start for [plant.mqtt]";

  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
  ASSERT_TRUE(wait_until([&] { return !states(sub).empty() && states(sub).back() == "offline"; })) << log();
  EXPECT_TRUE(has(states(sub), "stopping")) << "queued at SIGTERM, sent before the stop";
  EXPECT_EQ(sub.of("/state").back().payload["detail"], "the service stopped");
}

TEST_F(PlantServeTest, AKilledServiceLeavesTheLastWill) {
  testing::ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  ASSERT_GT(service.port(), 0) << log();
  {
    Subscriber sub(broker_->port(), "gaugeloop/plant-a/grinder-3/state");
    ASSERT_TRUE(wait_until([&] { return has(states(sub), "online"); })) << log();
  }
  service.signal(SIGKILL);
  service.wait();
  Subscriber late(broker_->port(), "gaugeloop/plant-a/grinder-3/state");
  ASSERT_TRUE(wait_until([&] {
    const std::vector<testing::Received> got = late.of("/state");
    return !got.empty() && got.back().payload["state"] == "offline";
  })) << "the broker publishes the will when the connection drops";
  EXPECT_TRUE(late.of("/state").back().retained);
  EXPECT_EQ(late.of("/state").back().payload["detail"], "the connection to the broker ended without a goodbye");
}

}  // namespace
}  // namespace gaugeloop
