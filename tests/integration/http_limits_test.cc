// What an oversized request costs the real service (`gaugeloop serve`): a body is bounded
// before it is buffered, whatever its transfer encoding, and a write without the token is
// refused before a byte of its body is read. Measured on the process: its peak resident
// memory (VmHWM) before and after.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "tests/support/cli.h"
#include "tests/support/raw_http.h"
#include "tests/support/service_process.h"
#include "tests/support/temp_dir.h"

// Last: httplib brings <resolv.h>, whose `res` macro breaks Eigen's headers.
#include <httplib.h>

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::ServiceProcess;
using testing::slurp;

constexpr const char* kLimitsToken = "0123456789abcdef0123456789abcdef";
constexpr std::uint64_t kHugeBodyBytes = 300ull * 1024 * 1024;
constexpr long kAllowedGrowthKb = 16 * 1024;

// A field of /proc/PID/status in kB (VmHWM: the peak resident memory so far; VmRSS: now).
long status_kb(pid_t pid, const std::string& field) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(field + ":", 0) == 0) return std::stol(line.substr(field.size() + 1));
  }
  return -1;
}

// `head`, then a chunked body of `body_bytes` made as it is sent (64 KiB chunks of one letter,
// no line break anywhere), to the service until it closes the connection; what it answered.
testing::RawExchange send_chunked(int port, const std::string& head, std::uint64_t body_bytes) {
  const std::string chunk = "10000\r\n" + std::string(64 * 1024, 'x') + "\r\n";
  std::uint64_t given = 0;
  int step = 0;  // 0: the head; 1: the chunks, then the last one; 2: all given
  return testing::raw_exchange(
      port,
      [&]() -> std::string_view {
        if (step == 0) {
          step = 1;
          return head;
        }
        if (step == 1 && given < body_bytes) {
          given += 64 * 1024;
          return chunk;
        }
        if (step == 1) {
          step = 2;
          return "0\r\n\r\n";
        }
        return {};
      },
      /*until_closed=*/true);
}

class HttpApiLimitsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
    const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
    // No measurement is triggered: the gauge is never reached.
    std::ofstream(dir_ / "gauge.toml") << "[link]\nhost = \"127.0.0.1\"\nport = 1\n";
    std::ofstream(dir_ / "gaugeloop.toml")
        << "machine = \"grinder-7\"\n[gauge]\nconfig = \"gauge.toml\"\n[[part]]\nfile = \""
        << (examples / "intake_flat.toml").string() << "\"\n[nc]\ndir = \"nc\"\ntemplate = \""
        << (examples / "sinumerik" / "cam_table.spf").string()
        << "\"\n[database]\npath = \"runs.sqlite\"\n[http]\nport = 0\ntoken_file = \"token\"\n";
    // Readable by its owner only, as the service insists of a token file.
    std::ofstream(dir_ / "token") << kLimitsToken << "\n";
    fs::permissions(dir_ / "token", fs::perms::owner_read | fs::perms::owner_write);
  }

  std::string log() const { return slurp(dir_ / "serve.log"); }

  testing::TempDir tmp_;  // before everything that lives in it
  fs::path dir_;
};

