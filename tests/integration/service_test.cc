// The real service process (`gaugeloop serve`) against the simulator over loopback: a run
// requested over HTTP ends in a stored run and an NC file; the HTTP API answers; a broken
// config on SIGHUP keeps the old one running; SIGTERM mid-run stores the whole run, leaves
// a whole table and exits 0.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "acquisition/modbus_gauge.h"
#include "app/part_file.h"
#include "nc_out/table_program.h"
#include "simulator/gauge_simulator.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"

// Last: httplib brings <resolv.h>, whose `res` macro breaks Eigen's headers.
#include <httplib.h>

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::slurp;

constexpr const char* kToken = "0123456789abcdef0123456789abcdef";

// `gaugeloop serve --config F` as a child process; stdout read line by line, stderr to a file.
class ServiceProcess {
 public:
  ServiceProcess(const fs::path& config, const fs::path& log) {
    // Everything the child needs, made before the fork.
    const std::string bin = std::string(GAUGELOOP_BINARY_DIR) + "/bin/gaugeloop";
    const std::string config_path = config.string();
    const std::string log_path = log.string();
    int out[2];
    if (::pipe(out) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      // Only async-signal-safe calls between fork and exec: the parent has other threads.
      ::dup2(out[1], STDOUT_FILENO);
      const int err = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (err >= 0) ::dup2(err, STDERR_FILENO);
      ::close(out[0]);
      ::execl(bin.c_str(), bin.c_str(), "serve", "--config", config_path.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(out[1]);
    stdout_ = ::fdopen(out[0], "r");
  }
  ~ServiceProcess() {
    if (pid_ > 0 && !exited_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (stdout_ != nullptr) std::fclose(stdout_);
  }

  // The HTTP port from the "listening on http://HOST:PORT" line; 0 if the process ended first.
  int port() {
    char line[512];
    while (stdout_ != nullptr && std::fgets(line, sizeof line, stdout_) != nullptr) {
      int port = 0;
      if (std::sscanf(line, "listening on http://127.0.0.1:%d", &port) == 1) return port;
    }
    return 0;
  }
  void signal(int sig) const { ::kill(pid_, sig); }
  // Exit status, or -1 if killed by a signal.
  int wait() {
    int status = 0;
    ::waitpid(pid_, &status, 0);
    exited_ = true;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
  std::FILE* stdout_ = nullptr;
  bool exited_ = false;
};

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("gaugeloop-serve-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
    auto pf = read_part_file(examples / "intake_flat.toml");
    ASSERT_TRUE(pf.ok()) << pf.error().message;
    auto design = read_lift_table_csv(pf->part.lift_table);
    ASSERT_TRUE(design.ok()) << design.error().message;
    SimulatorSettings ss;
    ss.time_scale = 4.0;  // 60 rpm at 4x: a run takes about a second
    auto sim = GaugeSimulator::start(pf->part, *design, ss);
    ASSERT_TRUE(sim.ok()) << sim.error().message;
    sim_ = std::move(*sim);
    std::ofstream(dir_ / "gauge.toml") << "[link]\nhost = \"127.0.0.1\"\nport = " << sim_->port() << "\n";
    config_text_ = "machine = \"grinder-7\"\n[gauge]\nconfig = \"gauge.toml\"\n[[part]]\nfile = \"" +
                   (examples / "intake_flat.toml").string() + "\"\n[nc]\ndir = \"nc\"\ntemplate = \"" +
                   (examples / "sinumerik" / "cam_table.spf").string() +
                   "\"\n[database]\npath = \"runs.sqlite\"\n[http]\nport = 0\ntoken = \"" + kToken + "\"\n";
    std::ofstream(dir_ / "gaugeloop.toml") << config_text_;
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string log() const { return slurp(dir_ / "serve.log"); }

  fs::path dir_;
  std::string config_text_;
  std::unique_ptr<GaugeSimulator> sim_;
};

httplib::Headers bearer(const std::string& token) { return {{"Authorization", "Bearer " + token}}; }

// Polls health until `done` holds for its JSON (or the service is gone): state, not time.
template <typename Pred>
bool wait_for_health(httplib::Client& cli, Pred done) {
  for (int i = 0; i < 200000; ++i) {
    auto r = cli.Get("/api/health");
    if (!r) return false;
    if (r->status == 200 && done(json::parse(r->body))) return true;
    std::this_thread::yield();
  }
  return false;
}

TEST_F(ServiceTest, RequestRunNcFileAndTheHttpApi) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  httplib::Client cli("127.0.0.1", port);
  cli.set_read_timeout(120, 0);  // a run answers when it is done: seconds, more under sanitizers

  auto health = cli.Get("/api/health");
  ASSERT_TRUE(health) << log();
  EXPECT_EQ(health->status, 200);
  EXPECT_EQ(json::parse(health->body)["state"], "idle");

  const std::string body = R"({"part": "intake_flat", "lobe": 1, "note": "first part of the shift"})";
  auto no_token = cli.Post("/api/measure", body, "application/json");
  ASSERT_TRUE(no_token);
  EXPECT_EQ(no_token->status, 401) << no_token->body;
  EXPECT_FALSE(fs::exists(dir_ / "nc" / "CAM_INTAKE_L1.SPF"));

  auto run = cli.Post("/api/measure", bearer(kToken), body, "application/json");
  ASSERT_TRUE(run) << log();
  ASSERT_EQ(run->status, 200) << run->body << "\n" << log();
  json report = json::parse(run->body);
  EXPECT_EQ(report["pushed"], true);
  const fs::path nc_file = report["nc_file"].get<std::string>();
  EXPECT_EQ(nc_file, fs::absolute(dir_ / "nc" / "CAM_INTAKE_L1.SPF").lexically_normal());
  auto parsed = parse_table_program(slurp(nc_file), "pushed");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_TRUE(verify_table_checksum(*parsed, "pushed").ok());
  EXPECT_EQ(parsed->header.at("run_id"), std::to_string(report["run_id"].get<long long>()));

  // Writes beyond measuring: a rollback over HTTP pushes version 1 again as version 2.
  auto rollback = cli.Post("/api/nc/rollback", bearer(kToken),
                           R"({"program": "CAM_INTAKE_L1", "version": 1, "by": "anna"})", "application/json");
  ASSERT_TRUE(rollback);
  ASSERT_EQ(rollback->status, 200) << rollback->body << "\n" << log();
  EXPECT_EQ(json::parse(rollback->body)["table_version"], 2);
  auto rolled = parse_table_program(slurp(nc_file), "rolled back");
  ASSERT_TRUE(rolled.ok()) << rolled.error().message;
  EXPECT_EQ(rolled->header.at("table_version"), "2");
  EXPECT_EQ(rolled->body_checksum, parsed->body_checksum);
  auto approve = cli.Post("/api/nc/approve/99", bearer(kToken), R"({"by": "anna"})", "application/json");
  ASSERT_TRUE(approve);
  EXPECT_EQ(approve->status, 404) << approve->body;

  auto unknown = cli.Post("/api/measure", bearer(kToken), R"({"part": "crank", "lobe": 1})", "application/json");
  ASSERT_TRUE(unknown);
  EXPECT_EQ(unknown->status / 100, 4) << unknown->body;
  EXPECT_NE(json::parse(unknown->body)["error"].get<std::string>().find("intake_flat lobe 1"), std::string::npos)
      << "the message lists the configured parts: " << unknown->body;

  auto runs = cli.Get("/api/runs?part=intake_flat");
  ASSERT_TRUE(runs);
  ASSERT_EQ(runs->status, 200) << runs->body;
  json list = json::parse(runs->body);
  ASSERT_EQ(list.size(), 1u);
  EXPECT_EQ(list[0]["machine"], "grinder-7");
  auto metrics = cli.Get("/metrics");
  ASSERT_TRUE(metrics);
  EXPECT_NE(metrics->body.find("gaugeloop_service_runs_total{outcome=\"pushed\"} 1"), std::string::npos)
      << metrics->body;

  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
}

TEST_F(ServiceTest, BrokenConfigOnReloadKeepsTheOldOneRunning) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  httplib::Client cli("127.0.0.1", port);
  cli.set_read_timeout(120, 0);  // a run answers when it is done: seconds, more under sanitizers

  std::ofstream(dir_ / "gaugeloop.toml") << config_text_ << "[compensation]\ngain = 3.0\n";
  service.signal(SIGHUP);
  ASSERT_TRUE(wait_for_health(cli, [](const json& h) { return h["config_reload_failures"] == 1; })) << log();
  EXPECT_NE(log().find("gain"), std::string::npos) << "the log names the key: " << log();

  auto run = cli.Post("/api/measure", bearer(kToken), R"({"part": "intake_flat", "lobe": 1})", "application/json");
  ASSERT_TRUE(run);
  EXPECT_EQ(run->status, 200) << run->body << "\n" << log();

  std::ofstream(dir_ / "gaugeloop.toml") << config_text_;
  service.signal(SIGHUP);
  ASSERT_TRUE(wait_for_health(cli, [](const json& h) { return h["config_reloads"] == 1; })) << log();
  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
}

TEST_F(ServiceTest, SigtermMidRunStoresTheWholeRunAndLeavesAWholeTable) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  httplib::Client cli("127.0.0.1", port);
  cli.set_read_timeout(120, 0);

  std::thread request([port] {
    httplib::Client c("127.0.0.1", port);
    c.set_read_timeout(120, 0);
    (void)c.Post("/api/measure", bearer(kToken), R"({"part": "intake_flat", "lobe": 1})", "application/json");
  });
  const bool measuring = wait_for_health(cli, [](const json& h) { return h["state"] == "measuring"; });
  service.signal(SIGTERM);
  const int status = service.wait();
  request.join();
  ASSERT_TRUE(measuring) << log();
  EXPECT_EQ(status, 0) << log();

  auto store = RunStore::open(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok());
  auto runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u) << "the run in progress was finished and stored: " << log();
  auto run = store->load_run((*runs)[0].id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->revolutions.size(), 3u);
  EXPECT_EQ(run->summary.status, "pushed");
  auto parsed = parse_table_program(slurp(dir_ / "nc" / "CAM_INTAKE_L1.SPF"), "after SIGTERM");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_TRUE(verify_table_checksum(*parsed, "after SIGTERM").ok());
}

