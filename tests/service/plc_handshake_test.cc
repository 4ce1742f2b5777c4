// The PLC handshake's transitions against a scripted PLC and a scripted cycle: no sockets, no
// threads, a clock the test moves.
#include "service/plc_handshake.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <utility>

namespace gaugeloop {
namespace {

using std::chrono::milliseconds;

// The PLC's registers in memory; faults on demand.
class ScriptedPlc final : public PlcRegisters {
 public:
  Status connect() override {
    ++connects;
    if (refuse_connect) return make_error(ErrorCode::kIo, "connection refused (scripted)");
    up = true;
    return {};
  }
  void disconnect() override { up = false; }
  bool connected() const override { return up; }
  Result<PlcRequestWords> read_request() override {
    if (fail_reads > 0) {
      --fail_reads;
      up = false;
      return make_error(ErrorCode::kIo, "connection reset (scripted)");
    }
    return plc;
  }
  Status write_service_words(const PlcServiceWords& words) override {
    if (fail_writes > 0) {
      --fail_writes;
      up = false;
      return make_error(ErrorCode::kIo, "broken pipe (scripted)");
    }
    written = words;
    ++writes;
    return {};
  }
  std::string address() const override { return "scripted"; }

  void request(std::uint16_t part, std::uint16_t lobe) {
    plc.part_number = part;
    plc.lobe = lobe;
    plc.request = plc_registers::kMeasureBit;
  }
  void clear() { plc.request = 0; }

  PlcRequestWords plc;
  PlcServiceWords written;
  int writes = 0;
  int connects = 0;
  int fail_reads = 0;
  int fail_writes = 0;
  bool refuse_connect = false;
  bool up = false;
};

// A cycle that ends when the test says so, or is refused at once.
class ScriptedCycle final : public PlcCycleRunner {
 public:
  std::optional<PlcCycleOutcome> start(const PlcRequestWords& request) override {
    const std::uint16_t part_number = request.part_number;
    const std::uint16_t lobe = request.lobe;
    starts.push_back({part_number, lobe});
    if (refuse) return *refuse;
    running = true;
    return std::nullopt;
  }
  std::optional<PlcCycleOutcome> poll() override {
    if (!running || !finish) return std::nullopt;
    running = false;
    std::optional<PlcCycleOutcome> o = finish;
    finish.reset();
    return o;
  }

  std::vector<std::pair<int, int>> starts;
  std::optional<PlcCycleOutcome> refuse;  // returned by start() when set
  std::optional<PlcCycleOutcome> finish;  // returned by the next poll() when set
  bool running = false;
};

PlcCycleOutcome pushed(std::uint32_t run_id, std::uint16_t version) {
  return {PlcResultCode::kTablePushed, run_id, version, "table pushed"};
}

bool has(const std::vector<PlcEvent>& events, PlcEvent e) {
  return std::find(events.begin(), events.end(), e) != events.end();
}

// The handshake bits the service wrote, in a word: "ack busy done fault" or a part of it.
std::string bits(const PlcServiceWords& w) {
  std::string out;
  for (const auto& [on, name] : {std::pair{w.ack, "ack"}, {w.busy, "busy"}, {w.done, "done"}, {w.fault, "fault"}}) {
    if (on) out += out.empty() ? name : std::string(" ") + name;
  }
  return out;
}

class PlcHandshakeTest : public ::testing::Test {
 protected:
  PlcHandshakeTest() : hs_(plc_, cycle_, settings(), clock_) {}

  static PlcHandshakeSettings settings() {
    PlcHandshakeSettings s;
    s.reconnect_min = milliseconds(100);
    s.reconnect_max = milliseconds(1000);
    return s;
  }

  // Connected, idle, the request seen low: ready for a rising edge.
  void ready() {
    const std::vector<PlcEvent> e = hs_.step();
    ASSERT_TRUE(has(e, PlcEvent::kConnected));
    ASSERT_EQ(hs_.state(), PlcState::kIdle);
  }

  // From ready to done with `outcome`.
  void run_cycle(const PlcCycleOutcome& outcome) {
    plc_.request(7, 1);
    ASSERT_TRUE(has(hs_.step(), PlcEvent::kRequestAccepted));
    cycle_.finish = outcome;
    ASSERT_TRUE(has(hs_.step(), PlcEvent::kOutcomeWritten));
    ASSERT_EQ(hs_.state(), PlcState::kDone);
  }

  ScriptedPlc plc_;
  ScriptedCycle cycle_;
  ManualClock clock_;
  PlcHandshake hs_;
};

TEST_F(PlcHandshakeTest, RequestAckBusyDoneClearAndReadyAgain) {
  ready();
  EXPECT_FALSE(plc_.written.ack);
  EXPECT_FALSE(plc_.written.busy);

  plc_.request(7, 1);
  std::vector<PlcEvent> e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kRequestAccepted));
  EXPECT_EQ(hs_.state(), PlcState::kBusy);
  ASSERT_EQ(cycle_.starts.size(), 1u);
  EXPECT_EQ(cycle_.starts[0], std::make_pair(7, 1));
  EXPECT_EQ(bits(plc_.written), "ack busy");

