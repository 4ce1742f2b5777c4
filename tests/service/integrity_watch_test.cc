// The run database checked whole beside the service: at once after a stop that was not clean,
// later after a clean one; a damaged file reported and runs refused; a check that never holds up
// a stop; the clean-shutdown marker.
#include "service/integrity_watch.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <mutex>
#include <string>

#include "storage/run_store.h"
#include "tests/support/damaged_database.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
// Far beyond what checking a small file takes on a loaded machine; reached only when it never ends.
constexpr std::chrono::seconds kWatchGenerous{60};

class IntegrityWatchTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> store = RunStore::open(db());
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (int i = 0; i < 3; ++i) {
      ASSERT_TRUE(
          store->insert_run(testing::sample_run("intake_flat", 1, "grinder-1", "2026-11-20T08:00:00Z", 5.0)).ok());
    }
  }
  fs::path db() const { return tmp_.path() / "gaugeloop.sqlite"; }
  testing::TempDir tmp_;
};

TEST_F(IntegrityWatchTest, AfterAStopThatWasNotCleanASoundFileIsCheckedAtOnce) {
  std::atomic<int> damaged{0};
  IntegrityWatch watch({db(), true, std::chrono::hours(24)}, [&](const std::string&) { ++damaged; }, {});
  ASSERT_TRUE(watch.wait_for_first_check(kWatchGenerous));
  const nlohmann::json h = watch.health();
  EXPECT_EQ(h["state"], "sound") << h.dump();
  EXPECT_EQ(h["checks"], 1);
  EXPECT_TRUE(h["last_check_utc"].is_string());
  EXPECT_TRUE(h["problem"].is_null());
  EXPECT_NE(watch.metrics().find("gaugeloop_database_integrity_sound 1\n"), std::string::npos) << watch.metrics();
  EXPECT_EQ(damaged.load(), 0);
}

TEST_F(IntegrityWatchTest, AfterACleanStopTheFirstCheckWaitsAndAStopDoesNotWaitForIt) {
  IntegrityWatch watch({db(), false, std::chrono::hours(24)}, {}, {});
  const nlohmann::json h = watch.health();
  EXPECT_EQ(h["state"], "waiting") << h.dump();
  EXPECT_EQ(h["checks"], 0);
  EXPECT_EQ(watch.metrics().find("gaugeloop_database_integrity_sound"), std::string::npos)
      << "no verdict before a check";
  watch.stop();
  EXPECT_EQ(watch.health()["checks"], 0) << "stopped while waiting: nothing was checked";
}

TEST_F(IntegrityWatchTest, ADamagedFileIsReportedWithWhatToDo) {
  ASSERT_TRUE(testing::damage_runs_table(db()));
  std::mutex m;
  std::string told;
  IntegrityWatch watch({db(), true, std::chrono::hours(24)},
                       [&](const std::string& message) {
                         std::lock_guard<std::mutex> lock(m);
                         told = message;
                       },
                       {});
  ASSERT_TRUE(watch.wait_for_first_check(kWatchGenerous));
  const nlohmann::json h = watch.health();
  EXPECT_EQ(h["state"], "damaged") << h.dump();
  EXPECT_NE(h["problem"].get<std::string>().find("is damaged"), std::string::npos) << h.dump();
  EXPECT_NE(watch.metrics().find("gaugeloop_database_integrity_sound 0\n"), std::string::npos);
  watch.stop();  // on_damaged ran before the verdict's notification, on the watch's thread
  std::lock_guard<std::mutex> lock(m);
  EXPECT_NE(told.find("is damaged"), std::string::npos) << told;
  EXPECT_NE(told.find("last sound backup"), std::string::npos) << "says what to do: " << told;
}

TEST_F(IntegrityWatchTest, TheCleanShutdownMarkerIsLeftByAStopAndTakenAtStart) {
  EXPECT_FALSE(take_clean_shutdown_marker(db())) << "none yet: a first start checks at once";
  leave_clean_shutdown_marker(db());
  EXPECT_TRUE(fs::exists(clean_shutdown_marker(db())));
  EXPECT_TRUE(take_clean_shutdown_marker(db()));
  EXPECT_FALSE(fs::exists(clean_shutdown_marker(db()))) << "taken: a crash from here on leaves none";
  EXPECT_FALSE(take_clean_shutdown_marker(db()));
}

}  // namespace
}  // namespace gaugeloop