TEST(ServiceConfigFile, ExampleConfigChecksAndABadOneNamesFileLineAndKey) {
  const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
  testing::CommandResult ok =
      testing::run_command("serve --check --config " + (examples / "service" / "gaugeloop.toml").string());
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("intake_flat lobe 1, exhaust_roller lobe 2"), std::string::npos) << ok.output;

  const fs::path dir = fs::temp_directory_path() / ("gaugeloop-badcfg-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::ofstream(dir / "bad.toml") << "machine = \"m\"\n[gauge]\nmode = \"fast\"\n";
  testing::CommandResult bad = testing::run_command("serve --config " + (dir / "bad.toml").string());
  EXPECT_EQ(bad.exit_code, 2) << bad.output;
  EXPECT_NE(bad.output.find("bad.toml:3"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("mode"), std::string::npos) << bad.output;
  EXPECT_NE(bad.output.find("not starting"), std::string::npos) << bad.output;
  std::ofstream(dir / "typo.toml") << "[gauge]\n[[part]]\nfile = \"x.toml\"\n[nc]\ntemplat = \"t.spf\"\n";
  testing::CommandResult typo = testing::run_command("serve --config " + (dir / "typo.toml").string());
  EXPECT_EQ(typo.exit_code, 2) << typo.output;
  EXPECT_NE(typo.output.find("templat"), std::string::npos) << typo.output;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace gaugeloop
