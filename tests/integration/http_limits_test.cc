// What an oversized request costs the real service (`gaugeloop serve`): a body is bounded
// before it is buffered, whatever its transfer encoding, and a write without the token is
// refused before a byte of its body is read. Measured on the process: its peak resident
// memory (VmHWM) before and after.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

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

}  // namespace
}  // namespace gaugeloop
