// The HTTP API's run lists and trends read from the central history ([http] history =
// "central"): every grinder's runs, each row saying whether its run is in this grinder's file,
// against a real PostgreSQL 15 cluster (tests/support/postgres_server.h).
#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>

#include "plant/central_sync.h"
#include "service/http_api.h"
#include "storage/run_store.h"
#include "tests/support/postgres_server.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"

// Last: httplib brings <resolv.h>, whose `res` macro breaks Eigen's headers.
#include <httplib.h>

#include "tests/support/http_answer.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::has;
using testing::shared_postgres;
using testing::TempDir;

class CentralHttpTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(shared_postgres().running());
    url_ = shared_postgres().create_database();
    ASSERT_FALSE(url_.empty());
  }
  void TearDown() override { api_.reset(); }

  // `count` runs of intake lobe 1 on `machine` in `dir`'s file, an hour apart from `first_hour`,
  // each with a lift error characteristic; synced into the central history.
  void grinder(const TempDir& dir, const std::string& machine, int count, int first_hour) {
    Result<RunStore> store = RunStore::open(dir / "gaugeloop.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (int i = 0; i < count; ++i) {
      const std::string started =
          "2026-11-20T" + std::string(first_hour + i < 10 ? "0" : "") + std::to_string(first_hour + i) + ":00:00Z";
      RunRecord r = testing::sample_run("intake_flat", 1, machine, started, 5.0 + i);
      r.characteristics = {single_characteristic("lift_error", "um", 5.0 + i, Limits{-12.0, 12.0})};
      ASSERT_TRUE(store->insert_run(r).ok());
    }
    Result<CentralSyncCounts> synced = sync_to_central(*store, url_, machine);
    ASSERT_TRUE(synced.ok()) << synced.error().message;
  }

  void start(const std::string& history_url) {
    HttpSettings settings;
    settings.port = 0;
    settings.history_url = history_url;
    Result<std::unique_ptr<HttpApi>> api = HttpApi::start(settings, here_ / "gaugeloop.sqlite", {}, {});
    ASSERT_TRUE(api.ok()) << api.error().message;
    api_ = std::move(*api);
    client_ = std::make_unique<httplib::Client>("127.0.0.1", api_->port());
  }

  testing::HttpAnswer get(const std::string& path) { return testing::answer_of(client_->Get(path)); }

  // Each row's machine and whether it is here, in the order given.
  static std::vector<std::string> machines_and_here(const json& rows) {
    std::vector<std::string> out;
    for (const json& r : rows) out.push_back(r["machine"].get<std::string>() + (r["here"].get<bool>() ? " here" : ""));
    return out;
  }

  std::string url_;
  TempDir here_{"central-http-here"};
  TempDir other_{"central-http-other"};
  std::unique_ptr<HttpApi> api_;
  std::unique_ptr<httplib::Client> client_;
};

TEST_F(CentralHttpTest, TheListsReadEveryGrindersRunsAndSayWhichAreHere) {
  grinder(here_, "g1", 2, 6);
  grinder(other_, "g2", 2, 7);  // 07:00 and 08:00; g1's at 06:00 and 07:00
  // Newest first; the two runs of 07:00 by their id in their file, g1's (2) before g2's (1).
  start(url_);
  testing::HttpAnswer list = get("/api/runs");
  ASSERT_EQ(list.status, 200) << list.body;
  EXPECT_EQ(machines_and_here(list.j), (std::vector<std::string>{"g2", "g1 here", "g2", "g1 here"}));
  testing::HttpAnswer trend = get("/api/trend?part=intake_flat&lobe=1");
  ASSERT_EQ(trend.status, 200) << trend.body;
  EXPECT_EQ(machines_and_here(trend.j), (std::vector<std::string>{"g1 here", "g2", "g1 here", "g2"}));
  testing::HttpAnswer one_machine = get("/api/runs?machine=g2&limit=1");
  ASSERT_EQ(one_machine.status, 200) << one_machine.body;
  EXPECT_EQ(machines_and_here(one_machine.j), (std::vector<std::string>{"g2"}));
  // The trend's picture is drawn from the central history's characteristics: the four runs',
  // another picture than the file's two.
  testing::HttpAnswer svg = get("/api/trend.svg?part=intake_flat&lobe=1&key=lift_error");
  ASSERT_EQ(svg.status, 200) << svg.body;

  // The same service reading its own file: g1's runs only, all here.
  api_.reset();
  start("");
  testing::HttpAnswer local = get("/api/runs");
  ASSERT_EQ(local.status, 200) << local.body;
  EXPECT_EQ(machines_and_here(local.j), (std::vector<std::string>{"g1 here", "g1 here"}));
  testing::HttpAnswer local_svg = get("/api/trend.svg?part=intake_flat&lobe=1&key=lift_error");
  ASSERT_EQ(local_svg.status, 200) << local_svg.body;
  EXPECT_TRUE(has(local_svg.body, "<svg"));
  EXPECT_NE(local_svg.body, svg.body);
}

// Before this grinder's first run its file does not exist: the plant's runs are listed, none
// here.
TEST_F(CentralHttpTest, AGrinderWithoutRunsListsThePlantsNoneHere) {
  grinder(other_, "g2", 1, 7);
  start(url_);
  testing::HttpAnswer list = get("/api/runs");
  ASSERT_EQ(list.status, 200) << list.body;
  EXPECT_EQ(machines_and_here(list.j), std::vector<std::string>{"g2"});
  EXPECT_FALSE(fs::exists(here_ / "gaugeloop.sqlite"));
}

// The central history out of reach: the lists answer 503 saying so, the run's own pages still
// read the file, and the lists answer again once the server is back.
TEST_F(CentralHttpTest, ACentralHistoryOutOfReachIsA503NamingItAndTheFileStillAnswers) {
  grinder(here_, "g1", 1, 6);
  const int port = testing::free_loopback_port();
  start("postgresql://postgres@127.0.0.1:" + std::to_string(port) + "/plant");
  testing::HttpAnswer list = get("/api/runs");
  EXPECT_EQ(list.status, 503) << list.body;
  EXPECT_TRUE(has(list.j.value("error", std::string()), "cannot reach the central history")) << list.body;
  testing::HttpAnswer run = get("/api/runs/1");
  EXPECT_EQ(run.status, 200) << run.body;
}

}  // namespace
}  // namespace gaugeloop