  e = hs_.step();  // still measuring
  EXPECT_TRUE(e.empty());
  EXPECT_EQ(hs_.state(), PlcState::kBusy);
  EXPECT_TRUE(plc_.written.busy);

  cycle_.finish = pushed(12, 3);
  e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kCycleEnded));
  EXPECT_TRUE(has(e, PlcEvent::kOutcomeWritten));
  EXPECT_EQ(hs_.state(), PlcState::kDone);
  EXPECT_EQ(bits(plc_.written), "ack done");
  EXPECT_EQ(plc_.written.result_code, PlcResultCode::kTablePushed);
  EXPECT_EQ(plc_.written.run_id, 12u);
  EXPECT_EQ(plc_.written.table_version, 3);

  plc_.clear();
  e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kCleared));
  EXPECT_EQ(hs_.state(), PlcState::kIdle);
  EXPECT_EQ(bits(plc_.written), "");
  EXPECT_EQ(plc_.written.run_id, 12u) << "the last result stays readable until the next request";

  plc_.request(7, 1);
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kRequestAccepted)) << "ready for the next part";
  EXPECT_EQ(plc_.written.run_id, 0u) << "a new request clears the old result";
  EXPECT_EQ(cycle_.starts.size(), 2u);
}

TEST_F(PlcHandshakeTest, UnknownPartIsAFaultWithItsCodeAndNoRun) {
  ready();
  cycle_.refuse = PlcCycleOutcome{PlcResultCode::kUnknownPart, 0, 0, "part number 99 is not configured"};
  plc_.request(99, 1);
  const std::vector<PlcEvent> e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kRequestRefused));
  EXPECT_TRUE(has(e, PlcEvent::kOutcomeWritten));
  EXPECT_FALSE(has(e, PlcEvent::kRequestAccepted));
  EXPECT_EQ(hs_.state(), PlcState::kDone);
  EXPECT_FALSE(cycle_.running);
  EXPECT_EQ(bits(plc_.written), "ack fault");
  EXPECT_EQ(plc_.written.result_code, PlcResultCode::kUnknownPart);
  EXPECT_EQ(plc_.written.run_id, 0u);

  plc_.clear();
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kCleared));
  EXPECT_EQ(bits(plc_.written), "");
}

TEST_F(PlcHandshakeTest, ARunThatFailsIsAFaultWithTheStepsCode) {
  ready();
  run_cycle({PlcResultCode::kGaugeFault, 0, 0, "gauge timeout"});
  EXPECT_EQ(bits(plc_.written), "ack fault");
  EXPECT_EQ(plc_.written.result_code, PlcResultCode::kGaugeFault);
}

TEST_F(PlcHandshakeTest, AHeldTableIsDoneWithItsCodeAndTheRun) {
  ready();
  run_cycle({PlcResultCode::kTableHeld, 41, 0, "approval required"});
  EXPECT_EQ(bits(plc_.written), "ack done");
  EXPECT_EQ(plc_.written.result_code, PlcResultCode::kTableHeld);
  EXPECT_EQ(plc_.written.run_id, 41u);
  EXPECT_EQ(plc_.written.table_version, 0);
}

TEST_F(PlcHandshakeTest, RequestHeldHighAfterDoneIsNotANewRequest) {
  ready();
  run_cycle(pushed(12, 3));
  for (int i = 0; i < 5; ++i) {
    EXPECT_TRUE(hs_.step().empty());
    EXPECT_EQ(hs_.state(), PlcState::kDone);
    EXPECT_TRUE(plc_.written.done);
  }
  EXPECT_EQ(cycle_.starts.size(), 1u) << "one request, one run";
  plc_.clear();
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kCleared));
  plc_.request(7, 1);
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kRequestAccepted));
  EXPECT_EQ(cycle_.starts.size(), 2u);
}

TEST_F(PlcHandshakeTest, RequestAlreadyHighAtStartIsTakenOnlyAfterTheRequestIsCleared) {
  plc_.request(7, 1);
  std::vector<PlcEvent> e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kConnected));
  EXPECT_FALSE(has(e, PlcEvent::kRequestAccepted));
  EXPECT_TRUE(hs_.step().empty());
  EXPECT_EQ(hs_.state(), PlcState::kIdle);
  EXPECT_FALSE(plc_.written.ack);
  EXPECT_TRUE(cycle_.starts.empty());
  plc_.clear();
  EXPECT_TRUE(hs_.step().empty());
  plc_.request(7, 1);
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kRequestAccepted));
}

