// The service's own sync ([plant.central]) against a real PostgreSQL 15 cluster: at the start
// and after each run it is told of, through a server that goes down and comes back, and
// `gaugeloop serve` as a process syncing its file and showing it in /api/health and /metrics.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "plant/central_syncer.h"
#include "service/service.h"
#include "storage/run_store.h"
#include "tests/support/postgres_server.h"
#include "tests/support/raw_http.h"
#include "tests/support/sample_runs.h"
#include "tests/support/service_process.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"
#include "tests/support/wait_until.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using std::chrono::seconds;
using testing::PostgresServer;
using testing::shared_postgres;
using testing::wait_until;

using testing::has;

// Generous: a sync on a loaded 2-core machine, with PostgreSQL beside it, is slow.
constexpr seconds kWithin{90};

class CentralSyncerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> opened = RunStore::open(db_path());
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    store_.emplace(std::move(*opened));
  }
  void TearDown() override { store_.reset(); }

  fs::path db_path() const { return dir_ / "runs.sqlite"; }
  // `n` more runs of intake lobe 1 on g1, one minute apart from `first`.
  void add_runs(int n, int first) {
    for (int i = first; i < first + n; ++i) {
      char started[32];
      std::snprintf(started, sizeof started, "2026-11-30T08:%02d:00Z", i);
      ASSERT_TRUE(store_->insert_run(testing::sample_run("intake", 1, "g1", started, 2.0 + 0.5 * i)).ok());
    }
  }
  static CentralSyncSettings settings(const std::string& url, seconds interval) {
    CentralSyncSettings s;
    s.url = url;
    s.interval = interval;
    s.batch_size = 2;  // several batches per sync
    s.retry_min = milliseconds(50);
    return s;
  }

  testing::TempDir dir_{"central-syncer"};
  std::optional<RunStore> store_;
};

TEST_F(CentralSyncerTest, SyncsAtTheStartAndAgainWhenARunIsStored) {
  const std::string url = shared_postgres().create_database();
  ASSERT_FALSE(url.empty());
  const std::string db = url.substr(url.rfind('/') + 1);
  add_runs(3, 0);
  // An interval of an hour: only the start and notify() can make the syncs below.
  CentralSyncer syncer(db_path(), settings(url, std::chrono::hours(1)), "g1");
  ASSERT_TRUE(wait_until([&] { return syncer.status().runs_copied == 3 && syncer.status().caught_up; }, kWithin))
      << syncer.status().last_error;
  EXPECT_EQ(shared_postgres().psql(db, "SELECT count(*), count(DISTINCT uuid) FROM runs"), "3|3");

  add_runs(2, 3);
  syncer.notify();
  ASSERT_TRUE(wait_until([&] { return syncer.status().runs_copied == 5; }, kWithin)) << syncer.status().last_error;
  EXPECT_EQ(shared_postgres().psql(db, "SELECT count(*), count(DISTINCT uuid) FROM runs"), "5|5");
  EXPECT_EQ(shared_postgres().psql(db,
                                   "SELECT machine, last_local_id FROM sync_progress WHERE "
                                   "table_name = 'runs'"),
            "g1|5");

  const nlohmann::json health = syncer.health();
  EXPECT_EQ(health["url"], url);
  EXPECT_EQ(health["interval_s"], 3600);
  EXPECT_TRUE(health["last_success_utc"].is_string()) << health.dump();
  EXPECT_TRUE(health["last_error"].is_null()) << health.dump();
  EXPECT_EQ(health["consecutive_failures"], 0);
  EXPECT_EQ(health["last_run_id"], 5);
  EXPECT_EQ(health["runs_copied"], 5);
  EXPECT_EQ(health["caught_up"], true);
  EXPECT_EQ(health["degraded"], false);
  const std::string metrics = syncer.metrics();
  EXPECT_TRUE(has(metrics, "gaugeloop_central_sync_ok 1\n")) << metrics;
  EXPECT_TRUE(has(metrics, "gaugeloop_central_sync_failures_total 0\n")) << metrics;
  EXPECT_TRUE(has(metrics, "gaugeloop_central_sync_copied_total{table=\"runs\"} 5\n")) << metrics;
  EXPECT_FALSE(has(metrics, "gaugeloop_central_sync_last_success_timestamp_seconds 0\n")) << metrics;
}

