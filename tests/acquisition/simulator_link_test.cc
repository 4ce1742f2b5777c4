// The real link: libmodbus over a loopback socket against the in-process simulator, and an
// independent client (mbpoll) reading the same registers.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <regex>

#include "acquisition/modbus_gauge.h"
#include "acquisition/poller.h"
#include "core/lift_table.h"
#include "simulator/gauge_simulator.h"
#include "tests/support/intake_simulator.h"

namespace gaugeloop {
namespace {

std::unique_ptr<GaugeSimulator> start_sim(SimulatorSettings s = {}) {
  auto sim = testing::start_intake_simulator(s);
  EXPECT_TRUE(sim.ok()) << sim.error().message;
  return std::move(*sim);
}

TEST(SimulatorLink, BindsAnEphemeralPortAndAnswersASnapshot) {
  auto sim = start_sim();
  ASSERT_GT(sim->port(), 0);
  ModbusSettings ms;
  ms.port = sim->port();
  ModbusGauge gauge(ms);
  ASSERT_TRUE(gauge.connect().ok());
  Result<GaugeSnapshot> s = gauge.read_snapshot();
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_TRUE(gauge_status_ok(s->status));
  EXPECT_GE(s->angle_deg, 0.0);
  EXPECT_LT(s->angle_deg, 360.0);
  // Reading = lift (0..8.5 mm) + the gauge offset 0.25 mm + error and noise of a few um.
  EXPECT_GT(s->reading_mm, 0.2);
  EXPECT_LT(s->reading_mm, 8.8);
  EXPECT_GE(sim->requests_served(), 1);
}

TEST(SimulatorLink, LobeErrorPeaksAtTheConfiguredValue) {
  SimulatorSettings s;
  s.lobe_error_peak_um = 15.0;
  auto sim = start_sim(s);
  double peak = 0.0;
  for (int i = 0; i < 3600; ++i) peak = std::max(peak, std::abs(sim->lobe_error_um(i * 0.1)));
  EXPECT_NEAR(peak, 15.0, 1e-9);
}

TEST(SimulatorLink, RefusedConnectionIsUnreachable) {
  // A port bound but not listening refuses connections, and stays ours for the test.
  int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  socklen_t len = sizeof addr;
  ::getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len);
  ModbusSettings ms;
  ms.port = ntohs(addr.sin_port);
  ModbusGauge gauge(ms);
  Status st = gauge.connect();
  ::close(fd);
  ASSERT_FALSE(st.ok());
  EXPECT_EQ(st.error().code, ErrorCode::kGaugeUnreachable);
  EXPECT_NE(st.error().message.find("127.0.0.1:" + std::to_string(ms.port)), std::string::npos) << st.error().message;
}

TEST(SimulatorLink, SilentGaugeTimesOut) {
  auto sim = start_sim();
  sim->set_silent(true);
  ModbusSettings ms;
  ms.port = sim->port();
  ms.response_timeout = std::chrono::milliseconds(50);
  ModbusGauge gauge(ms);
  ASSERT_TRUE(gauge.connect().ok());
  Result<GaugeSnapshot> s = gauge.read_snapshot();
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kGaugeTimeout);
  EXPECT_FALSE(gauge.connected()) << "a timed-out link is closed so no late reply is mistaken for the next";
}

// Both sampling modes against the real simulator. The gauge reading is the lobe plus the
// 0.25 mm gauge offset: about 8.75 mm at the nose, 0.25 mm on the base circle (the 15 um
// form error and 0.3 um noise sit well inside the 0.05 mm tolerance).
void expect_lobe_read(const MeasuredRun& run) {
  ASSERT_EQ(run.revolutions.size(), 3u);
  for (const auto& rev : run.revolutions) {
    EXPECT_NEAR(rev.lift_mm[0], 8.75, 0.05);
    EXPECT_NEAR(rev.lift_mm[180], 0.25, 0.05);
  }
}

TEST(SimulatorLink, LatchedPollerMeasuresThreeRevolutionsOverLoopback) {
  SimulatorSettings s;
  s.time_scale = 4.0;  // 60 rpm simulated at 4x: the run takes about a second
  auto sim = start_sim(s);
  ModbusSettings ms;
  ms.port = sim->port();
  ModbusGauge gauge(ms);
  Poller poller(gauge, PollerSettings{});
  Result<MeasuredRun> run = poller.measure();
  ASSERT_TRUE(run.ok()) << run.error().message;
  expect_lobe_read(*run);
  // Latched entries are the readings at exact degree marks: revolutions agree to the noise
  // (0.3 um RMS per sample; 5 sigma of a difference of two samples is 2.1 um).
  for (int d = 0; d < 360; ++d) EXPECT_NEAR(run->revolutions[0].lift_mm[d], run->revolutions[1].lift_mm[d], 0.0021);
  // Block reads, paced to let about 31 entries gather: far fewer requests than entries.
  // Up to 4 revolutions of entries are read (waiting for degree 0 first), about 1440; at 2
  // requests per block that is under 100 requests, 300 leaves room for a slow machine.
  // Reading entry by entry would take over 2000.
  EXPECT_LT(run->polls, 300);
}

// mbpoll, an independent Modbus client from Debian, reads the simulator's input registers.
TEST(SimulatorLink, MbpollReadsTheRegisters) {
  auto sim = start_sim();
  const std::string cmd = "mbpoll -m tcp -a 1 -t 3 -r 1 -c 9 -1 -p " + std::to_string(sim->port()) + " 127.0.0.1 2>&1";
  FILE* pipe = ::popen(cmd.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string out;
  char buf[512];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) out += buf;
  const int rc = ::pclose(pipe);
  ASSERT_EQ(rc, 0) << "mbpoll failed (is it installed? scripts/install-deps.sh):\n" << out;
  // mbpoll numbers registers from 1: [3] is address 2, the status word: ready.
  EXPECT_NE(out.find("[3]: \t1"), std::string::npos) << out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex(R"(\[6\]:\s+(\d+))"))) << out;
  // Address 5, the revolution count: a fresh simulator has turned at most a few times.
  EXPECT_LT(std::stoi(m[1]), 100);
  EXPECT_GE(sim->requests_served(), 1);
}

}  // namespace
}  // namespace gaugeloop