TEST_F(PlcHandshakeTest, PlcClearingEarlyLetsTheRunFinishAndDoneStandsOnePoll) {
  ready();
  plc_.request(7, 1);
  ASSERT_TRUE(has(hs_.step(), PlcEvent::kRequestAccepted));
  plc_.clear();
  std::vector<PlcEvent> e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kClearedEarly));
  EXPECT_EQ(hs_.state(), PlcState::kBusy) << "the run is not aborted";
  EXPECT_TRUE(plc_.written.busy);
  EXPECT_TRUE(hs_.step().empty()) << "told once";

  cycle_.finish = pushed(12, 3);
  e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kOutcomeWritten));
  EXPECT_FALSE(has(e, PlcEvent::kCleared)) << "done is written before it is cleared";
  EXPECT_TRUE(plc_.written.done);
  EXPECT_EQ(plc_.written.run_id, 12u);
  e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kCleared));
  EXPECT_EQ(hs_.state(), PlcState::kIdle);
  EXPECT_FALSE(plc_.written.done);
  EXPECT_FALSE(plc_.written.ack);
}

TEST_F(PlcHandshakeTest, LinkLostMidCycleDeliversTheOutcomeAfterReconnecting) {
  ready();
  plc_.request(7, 1);
  ASSERT_TRUE(has(hs_.step(), PlcEvent::kRequestAccepted));
  plc_.fail_reads = 1;
  std::vector<PlcEvent> e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kLinkLost));
  EXPECT_FALSE(hs_.connected());
  EXPECT_EQ(hs_.state(), PlcState::kBusy);

  cycle_.finish = pushed(12, 3);
  const int writes_before = plc_.writes;
  e = hs_.step();  // within the backoff: the cycle ends, nobody to tell yet
  EXPECT_TRUE(has(e, PlcEvent::kCycleEnded));
  EXPECT_FALSE(has(e, PlcEvent::kConnected));
  EXPECT_EQ(hs_.state(), PlcState::kDone);
  EXPECT_FALSE(hs_.outcome_delivered());
  EXPECT_EQ(plc_.writes, writes_before);

  clock_.advance(milliseconds(100));
  e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kConnected));
  EXPECT_TRUE(has(e, PlcEvent::kOutcomeWritten));
  EXPECT_TRUE(hs_.outcome_delivered());
  EXPECT_TRUE(plc_.written.done);
  EXPECT_EQ(plc_.written.run_id, 12u);
  EXPECT_EQ(cycle_.starts.size(), 1u) << "the request still high is the same request";

  plc_.clear();
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kCleared));
}

TEST_F(PlcHandshakeTest, AFailedWriteIsALostLinkAndTheStateIsKept) {
  ready();
  plc_.request(7, 1);
  plc_.fail_writes = 1;
  const std::vector<PlcEvent> e = hs_.step();
  EXPECT_TRUE(has(e, PlcEvent::kRequestAccepted));
  EXPECT_TRUE(has(e, PlcEvent::kLinkLost));
  EXPECT_EQ(hs_.state(), PlcState::kBusy);
  EXPECT_FALSE(hs_.connected());
  clock_.advance(milliseconds(100));
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kConnected));
  EXPECT_TRUE(plc_.written.busy) << "written once the link is back";
}

TEST_F(PlcHandshakeTest, ReconnectBacksOffDoublingUpToTheMaximum) {
  plc_.refuse_connect = true;
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kConnectFailed));
  EXPECT_EQ(plc_.connects, 1);
  // Next attempts at +100, +200, +400, +800, then every 1000 ms.
  const int waits_ms[] = {100, 200, 400, 800, 1000, 1000};
  for (int wait : waits_ms) {
    clock_.advance(milliseconds(wait - 1));
    const int before = plc_.connects;
    EXPECT_TRUE(hs_.step().empty()) << "no attempt before " << wait << " ms";
    EXPECT_EQ(plc_.connects, before);
    clock_.advance(milliseconds(1));
    EXPECT_TRUE(has(hs_.step(), PlcEvent::kConnectFailed));
    EXPECT_EQ(plc_.connects, before + 1);
  }
  EXPECT_FALSE(hs_.last_link_error().empty());
  plc_.refuse_connect = false;
  clock_.advance(milliseconds(1000));
  EXPECT_TRUE(has(hs_.step(), PlcEvent::kConnected));
}

TEST_F(PlcHandshakeTest, HeartbeatCountsEveryPollAndWraps) {
  ready();
  const std::uint16_t first = plc_.written.heartbeat;
  for (int i = 1; i <= 70000; ++i) (void)hs_.step();
  EXPECT_EQ(plc_.written.heartbeat, static_cast<std::uint16_t>(first + 70000));
}

TEST(PlcServiceWords, RunIdIsHighWordFirst) {
  PlcServiceWords w;
  w.run_id = 0x00012345;
  w.done = true;
  w.result_code = PlcResultCode::kTableHeld;
  const auto regs = encode_service_words(w);
  EXPECT_EQ(regs[plc_registers::kRunIdHigh - plc_registers::kServiceFirst], 0x0001);
  EXPECT_EQ(regs[plc_registers::kRunIdLow - plc_registers::kServiceFirst], 0x2345);
  EXPECT_EQ(regs[plc_registers::kResultCode - plc_registers::kServiceFirst], 1);
  EXPECT_EQ(decode_service_words(regs), w);
}

}  // namespace
}  // namespace gaugeloop