TEST_F(CentralSyncerTest, AServerDownLosesNothingAndHealthSaysSoUntilItIsBack) {
  // A server of its own: this test stops it.
  PostgresServer server;
  ASSERT_EQ(server.start(), "");
  const std::string url = server.create_database();
  ASSERT_FALSE(url.empty());
  const std::string db = url.substr(url.rfind('/') + 1);
  add_runs(2, 0);
  CentralSyncer syncer(db_path(), settings(url, seconds(1)), "g1");
  ASSERT_TRUE(wait_until([&] { return syncer.status().runs_copied == 2; }, kWithin)) << syncer.status().last_error;

  ASSERT_EQ(server.kill_server(), "");
  add_runs(3, 2);
  syncer.notify();
  ASSERT_TRUE(wait_until([&] { return syncer.status().consecutive_failures >= 2; }, kWithin));
  EXPECT_FALSE(syncer.status().last_error.empty());
  EXPECT_TRUE(has(syncer.metrics(), "gaugeloop_central_sync_ok 0\n")) << syncer.metrics();
  // Three intervals without a sync getting through.
  ASSERT_TRUE(wait_until([&] { return syncer.health()["degraded"] == true; }, kWithin)) << syncer.health().dump();
  EXPECT_TRUE(syncer.health()["last_error"].is_string());

  ASSERT_EQ(server.start_again(), "");
  ASSERT_TRUE(wait_until(
      [&] {
        const CentralSyncerStatus s = syncer.status();
        return s.runs_copied == 5 && s.consecutive_failures == 0;
      },
      kWithin))
      << syncer.status().last_error;
  EXPECT_EQ(server.psql(db, "SELECT count(*), count(DISTINCT uuid) FROM runs"), "5|5");
  EXPECT_EQ(syncer.health()["degraded"], false);
  EXPECT_TRUE(syncer.health()["last_error"].is_null());
  EXPECT_GE(syncer.status().syncs_failed, 2);
}

// An event of a run that the service writes after the run's own sync (a push's outcome, a
// refusal) reaches the central history at once, not at the next interval (an hour here).
TEST_F(CentralSyncerTest, AnEventOfARunWrittenAfterItsSyncIsCopiedWithoutWaitingTheInterval) {
  const std::string url = shared_postgres().create_database();
  ASSERT_FALSE(url.empty());
  const std::string db = url.substr(url.rfind('/') + 1);
  add_runs(1, 0);
  CentralSyncer syncer(db_path(), settings(url, std::chrono::hours(1)), "g1");
  ASSERT_TRUE(wait_until([&] { return syncer.status().runs_copied == 1 && syncer.status().caught_up; }, kWithin))
      << syncer.status().last_error;
  ServiceConfig config;
  config.job.db_path = db_path();
  Service service(config, {});
  service.set_central_sync(&syncer);
  service.record_event(EventKind::kInfo, "pushed", "intake", 1, 1, "the table of run 1 was pushed");
  ASSERT_TRUE(wait_until(
      [&] { return shared_postgres().psql(db, "SELECT count(*) FROM events WHERE run_uuid IS NOT NULL") == "1"; },
      kWithin))
      << syncer.status().last_error;
  EXPECT_EQ(shared_postgres().psql(db, "SELECT e.code FROM events AS e JOIN runs AS r ON r.uuid = e.run_uuid"),
            "pushed");
  service.stop();
}

TEST_F(CentralSyncerTest, TheServiceSyncsItsFileAndShowsItInHealthAndMetrics) {
  const std::string url = shared_postgres().create_database();
  ASSERT_FALSE(url.empty());
  const std::string db = url.substr(url.rfind('/') + 1);
  add_runs(4, 0);
  store_.reset();  // the service's file from now on
  const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
  std::ofstream(dir_ / "gaugeloop.toml") << "machine = \"grinder-5\"\n"
                                         << "[gauge]\nconfig = \"" << (examples / "gauges" / "simulator.toml").string()
                                         << "\"\n"
                                         << "[[part]]\nfile = \"" << (examples / "intake_flat.toml").string() << "\"\n"
                                         << "[nc]\ndir = \"nc\"\ntemplate = \""
                                         << (examples / "sinumerik" / "cam_table.spf").string() << "\"\n"
                                         << "[database]\npath = \"runs.sqlite\"\n[http]\nport = 0\n"
                                         << "[plant.central]\nurl = \"" << url << "\"\ninterval_s = 3600\n";
  testing::ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  const auto log = [this] {
    std::ifstream in(dir_ / "serve.log");
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  ASSERT_GT(port, 0) << log();
  ASSERT_TRUE(wait_until([&] { return shared_postgres().psql(db, "SELECT count(*) FROM runs") == "4"; }, kWithin))
      << log();
  // Named by the config's machine.
  EXPECT_EQ(shared_postgres().psql(db, "SELECT DISTINCT source_machine FROM runs"), "grinder-5");

  const auto get = [port](const std::string& path) {
    const std::string answer =
        testing::raw_http(port, "GET " + path + " HTTP/1.1\r\nHost: t\r\nConnection: close\r\n\r\n");
    const std::size_t body = answer.find("\r\n\r\n");
    return body == std::string::npos ? answer : answer.substr(body + 4);
  };
  nlohmann::json health;
  ASSERT_TRUE(wait_until(
      [&] {
        health = nlohmann::json::parse(get("/api/health"), nullptr, false);
        return health.contains("central") && health["central"].is_object() && health["central"]["runs_copied"] == 4;
      },
      kWithin))
      << health.dump();
  EXPECT_EQ(health["central"]["url"], url);
  EXPECT_EQ(health["central"]["caught_up"], true);
  EXPECT_TRUE(health["central"]["last_error"].is_null()) << health.dump();
  EXPECT_TRUE(has(get("/metrics"), "gaugeloop_central_sync_copied_total{table=\"runs\"} 4\n"));
  EXPECT_TRUE(has(log(), "central history: " + url)) << log();

  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
}

}  // namespace
}  // namespace gaugeloop
