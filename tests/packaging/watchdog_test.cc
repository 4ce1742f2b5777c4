// The systemd watchdog (service/systemd_notify.h): fed while the liveness check answers alive,
// not fed while it says why not, once each way in the log; fed through sd_notify when systemd
// asks for it, and nothing at all without systemd.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <mutex>
#include <string>
#include <vector>

#include "service/systemd_notify.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using std::chrono::milliseconds;

constexpr std::chrono::seconds kGuard{120};  // a hang fails the test instead of blocking it

// What the watchdog sent, and a liveness the test sets.
struct FakeSystemd {
  std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::string> sent;
  std::string why_not;  // empty: alive
  int feeds = 0;
  int dead_checks = 0;
  int feeds_at_first_dead_check = -1;

  Watchdog::Send send() {
    return [this](const std::string& m) {
      std::lock_guard<std::mutex> lock(mutex);
      sent.push_back(m);
      if (m == "WATCHDOG=1") ++feeds;
      changed.notify_all();
    };
  }
  LivenessCheck check() {
    return [this] {
      std::lock_guard<std::mutex> lock(mutex);
      if (!why_not.empty() && dead_checks++ == 0) feeds_at_first_dead_check = feeds;
      changed.notify_all();
      return why_not;
    };
  }
  void set_why_not(std::string why) {
    std::lock_guard<std::mutex> lock(mutex);
    why_not = std::move(why);
  }
  template <typename Pred>
  bool wait_until(Pred done) {
    std::unique_lock<std::mutex> lock(mutex);
    return changed.wait_for(lock, kGuard, [&] { return done(); });
  }
};

TEST(ServiceWatchdog, FeedsWhileAliveAndSaysOnceWhyItStopsAndWhenItFeedsAgain) {
  FakeSystemd systemd;
  Watchdog watchdog(milliseconds(1), systemd.check(), systemd.send());
  EXPECT_TRUE(watchdog.tick());
  EXPECT_EQ(systemd.sent, std::vector<std::string>{"WATCHDOG=1"});

  systemd.set_why_not("the PLC trigger has not begun a poll for more than 1000 ms");
  EXPECT_FALSE(watchdog.tick());
  EXPECT_FALSE(watchdog.tick());
  EXPECT_FALSE(watchdog.tick());
  ASSERT_EQ(systemd.sent.size(), 2u) << "no feed while not alive, and the reason said once";
  EXPECT_EQ(systemd.sent[1], "STATUS=watchdog not fed: the PLC trigger has not begun a poll for more than 1000 ms");

  systemd.set_why_not("");
  EXPECT_TRUE(watchdog.tick());
  EXPECT_TRUE(watchdog.tick());
  ASSERT_EQ(systemd.sent.size(), 5u);
  EXPECT_EQ(systemd.sent[2], "STATUS=waiting for requests (watchdog fed again)");
  EXPECT_EQ(systemd.sent[3], "WATCHDOG=1");
  EXPECT_EQ(systemd.sent[4], "WATCHDOG=1");
}

// The thread: feeds, then, once the check answers dead, feeds no more however often it asks.
TEST(ServiceWatchdog, TheThreadStopsFeedingWhileTheCheckAnswersDead) {
  FakeSystemd systemd;
  Watchdog watchdog(milliseconds(1), systemd.check(), systemd.send());
  watchdog.start();
  ASSERT_TRUE(systemd.wait_until([&] { return systemd.feeds >= 2; }));
  systemd.set_why_not("the HTTP server no longer accepts connections");
  // Each tick asks, then feeds or not, on the one thread: after the first dead answer the
  // count of feeds stays what it was, three rounds on.
  ASSERT_TRUE(systemd.wait_until([&] { return systemd.dead_checks >= 3; }));
  watchdog.stop();
  EXPECT_EQ(systemd.feeds, systemd.feeds_at_first_dead_check);
  EXPECT_GE(systemd.feeds, 2);
}

TEST(ServiceWatchdog, StopReturnsAtOnceWithoutWaitingForTheNextRound) {
  FakeSystemd systemd;
  Watchdog watchdog(std::chrono::hours(1), systemd.check(), systemd.send());
  watchdog.start();
  watchdog.stop();  // a wait of an hour would hold the test until ctest's timeout
  watchdog.stop();
  EXPECT_TRUE(systemd.sent.empty());
}

// The tests below set the process's environment as systemd does for the service: only while
// no other thread of the test runs (getenv and setenv are not safe against each other).
class ServiceNotifyEnv : public ::testing::Test {
 protected:
  void TearDown() override {
    ::unsetenv("NOTIFY_SOCKET");
    ::unsetenv("WATCHDOG_USEC");
    ::unsetenv("WATCHDOG_PID");
  }
};

TEST_F(ServiceNotifyEnv, WithoutSystemdEverythingIsANoOp) {
  ::unsetenv("NOTIFY_SOCKET");
  ::unsetenv("WATCHDOG_USEC");
  EXPECT_FALSE(notify_systemd("READY=1"));
  notify_started(nullptr, nullptr);
  notify_reloading();
  notify_stopping();
  EXPECT_EQ(Watchdog::start_for_systemd([] { return std::string(); }), nullptr);
}

TEST_F(ServiceNotifyEnv, AWatchdogForAnotherProcessIsNotOurs) {
  ::setenv("WATCHDOG_USEC", "30000000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid() + 1).c_str(), 1);
  EXPECT_EQ(Watchdog::start_for_systemd([] { return std::string(); }), nullptr);
}

// A real datagram socket, as systemd's: the watchdog it asks for (WATCHDOG_USEC, WATCHDOG_PID
// this process) is fed through sd_notify every half interval.
TEST_F(ServiceNotifyEnv, TheWatchdogSystemdAsksForIsFedThroughItsSocket) {
  testing::TempDir dir("notify");
  const std::string path = (dir.path() / "s").string();
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  ASSERT_GE(fd, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path.c_str());
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  const timeval guard{static_cast<time_t>(kGuard.count()), 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &guard, sizeof guard);
  ::setenv("NOTIFY_SOCKET", path.c_str(), 1);
  ::setenv("WATCHDOG_USEC", "2000", 1);
  ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);

  EXPECT_TRUE(notify_systemd("STATUS=testing"));
  std::unique_ptr<Watchdog> watchdog = Watchdog::start_for_systemd([] { return std::string(); });
  ASSERT_NE(watchdog, nullptr);
  std::vector<std::string> got;
  char buf[256];
  for (int i = 0; i < 3; ++i) {
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    got.emplace_back(buf, n > 0 ? static_cast<size_t>(n) : 0);
  }
  watchdog.reset();  // before TearDown changes the environment its thread reads
  ::close(fd);
  EXPECT_EQ(got, (std::vector<std::string>{"STATUS=testing", "WATCHDOG=1", "WATCHDOG=1"}));
}

TEST(ServiceWatchdog, ThePlcTriggerCountsAsAliveForThreePollsOrItsReplyTimeoutsAndASecondAtLeast) {
  PlcSettings plc;
  plc.poll_interval = milliseconds(100);
  plc.link.link.response_timeout = milliseconds(200);
  EXPECT_EQ(plc_alive_within(plc), milliseconds(1000));
  plc.poll_interval = milliseconds(20);
  plc.link.link.response_timeout = milliseconds(2000);
  EXPECT_EQ(plc_alive_within(plc), milliseconds(6020));
  plc.poll_interval = milliseconds(5000);
  EXPECT_EQ(plc_alive_within(plc), milliseconds(15000));
}

}  // namespace
}  // namespace gaugeloop
