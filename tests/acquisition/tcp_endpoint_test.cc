// Host names and IPv6 for the gauge and the PLC: parsing HOST:PORT, resolving at check time,
// and the links reaching the simulators by name and over ::1.
#include "acquisition/tcp_endpoint.h"

#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include "acquisition/modbus_gauge.h"
#include "acquisition/plc_link.h"
#include "simulator/gauge_simulator.h"
#include "simulator/plc_simulator.h"
#include "tests/support/intake_simulator.h"

namespace gaugeloop {
namespace {

// Whether this machine can bind the IPv6 loopback address.
bool has_ipv6_loopback() {
  const int fd = ::socket(AF_INET6, SOCK_STREAM, 0);
  if (fd < 0) return false;
  sockaddr_in6 addr{};
  addr.sin6_family = AF_INET6;
  addr.sin6_addr = in6addr_loopback;
  const bool ok = ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  ::close(fd);
  return ok;
}

// Starts the gauge simulator on `host`, port 0, and reads one snapshot through a gauge
// configured with `gauge_host`.
void expect_snapshot_through(const std::string& host, const std::string& gauge_host) {
  SimulatorSettings ss;
  ss.host = host;
  auto sim = testing::start_intake_simulator(ss);
  ASSERT_TRUE(sim.ok()) << sim.error().message;
  ModbusSettings ms;
  ms.host = gauge_host;
  ms.port = (*sim)->port();
  ModbusGauge gauge(ms);
  Status c = gauge.connect();
  ASSERT_TRUE(c.ok()) << c.error().message;
  Result<GaugeSnapshot> s = gauge.read_snapshot();
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_TRUE(gauge_status_ok(s->status));
  EXPECT_GT(s->reading_mm, 0.2);
}

TEST(TcpEndpoint, ParsesNamesAddressesAndBracketedIpv6) {
  auto named = parse_tcp_endpoint("localhost:1502");
  ASSERT_TRUE(named.ok()) << named.error().message;
  EXPECT_EQ(named->host, "localhost");
  EXPECT_EQ(named->port, 1502);
  auto v6 = parse_tcp_endpoint("[::1]:1502");
  ASSERT_TRUE(v6.ok()) << v6.error().message;
  EXPECT_EQ(v6->host, "::1");
  EXPECT_EQ(v6->port, 1502);
  auto v4 = parse_tcp_endpoint("192.168.0.20:502");
  ASSERT_TRUE(v4.ok());
  EXPECT_EQ(v4->host, "192.168.0.20");
  for (const char* bad : {"localhost", ":502", "::1:1502", "[::1]", "[]:502", "host:0", "host:70000", "host:5x"}) {
    auto b = parse_tcp_endpoint(bad);
    ASSERT_FALSE(b.ok()) << bad;
    EXPECT_NE(b.error().message.find("expected HOST:PORT"), std::string::npos) << b.error().message;
  }
  EXPECT_EQ(format_tcp_endpoint("::1", 1502), "[::1]:1502");
  EXPECT_EQ(format_tcp_endpoint("localhost", 1502), "localhost:1502");
}

// ".invalid" never resolves (RFC 2606).
TEST(TcpEndpoint, AnUnknownNameIsRefusedNamingIt) {
  EXPECT_TRUE(resolve_tcp_host("localhost", 502, "gauge").ok());
  EXPECT_TRUE(resolve_tcp_host("127.0.0.1", 502, "gauge").ok());
  Status s = resolve_tcp_host("gauge-amp.invalid", 502, "gauge");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(s.error().message.find("cannot resolve host 'gauge-amp.invalid': "), std::string::npos)
      << s.error().message;
  EXPECT_NE(s.error().message.find("check the gauge's address"), std::string::npos) << s.error().message;
}

TEST(TcpEndpoint, TheGaugeIsReachedByName) { expect_snapshot_through("127.0.0.1", "localhost"); }

TEST(TcpEndpoint, TheGaugeIsReachedOverIpv6) {
  if (!has_ipv6_loopback()) GTEST_SKIP() << "this machine has no ::1";
  expect_snapshot_through("::1", "::1");
}

// Before: libmodbus called a name it could not resolve "Connection refused".
TEST(TcpEndpoint, AGaugeWithAnUnknownNameSaysSo) {
  ModbusSettings ms;
  ms.host = "gauge-amp.invalid";
  ms.port = 502;
  ModbusGauge gauge(ms);
  Status c = gauge.connect();
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(c.error().message.find("cannot resolve host 'gauge-amp.invalid'"), std::string::npos) << c.error().message;
  EXPECT_FALSE(gauge.connected());
}

TEST(TcpEndpoint, ThePlcIsReachedByNameAndOverIpv6) {
  for (const char* host : {"127.0.0.1", "::1"}) {
    if (std::string(host) == "::1" && !has_ipv6_loopback()) continue;
    PlcSimulatorSettings ps;
    ps.host = host;
    auto sim = PlcSimulator::start(ps);
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    PlcLinkSettings ls;
    ls.link.host = std::string(host) == "::1" ? "::1" : "localhost";
    ls.link.port = (*sim)->port();
    ls.link.response_timeout = std::chrono::milliseconds(2000);
    ModbusPlcLink link(ls);
    Status c = link.connect();
    ASSERT_TRUE(c.ok()) << host << ": " << c.error().message;
    Result<PlcRequestWords> idle = link.read_request();
    ASSERT_TRUE(idle.ok()) << host << ": " << idle.error().message;
    EXPECT_FALSE(idle->measure());
  }
}

}  // namespace
}  // namespace gaugeloop