TEST_F(HttpApiLimitsTest, AHugeChunkedBodyCostsTheServiceUnder16MegabytesWithOrWithoutTheToken) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  httplib::Client cli("127.0.0.1", port);
  ASSERT_TRUE(cli.Get("/api/health")) << log();  // every thread and pool the service starts is up
  const long peak_before_kb = status_kb(service.pid(), "VmHWM");
  ASSERT_GT(peak_before_kb, 0);

  const std::string post =
      "POST /api/measure HTTP/1.1\r\nHost: x\r\nContent-Type: application/json\r\n"
      "Transfer-Encoding: chunked\r\n";
  const testing::RawExchange no_token = send_chunked(port, post + "\r\n", kHugeBodyBytes);
  EXPECT_EQ(no_token.answer.rfind("HTTP/1.1 401", 0), 0u) << no_token.answer.substr(0, 400);
  EXPECT_NE(no_token.answer.find("Authorization: Bearer <token>"), std::string::npos) << no_token.answer;
  EXPECT_NE(no_token.answer.find("Connection: close"), std::string::npos) << no_token.answer;
  EXPECT_FALSE(no_token.all_sent) << "the service closes the connection instead of reading the body";

  const testing::RawExchange with_token =
      send_chunked(port, post + "Authorization: Bearer " + kLimitsToken + "\r\n\r\n", kHugeBodyBytes);
  EXPECT_EQ(with_token.answer.rfind("HTTP/1.1 413", 0), 0u) << with_token.answer.substr(0, 400);
  EXPECT_NE(with_token.answer.find("larger than 64 KiB"), std::string::npos) << with_token.answer;
  EXPECT_FALSE(with_token.all_sent);

  const testing::RawExchange get =
      send_chunked(port, "GET /api/runs HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n", kHugeBodyBytes);
  EXPECT_EQ(get.answer.rfind("HTTP/1.1 400", 0), 0u) << get.answer.substr(0, 400);
  EXPECT_NE(get.answer.find("takes no request body"), std::string::npos) << get.answer;
  EXPECT_FALSE(get.all_sent);

  const long peak_after_kb = status_kb(service.pid(), "VmHWM");
  const long now_kb = status_kb(service.pid(), "VmRSS");
  EXPECT_LT(peak_after_kb - peak_before_kb, kAllowedGrowthKb)
      << "peak resident memory grew from " << peak_before_kb << " kB to " << peak_after_kb << " kB (now " << now_kb
      << " kB)";
  std::printf("service peak resident memory: %ld kB before, %ld kB after three 300 MB chunked bodies (now %ld kB)\n",
              peak_before_kb, peak_after_kb, now_kb);

  auto health = cli.Get("/api/health");
  ASSERT_TRUE(health) << log();
  EXPECT_EQ(health->status, 200) << "still serving";
}

// A connection from `source` (any 127.x.y.z: loopback answers them all) to 127.0.0.1:`port`,
// `bytes` sent; -1 if it could not be made.
int connect_from(const std::string& source, int port, const std::string& bytes) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  sockaddr_in local{};
  local.sin_family = AF_INET;
  ::inet_pton(AF_INET, source.c_str(), &local.sin_addr);
  sockaddr_in to{};
  to.sin_family = AF_INET;
  to.sin_port = htons(static_cast<std::uint16_t>(port));
  to.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (::bind(fd, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0 ||
      ::connect(fd, reinterpret_cast<sockaddr*>(&to), sizeof to) != 0 ||
      ::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(bytes.size())) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// What comes on `fd` until the peer closes it (a guard of 60 s against a hang, not a clock).
std::string read_until_closed(int fd) {
  std::string out;
  char buf[4096];
  for (;;) {
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, 60 * 1000) <= 0) break;
    const ssize_t n = ::recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    out.append(buf, static_cast<std::size_t>(n));
  }
  return out;
}

