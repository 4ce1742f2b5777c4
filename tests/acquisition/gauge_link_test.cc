// GaugeLink: every transition of the state machine drawn in acquisition/gauge_link.h.
#include "acquisition/gauge_link.h"

#include <gtest/gtest.h>

#include <utility>
#include <vector>

#include "scripted_gauge.h"

namespace gaugeloop {
namespace {

using testing::ScriptedGauge;
using Transition = std::pair<LinkState, LinkState>;
constexpr auto kDisconnected = LinkState::kDisconnected;
constexpr auto kConnected = LinkState::kConnected;
constexpr auto kBackingOff = LinkState::kBackingOff;
constexpr auto kFailed = LinkState::kFailed;

class GaugeLinkTest : public ::testing::Test {
 protected:
  GaugeLinkTest() : link_(gauge_, LinkPolicy{3, std::chrono::milliseconds(0), std::chrono::milliseconds(0)}) {
    link_.set_on_transition([this](LinkState from, LinkState to) { seen_.emplace_back(from, to); });
  }
  Error timeout() const { return make_error(ErrorCode::kGaugeTimeout, "no reply"); }

  ScriptedGauge gauge_;
  GaugeLink link_;
  std::vector<Transition> seen_;
};

TEST_F(GaugeLinkTest, StartsDisconnectedAndConnectsOnEnsure) {
  EXPECT_EQ(link_.state(), kDisconnected);
  ASSERT_TRUE(link_.ensure("before the run").ok());
  EXPECT_EQ(seen_, (std::vector<Transition>{{kDisconnected, kConnected}}));
  EXPECT_EQ(link_.reconnects(), 0);
  EXPECT_TRUE(gauge_.connected());
}

TEST_F(GaugeLinkTest, FailedRequestBacksOffThenReconnects) {
  ASSERT_TRUE(link_.ensure("").ok());
  ASSERT_TRUE(link_.failed(timeout(), "").ok());
  EXPECT_EQ(link_.state(), kBackingOff);
  EXPECT_FALSE(gauge_.connected()) << "the link is closed so a late reply cannot be read as the next";
  ASSERT_TRUE(link_.ensure("").ok());
  EXPECT_EQ(seen_, (std::vector<Transition>{
                       {kDisconnected, kConnected}, {kConnected, kBackingOff}, {kBackingOff, kConnected}}));
  EXPECT_EQ(link_.reconnects(), 1);
  EXPECT_EQ(gauge_.connects, 2);
}

TEST_F(GaugeLinkTest, ConnectFailuresBackOffUntilTheAttemptsAreSpent) {
  gauge_.fail_connects = 10;
  Status s = link_.ensure("before the run");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_NE(s.error().message.find("(3 attempts)"), std::string::npos) << s.error().message;
  EXPECT_EQ(seen_, (std::vector<Transition>{{kDisconnected, kBackingOff}, {kBackingOff, kFailed}}));
  EXPECT_EQ(gauge_.connects, 3);
}

TEST_F(GaugeLinkTest, ConnectThatSucceedsWithinTheAttemptsIsNotAReconnect) {
  gauge_.fail_connects = 2;
  ASSERT_TRUE(link_.ensure("").ok());
  EXPECT_EQ(link_.state(), kConnected);
  EXPECT_EQ(link_.reconnects(), 0) << "never connected before: a first connection, late";
}

TEST_F(GaugeLinkTest, RequestFailuresInARowFailTheLinkNamingWhere) {
  ASSERT_TRUE(link_.ensure("").ok());
  ASSERT_TRUE(link_.failed(timeout(), "").ok());
  ASSERT_TRUE(link_.ensure("").ok());
  ASSERT_TRUE(link_.failed(timeout(), "").ok());
  ASSERT_TRUE(link_.ensure("").ok());
  Status s = link_.failed(timeout(), "during revolution 2 of 3");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(link_.state(), kFailed);
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_NE(s.error().message.find("stopped answering during revolution 2 of 3: no reply (gave up after 3 attempts)"),
            std::string::npos)
      << s.error().message;
}

TEST_F(GaugeLinkTest, AGoodRequestResetsTheCount) {
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(link_.ensure("").ok());
    ASSERT_TRUE(link_.failed(timeout(), "").ok());
    ASSERT_TRUE(link_.ensure("").ok());
    link_.succeeded();
  }
  EXPECT_EQ(link_.state(), kConnected);
  EXPECT_EQ(link_.reconnects(), 10);
}

// Once the link has been up, an outage is waited out for the patience (what the spare
// revolutions absorb) however many attempts fail in it; an hour is never reached here.
TEST_F(GaugeLinkTest, AnOutageShorterThanThePatienceOutlastsTheAttempts) {
  link_.set_patience(std::chrono::hours(1));
  ASSERT_TRUE(link_.ensure("").ok());
  gauge_.fail_connects = 10;
  ASSERT_TRUE(link_.failed(timeout(), "").ok());
  ASSERT_EQ(link_.state(), kBackingOff);
  Status back = link_.ensure("");  // 10 refused connects, then the gauge is back
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(link_.state(), kConnected);
  EXPECT_EQ(gauge_.connects, 12);
  EXPECT_EQ(link_.reconnects(), 1);
}

// Before the link was ever up there is no run to save: the attempts alone decide.
TEST_F(GaugeLinkTest, ThePatienceDoesNotDelayAGaugeNeverReached) {
  link_.set_patience(std::chrono::hours(1));
  gauge_.fail_connects = 10;
  ASSERT_FALSE(link_.ensure("before the run").ok());
  EXPECT_EQ(gauge_.connects, 3);
}

TEST_F(GaugeLinkTest, FailedIsTerminal) {
  gauge_.fail_connects = 10;
  ASSERT_FALSE(link_.ensure("").ok());
  const int connects = gauge_.connects;
  gauge_.fail_connects = 0;
  Status again = link_.ensure("");
  ASSERT_FALSE(again.ok());
  EXPECT_EQ(gauge_.connects, connects) << "no more connects once failed";
  EXPECT_FALSE(link_.failed(timeout(), "").ok());
  EXPECT_EQ(link_.state(), kFailed);
}

TEST_F(GaugeLinkTest, AClientThatClosedItselfIsReopened) {
  ASSERT_TRUE(link_.ensure("").ok());
  gauge_.disconnect();  // as ModbusGauge does after a timeout
  ASSERT_TRUE(link_.ensure("").ok());
  EXPECT_EQ(seen_, (std::vector<Transition>{
                       {kDisconnected, kConnected}, {kConnected, kBackingOff}, {kBackingOff, kConnected}}));
}

// The backoff, timed on a manual clock: each sleep is recorded and returns at once.
TEST(GaugeLinkBackoff, DoublesFromTheInitialDelayUpToTheMaximumAndResetsOnAGoodRequest) {
  ScriptedGauge gauge;
  ManualClock clock;
  GaugeLink link(gauge, LinkPolicy{10, std::chrono::milliseconds(20), std::chrono::milliseconds(100)}, clock);
  gauge.fail_connects = 4;
  ASSERT_TRUE(link.ensure("").ok());
  using std::chrono::milliseconds;
  EXPECT_EQ(clock.sleeps(),
            (std::vector<Clock::duration>{milliseconds(20), milliseconds(40), milliseconds(80), milliseconds(100)}));
  EXPECT_EQ(clock.now(), Clock::time_point{} + milliseconds(240));

  link.succeeded();
  ASSERT_TRUE(link.failed(make_error(ErrorCode::kGaugeTimeout, "no reply"), "").ok());
  ASSERT_TRUE(link.ensure("").ok());
  EXPECT_EQ(clock.sleeps().back(), milliseconds(20)) << "a good request starts the backoff over";
}

// Once the link has been up, an outage ends the run only when both the attempts and the
// patience are spent; the patience is counted on the clock from the outage's first failure.
TEST(GaugeLinkBackoff, AnOutageIsGivenUpOnOnceThePatienceHasPassed) {
  ScriptedGauge gauge;
  ManualClock clock;
  GaugeLink link(gauge, LinkPolicy{3, std::chrono::milliseconds(100), std::chrono::milliseconds(400)}, clock);
  link.set_patience(std::chrono::milliseconds(1000));
  ASSERT_TRUE(link.ensure("").ok());
  const Clock::time_point outage_start = clock.now();
  gauge.fail_connects = 100;
  ASSERT_TRUE(link.failed(make_error(ErrorCode::kGaugeTimeout, "no reply"), "").ok());
  Status s = link.ensure("during revolution 2 of 3");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(link.state(), LinkState::kFailed);
  // The failed request, then reconnects after 100, 200, 400 and 400 ms, all refused: the
  // third failure spent the attempts, the fifth, at 1100 ms, is the first past the patience.
  EXPECT_EQ(clock.now() - outage_start, std::chrono::milliseconds(1100));
  EXPECT_EQ(clock.sleeps().size(), 4u);
  EXPECT_EQ(gauge.connects, 1 + 4);
  EXPECT_NE(s.error().message.find("gave up after 5 attempts"), std::string::npos) << s.error().message;
}

TEST(LinkState, HasNames) {
  EXPECT_EQ(link_state_name(LinkState::kBackingOff), "backing off");
  EXPECT_EQ(link_state_name(LinkState::kFailed), "failed");
}

}  // namespace
}  // namespace gaugeloop