// 200 clients that send a request line and a header line and then nothing more (as a client
// sending one header line a second would): the health check and the metrics still answer.
TEST_F(HttpApiLimitsTest, TwoHundredSlowClientsDoNotSilenceTheHealthCheck) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  std::vector<int> slow;
  for (int i = 0; i < 200; ++i) {
    // Eight addresses, 25 each: under the cap of 32 connections an address.
    const int fd =
        connect_from("127.0.0." + std::to_string(2 + i % 8), port, "GET /api/runs HTTP/1.1\r\nHost: grinder\r\n");
    ASSERT_GE(fd, 0) << "slow client " << i;
    slow.push_back(fd);
  }
  const std::string health = testing::raw_http(port, "GET /api/health HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(health.rfind("HTTP/1.1 200", 0), 0u) << health.substr(0, 300);
  EXPECT_NE(health.find("\"state\""), std::string::npos) << health;
  const std::string metrics = testing::raw_http(port, "GET /metrics HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(metrics.rfind("HTTP/1.1 200", 0), 0u) << metrics.substr(0, 300);
  // The slow clients are still waited for, not answered.
  int answered = 0;
  for (const int fd : slow) {
    pollfd p{fd, POLLIN, 0};
    answered += ::poll(&p, 1, 0) > 0 ? 1 : 0;
    ::close(fd);
  }
  EXPECT_EQ(answered, 0);
}

// One address may hold 32 connections: the 33rd and later are answered 503 and closed at once,
// and another address is still served.
TEST_F(HttpApiLimitsTest, OneAddressHoldsAtMost32Connections) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  std::vector<int> held;
  for (int i = 0; i < 32; ++i) {
    const int fd = connect_from("127.0.0.3", port, "GET /api/runs HTTP/1.1\r\n");
    ASSERT_GE(fd, 0);
    held.push_back(fd);
  }
  const int over = connect_from("127.0.0.3", port, "GET /api/health HTTP/1.1\r\nHost: x\r\n\r\n");
  ASSERT_GE(over, 0);
  const std::string refused = read_until_closed(over);
  ::close(over);
  EXPECT_EQ(refused.rfind("HTTP/1.1 503", 0), 0u) << refused;
  EXPECT_NE(refused.find("too many connections from 127.0.0.3"), std::string::npos) << refused;
  const std::string other = testing::raw_http(port, "GET /api/health HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(other.rfind("HTTP/1.1 200", 0), 0u) << other.substr(0, 300);
  for (const int fd : held) ::close(fd);
}

// A header line of 100 MB is answered 431 after its first 8 KiB; the service's peak resident
// memory grows by less than 1 MB. The request line has a bound of its own (414).
TEST_F(HttpApiLimitsTest, AHundredMegabyteHeaderLineCostsUnderAMegabyte) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  httplib::Client cli("127.0.0.1", port);
  ASSERT_TRUE(cli.Get("/api/health")) << log();
  const long peak_before_kb = status_kb(service.pid(), "VmHWM");
  const std::string head = "GET /api/health HTTP/1.1\r\nHost: x\r\nX-Long: ";
  const std::string piece(64 * 1024, 'x');
  std::uint64_t given = 0;
  bool head_given = false;
  const testing::RawExchange long_line = testing::raw_exchange(
      port,
      [&]() -> std::string_view {
        if (!head_given) {
          head_given = true;
          return head;
        }
        if (given >= 100ull * 1024 * 1024) return {};
        given += piece.size();
        return piece;
      },
      /*until_closed=*/true);
  EXPECT_EQ(long_line.answer.rfind("HTTP/1.1 431", 0), 0u) << long_line.answer.substr(0, 300);
  EXPECT_NE(long_line.answer.find("a header line is longer than 8 KiB"), std::string::npos) << long_line.answer;
  EXPECT_FALSE(long_line.all_sent) << "the connection ends instead of the line being read";
  const long peak_after_kb = status_kb(service.pid(), "VmHWM");
  EXPECT_LT(peak_after_kb - peak_before_kb, 1024) << peak_before_kb << " kB before, " << peak_after_kb << " kB after";
  std::printf("service peak resident memory: %ld kB before, %ld kB after a 100 MB header line\n", peak_before_kb,
              peak_after_kb);

  const std::string long_target =
      testing::raw_http(port, "GET /api/runs?part=" + std::string(9000, 'a') + " HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(long_target.rfind("HTTP/1.1 414", 0), 0u) << long_target.substr(0, 300);
  std::string many_headers = "GET /api/health HTTP/1.1\r\n";
  for (int i = 0; i < 100; ++i) many_headers += "X-" + std::to_string(i) + ": " + std::string(1000, 'v') + "\r\n";
  const std::string too_much = testing::raw_http(port, many_headers + "\r\n");
  EXPECT_EQ(too_much.rfind("HTTP/1.1 431", 0), 0u) << too_much.substr(0, 300);
  EXPECT_NE(too_much.find("head is larger than 64 KiB"), std::string::npos) << too_much.substr(0, 300);
}

}  // namespace
}  // namespace gaugeloop
