// The real service process (`gaugeloop serve`) against the simulators over loopback: a run
// requested over HTTP, or by the PLC through the Modbus handshake, ends in a stored run and an
// NC file; the HTTP API answers; a broken config on SIGHUP keeps the old one running, a new
// token is in force after SIGHUP; SIGTERM mid-run stores the whole run, leaves a whole table,
// completes the handshake and exits 0.
#include <arpa/inet.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "acquisition/modbus_gauge.h"
#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "config/part_file.h"
#include "nc_out/table_program.h"
#include "simulator/gauge_simulator.h"
#include "simulator/plc_simulator.h"
#include "simulator/virtual_grinder.h"
#include "storage/run_store.h"
#include "tests/support/cli.h"
#include "tests/support/damaged_database.h"
#include "tests/support/raw_http.h"
#include "tests/support/sample_runs.h"
#include "tests/support/service_process.h"
#include "tests/support/temp_dir.h"

// Last: httplib brings <resolv.h>, whose `res` macro breaks Eigen's headers.
#include <httplib.h>

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::raw_http;
using testing::ServiceProcess;
using testing::slurp;

constexpr const char* kToken = "0123456789abcdef0123456789abcdef";

bool has_code(const std::vector<StoredEvent>& events, const std::string& code) {
  for (const StoredEvent& e : events) {
    if (e.event.code == code) return true;
  }
  return false;
}

class ServiceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = tmp_.path();
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
                   "\"\n[database]\npath = \"runs.sqlite\"\n[http]\nport = 0\ntoken_file = \"token\"\n";
    std::ofstream(dir_ / "gaugeloop.toml") << config_text_;
    write_token(kToken);
  }

  // The token file, readable by its owner only, as the service insists.
  void write_token(const std::string& token) const {
    std::ofstream(dir_ / "token") << token << "\n";
    fs::permissions(dir_ / "token", fs::perms::owner_read | fs::perms::owner_write);
  }

  std::string log() const { return slurp(dir_ / "serve.log"); }

  std::vector<StoredEvent> events(EventKind kind) {
    auto store = RunStore::open(dir_ / "runs.sqlite");
    EXPECT_TRUE(store.ok());
    if (!store.ok()) return {};
    EventQuery q;
    q.kind = kind;
    auto list = store->list_events(q);
    EXPECT_TRUE(list.ok());
    return list.ok() ? *list : std::vector<StoredEvent>{};
  }

  // The service writes its events on a thread of its own, after the step that made them: a
  // test that saw the step waits for the event as it waits for the health answer.
  bool wait_for_event(EventKind kind, const std::string& code) {
    for (int i = 0; i < 20000; ++i) {
      if (has_code(events(kind), code)) return true;
      std::this_thread::yield();
    }
    return false;
  }

  testing::TempDir tmp_;  // before everything that lives in it
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

// The service starts without reading the whole database: its header and schema are checked,
// the whole file beside it. After a stop that left no clean-shutdown marker the check runs at
// once; a damaged file is reported in health and /metrics and every run is refused naming the
// damage. A clean stop leaves the marker, and the next start waits with its check.
TEST_F(ServiceTest, ADamagedDatabaseIsFoundBesideTheRunningServiceAndRunsAreRefused) {
  {
    auto store = RunStore::open(dir_ / "runs.sqlite");
    ASSERT_TRUE(store.ok()) << store.error().message;
    for (int i = 0; i < 3; ++i) {
      ASSERT_TRUE(
          store->insert_run(testing::sample_run("intake_flat", 1, "grinder-7", "2026-11-20T08:00:00Z", 5.0)).ok());
    }
  }
  ASSERT_TRUE(testing::damage_runs_table(dir_ / "runs.sqlite"));
  {
    ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
    const int port = service.port();
    ASSERT_GT(port, 0) << "started without checking the file whole\n" << log();
    httplib::Client cli("127.0.0.1", port);
    cli.set_read_timeout(120, 0);
    ASSERT_TRUE(wait_for_health(cli, [](const json& h) { return h["integrity"]["state"] == "damaged"; })) << log();
    auto metrics = cli.Get("/metrics");
    ASSERT_TRUE(metrics);
    EXPECT_NE(metrics->body.find("gaugeloop_database_integrity_sound 0\n"), std::string::npos);
    auto run = cli.Post("/api/measure", bearer(kToken), R"({"part": "intake_flat", "lobe": 1})", "application/json");
    ASSERT_TRUE(run);
    EXPECT_EQ(run->status, 503) << run->body;
    EXPECT_NE(run->body.find("is damaged"), std::string::npos) << run->body;
    EXPECT_FALSE(fs::exists(dir_ / "nc" / "CAM_INTAKE_L1.SPF"));
    service.signal(SIGTERM);
    EXPECT_EQ(service.wait(), 0) << log();
  }
  EXPECT_TRUE(fs::exists(dir_ / "runs.sqlite.clean-shutdown")) << "a clean stop leaves its marker";
  ServiceProcess again(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = again.port();
  ASSERT_GT(port, 0) << log();
  httplib::Client cli("127.0.0.1", port);
  auto health = cli.Get("/api/health");
  ASSERT_TRUE(health);
  EXPECT_EQ(json::parse(health->body)["integrity"]["state"], "waiting") << health->body;
  EXPECT_FALSE(fs::exists(dir_ / "runs.sqlite.clean-shutdown")) << "taken at start";
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
  EXPECT_TRUE(has_code(events(EventKind::kRefusal), "run not started")) << log();
  EXPECT_NE(log().find("run not started: "), std::string::npos) << log();

  // Requests no client library would send: a 4xx each, and the service serves on.
  for (const std::string& garbage :
       {std::string("BREW /api/health HTCPCP/1.0\r\n\r\n"),
        std::string("\x16\x03\x01\x00\xa5\x01\x00\x00\xa1\x03\x03\r\n\r\n", 15),  // TLS to a plain port
        std::string("POST /api/measure HTTP/1.1\r\nHost: x\r\nAuthorization: Bearer ") + kToken +
            "\r\nContent-Type: application/json\r\nContent-Length: 7\r\n\r\n{\"part\"",
        std::string("GET /api/runs?lobe=abc HTTP/1.1\r\nHost: x\r\n\r\n")}) {
    const std::string answer = raw_http(port, garbage);
    ASSERT_EQ(answer.rfind("HTTP/1.1 4", 0), 0u) << garbage << " -> " << answer;
    EXPECT_NE(answer.find("\"error\": \""), std::string::npos) << "a JSON message: " << answer;
  }
  auto still = cli.Get("/api/health");
  ASSERT_TRUE(still) << log();
  EXPECT_EQ(still->status, 200) << log();
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

// `gaugeloop measure` by hand with the service's config: the same gauge, settings, database
// and NC directory as a run the service makes; options the config sets are refused beside it.
TEST_F(ServiceTest, MeasureByHandWithTheServiceConfig) {
  const std::string config = " --config " + (dir_ / "gaugeloop.toml").string();
  testing::CommandResult r = testing::run_command(
      "measure" + config + " --part-name intake_flat --lobe 1 --note hand --serial CS-7 --operator anna");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("run 1: intake_flat lobe 1 on grinder-7"), std::string::npos) << r.output;
  auto store = RunStore::open(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok());
  auto runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].machine, "grinder-7");
  EXPECT_EQ((*runs)[0].note, "hand");
  EXPECT_EQ((*runs)[0].serial, "CS-7");
  EXPECT_EQ((*runs)[0].operator_name, "anna");
  EXPECT_TRUE(fs::exists(dir_ / "nc" / "CAM_INTAKE_L1.SPF"));

  r = testing::run_command("measure" + config + " --part-name intake_flat --lobe 1 --data-dir " + dir_.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--data-dir does not go with --config"), std::string::npos) << r.output;
  r = testing::run_command("measure" + config + " --part-name crank --lobe 1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("intake_flat lobe 1"), std::string::npos) << "names the parts it has: " << r.output;
  r = testing::run_command("measure" + config);
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("--config needs --part-name and --lobe"), std::string::npos) << r.output;
  r = testing::run_command("measure --lobe 1");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  EXPECT_EQ(runs->size(), 1u) << "no refused command measured";
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
  const std::vector<StoredEvent> faults = events(EventKind::kFault);
  ASSERT_TRUE(has_code(faults, "config reload refused")) << log();
  EXPECT_NE(faults.front().event.message.find("gain"), std::string::npos) << faults.front().event.message;

  auto run = cli.Post("/api/measure", bearer(kToken), R"({"part": "intake_flat", "lobe": 1})", "application/json");
  ASSERT_TRUE(run);
  EXPECT_EQ(run->status, 200) << run->body << "\n" << log();

  std::ofstream(dir_ / "gaugeloop.toml") << config_text_;
  service.signal(SIGHUP);
  ASSERT_TRUE(wait_for_health(cli, [](const json& h) { return h["config_reloads"] == 1; })) << log();
  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
}

// A new token in the token file is in force after SIGHUP, without a restart: the old one is
// refused from then on. Approving a pending table that does not exist answers 404 once past the
// token check, 401 before it, and measures nothing.
TEST_F(ServiceTest, SighupReplacesTheTokenWithoutARestart) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  httplib::Client cli("127.0.0.1", port);
  cli.set_read_timeout(120, 0);
  auto approve_with = [&cli](const std::string& token) {
    auto r = cli.Post("/api/nc/approve/99", bearer(token), R"({"by": "anna"})", "application/json");
    return r ? r->status : -1;
  };
  const std::string token_b = "d41d8cd98f00b204e9800998ecf8427e0cc175b9c0f1b6a831c399e269772661";
  EXPECT_EQ(approve_with(kToken), 404) << log();
  EXPECT_EQ(approve_with(token_b), 401) << log();

  write_token(token_b);
  service.signal(SIGHUP);
  ASSERT_TRUE(wait_for_health(cli, [](const json& h) { return h["config_reloads"] == 1; })) << log();
  EXPECT_EQ(approve_with(kToken), 401) << log();
  EXPECT_EQ(approve_with(token_b), 404) << log();
  EXPECT_NE(log().find("token replaced"), std::string::npos) << log();
  EXPECT_EQ(log().find("[http] changes take effect when the service restarts"), std::string::npos) << log();
  EXPECT_EQ(log().find(token_b), std::string::npos) << "the token is never logged: " << log();
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
  // One run at a time: a second request while the first measures is refused with a reason,
  // not queued. The gauge holds its answers meanwhile, so the first run cannot have ended.
  sim_->set_silent(true);
  auto second = cli.Post("/api/measure", bearer(kToken), R"({"part": "intake_flat", "lobe": 1})", "application/json");
  sim_->set_silent(false);
  // Not ASSERT: returning before request.join() would end the whole test program.
  EXPECT_TRUE(second) << httplib::to_string(second.error()) << "\n" << log();
  if (second) {
    EXPECT_EQ(second->status, 409) << second->body;
    EXPECT_NE(second->body.find("a run is in progress"), std::string::npos) << second->body;
  }
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

// The same service with [plc] pointed at an in-process PLC simulator; the intake lobe is PLC
// part number 7.
class PlcServiceTest : public ServiceTest {
 protected:
  void SetUp() override {
    ServiceTest::SetUp();
    if (HasFatalFailure()) return;
    PlcSimulatorSettings ps;
    ps.base_address = 100;
    auto plc = PlcSimulator::start(ps);
    ASSERT_TRUE(plc.ok()) << plc.error().message;
    plc_ = std::move(*plc);
    const std::string part_line = "intake_flat.toml\"\n";
    const size_t at = config_text_.find(part_line);
    ASSERT_NE(at, std::string::npos);
    config_text_.insert(at + part_line.size(), "plc_part_number = 7\n");
    config_text_ +=
        "[plc]\nhost = \"127.0.0.1\"\nport = " + std::to_string(plc_->port()) +
        "\nbase_address = 100\npoll_interval_ms = 20\nresponse_timeout_ms = 2000\npart_temperature = true\n";
    std::ofstream(dir_ / "gaugeloop.toml") << config_text_;
  }

  // Once the service has polled with the request low, a request raised is a rising edge.
  void wait_until_polled() {
    ASSERT_TRUE(plc_->wait_until([](const PlcServiceWords& w) { return w.heartbeat >= 1; }, kGenerous))
        << "the service never wrote its heartbeat: " << log();
  }

  static constexpr std::chrono::milliseconds kGenerous{120000};  // a run under sanitizers, with margin
  std::unique_ptr<PlcSimulator> plc_;
};

// systemd's end of sd_notify(3): a datagram socket in a directory of its own (a socket's path
// is at most 107 bytes; a test's own directory name can be long).
class NotifySocket {
 public:
  NotifySocket() : dir_("notify") {
    path_ = (dir_.path() / "s").string();
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof addr.sun_path, "%s", path_.c_str());
    bound_ = ::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
    const timeval guard{120, 0};  // a service that never says fails the test instead of hanging it
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &guard, sizeof guard);
  }
  ~NotifySocket() { ::close(fd_); }
  bool bound() const { return bound_; }
  std::string env() const { return "NOTIFY_SOCKET=" + path_; }
  // The next message; empty after the guard's two minutes without one.
  std::string next() const {
    char buf[4096];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    return n > 0 ? std::string(buf, static_cast<size_t>(n)) : std::string();
  }
  // The next message that tells a state (READY=1, RELOADING=1, STOPPING=1), past what the
  // watchdog's thread sends at any time: feeds, and a STATUS= line alone when it stops or
  // starts feeding again (a loaded machine may hold the PLC trigger's first poll).
  std::string next_state() const {
    for (std::string m = next();; m = next()) {
      if (m.empty() || !from_watchdog(m)) return m;
    }
  }
  // True at the next feed; false at a state message first, or the guard's timeout.
  bool fed() const {
    for (std::string m = next();; m = next()) {
      if (m == "WATCHDOG=1") return true;
      if (m.empty() || !from_watchdog(m)) return false;
    }
  }

 private:
  static bool from_watchdog(const std::string& m) {
    return m == "WATCHDOG=1" || (m.rfind("STATUS=", 0) == 0 && m.find('\n') == std::string::npos);
  }

  testing::TempDir dir_;  // before the socket in it
  std::string path_;
  int fd_ = -1;
  bool bound_ = false;
};

bool has_line(const std::string& message, const std::string& line) {
  return ("\n" + message + "\n").find("\n" + line + "\n") != std::string::npos;
}

// Started by systemd (NOTIFY_SOCKET, WATCHDOG_USEC as systemd sets them for Type=notify and
// WatchdogSec=), the service says READY=1 once the HTTP API and the PLC trigger are started,
// feeds the watchdog while they live, says RELOADING=1 and READY=1 around a SIGHUP, and
// STOPPING=1 on SIGTERM.
TEST_F(PlcServiceTest, TellsSystemdReadyFeedsTheWatchdogAndSaysStopping) {
  NotifySocket systemd;
  ASSERT_TRUE(systemd.bound());
  // A feed every 200 ms: a few while the test looks, none needed in time (nothing watches).
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log", {systemd.env(), "WATCHDOG_USEC=400000"});
  const std::string ready = systemd.next();
  ASSERT_TRUE(has_line(ready, "READY=1")) << ready << "\n" << log();
  EXPECT_NE(ready.find("STATUS=waiting for requests: HTTP API on port"), std::string::npos) << ready;
  EXPECT_NE(ready.find("PLC trigger at tcp:127.0.0.1:"), std::string::npos) << ready;
  EXPECT_TRUE(systemd.fed()) << log();
  EXPECT_TRUE(systemd.fed()) << log();

  service.signal(SIGHUP);
  EXPECT_TRUE(has_line(systemd.next_state(), "RELOADING=1")) << log();
  EXPECT_TRUE(has_line(systemd.next_state(), "READY=1")) << log();

  service.signal(SIGTERM);
  EXPECT_TRUE(has_line(systemd.next_state(), "STOPPING=1")) << log();
  EXPECT_EQ(service.wait(), 0) << log();
}

// Word 12 says which table ground the part: the design while version 1 is in force is an
// older part (stored, nothing pushed, result code 2); version 1 builds on it and pushes.
TEST_F(PlcServiceTest, TheGroundWithWordNamesTheTableThatGroundThePart) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  ASSERT_GT(service.port(), 0) << log();
  wait_until_polled();
  auto cycle = [this](std::uint16_t ground_with) -> std::optional<PlcServiceWords> {
    plc_->request(7, 1, ground_with);
    auto out = plc_->wait_for_outcome(kGenerous);
    plc_->clear_request();
    if (!plc_->wait_until([](const PlcServiceWords& w) { return !w.ack && !w.done && !w.fault; }, kGenerous)) {
      return std::nullopt;
    }
    return out;
  };
  auto first = cycle(0);  // not said: nothing in force yet, from the design
  ASSERT_TRUE(first.has_value()) << log();
  EXPECT_EQ(first->result_code, PlcResultCode::kTablePushed) << log();
  EXPECT_EQ(first->table_version, 1);

  auto older = cycle(plc_registers::kGroundWithDesign);
  ASSERT_TRUE(older.has_value()) << log();
  EXPECT_TRUE(older->done);
  EXPECT_EQ(older->result_code, PlcResultCode::kTableRefused) << log();
  EXPECT_EQ(older->table_version, 0);
  EXPECT_NE(older->run_id, 0u);

  auto with_v1 = cycle(1);
  ASSERT_TRUE(with_v1.has_value()) << log();
  EXPECT_EQ(with_v1->result_code, PlcResultCode::kTablePushed) << log();
  EXPECT_EQ(with_v1->table_version, 2);

  auto store = RunStore::open(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok());
  auto run = store->load_run(with_v1->run_id);
  ASSERT_TRUE(run.ok());
  EXPECT_EQ(run->ground_with_source, "plc");
  EXPECT_EQ(run->ground_with_version, std::optional<int>(1));
  EXPECT_EQ(run->correction_in_force_run, std::optional<std::int64_t>(first->run_id));
}

TEST_F(PlcServiceTest, PlcRequestRunNcFileDoneWithTheRunIdThenCleared) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  const int port = service.port();
  ASSERT_GT(port, 0) << log();
  wait_until_polled();

  ASSERT_TRUE(plc_->set_part_temperature_c(21.4).ok());  // word 37 = 214, with part and lobe
  plc_->request(7, 1);
  auto acked = plc_->wait_until([](const PlcServiceWords& w) { return w.ack; }, kGenerous);
  ASSERT_TRUE(acked.has_value()) << log();
  auto out = plc_->wait_for_outcome(kGenerous);
  ASSERT_TRUE(out.has_value()) << log();
  EXPECT_TRUE(out->done) << log();
  EXPECT_FALSE(out->fault);
  EXPECT_FALSE(out->busy);
  EXPECT_TRUE(out->ack);
  EXPECT_EQ(out->result_code, PlcResultCode::kTablePushed) << log();
  EXPECT_EQ(out->table_version, 1);

  // The run id the PLC reads is the stored run's, and the one the NC file carries.
  auto store = RunStore::open(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok());
  auto runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u) << log();
  EXPECT_EQ((*runs)[0].id, static_cast<std::int64_t>(out->run_id));
  EXPECT_EQ((*runs)[0].status, "pushed");
  auto parsed = parse_table_program(slurp(dir_ / "nc" / "CAM_INTAKE_L1.SPF"), "pushed for the PLC");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_TRUE(verify_table_checksum(*parsed, "pushed for the PLC").ok());
  EXPECT_EQ(parsed->header.at("run_id"), std::to_string(out->run_id));
  // The part temperature the PLC gave is kept with the run, said to be the PLC's.
  auto stored = store->load_run(static_cast<std::int64_t>(out->run_id));
  ASSERT_TRUE(stored.ok()) << stored.error().message;
  EXPECT_NE(stored->settings.find("\npart.temperature_c = 21.4\npart.temperature_source = plc\n"), std::string::npos)
      << stored->settings;

  // The request held high after done is not a new one: polls go on, no second run.
  const std::uint16_t heartbeat = out->heartbeat;
  auto later = plc_->wait_until(
      [heartbeat](const PlcServiceWords& w) { return static_cast<std::uint16_t>(w.heartbeat - heartbeat) >= 5; },
      kGenerous);
  ASSERT_TRUE(later.has_value()) << log();
  EXPECT_TRUE(later->done);
  runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  EXPECT_EQ(runs->size(), 1u);

  plc_->clear_request();
  auto cleared =
      plc_->wait_until([](const PlcServiceWords& w) { return !w.ack && !w.done && !w.fault && !w.busy; }, kGenerous);
  ASSERT_TRUE(cleared.has_value()) << log();

  httplib::Client cli("127.0.0.1", port);
  auto health = cli.Get("/api/health");
  ASSERT_TRUE(health);
  json h = json::parse(health->body);
  EXPECT_EQ(h["plc"]["connected"], true) << health->body;
  EXPECT_EQ(h["plc"]["requests"], 1) << health->body;
  auto run_page = cli.Get("/api/runs/" + std::to_string(out->run_id));
  ASSERT_TRUE(run_page);
  json rj = json::parse(run_page->body);
  EXPECT_EQ(rj["part_temperature_c"], 21.4) << run_page->body;
  EXPECT_EQ(rj["part_temperature_source"], "plc") << run_page->body;

  // Every step of the cycle, in order, in the database and in the log, the run named from
  // the moment it is stored.
  ASSERT_TRUE(wait_for_event(EventKind::kInfo, "plc done")) << log();
  std::vector<StoredEvent> info = events(EventKind::kInfo);
  std::sort(info.begin(), info.end(), [](const StoredEvent& a, const StoredEvent& b) { return a.id < b.id; });
  std::vector<std::string> cycle;
  for (const StoredEvent& e : info) {
    if (e.event.code.rfind("plc link", 0) == 0) continue;
    cycle.push_back(e.event.code);
    if (e.event.code == "stored" || e.event.code == "table pushed" || e.event.code == "plc done") {
      EXPECT_EQ(e.event.run_id, std::optional<std::int64_t>(out->run_id)) << e.event.code;
    }
  }
  EXPECT_EQ(cycle, (std::vector<std::string>{"plc request", "acquired", "analysed", "judged", "compensated", "stored",
                                             "table pushed", "plc done"}))
      << log();
  for (const char* line : {"part intake_flat lobe 1: acquired: 3 revolutions", "compensated: apply: largest correction",
                           "stored: run 1 stored in"}) {
    EXPECT_NE(log().find(line), std::string::npos) << line << "\n" << log();
  }
  auto api_events = cli.Get("/api/events?kind=info");
  ASSERT_TRUE(api_events);
  EXPECT_NE(api_events->body.find("plc done"), std::string::npos) << api_events->body;

  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
}

// The machine model of the virtual grinder (docs/virtual_grinder.md) under the service: the
// PLC asks for part 1, ground from the design on the default machine (about 16 um); the
// service measures it and pushes a table; part 2 is ground from that NC file, read back, and
// the PLC asks again: the service builds on the table in force and the part comes out under
// the 2.6 um the published cam-grinding result reached. Every change to compensation is judged here by the part it
// grinds.
TEST_F(PlcServiceTest, TheNextPartGroundFromThePushedTableComesOutUnder26Um) {
  auto pf = read_part_file(fs::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.toml");
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  auto design = read_lift_table_csv(pf->part.lift_table);
  ASSERT_TRUE(design.ok()) << design.error().message;
  const MachineErrorModel machine;  // the defaults: servo lag, geometric error, drift, vibration
  auto design_path = commanded_path_from_design(pf->part, *design);
  ASSERT_TRUE(design_path.ok()) << design_path.error().message;
  auto first = grind_part(pf->part, *design_path, machine, 0);
  ASSERT_TRUE(first.ok()) << first.error().message;
  ASSERT_TRUE(sim_->load_ground_part(first->reading_mm).ok());

  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  ASSERT_GT(service.port(), 0) << log();
  wait_until_polled();
  const auto cycle = [&]() -> std::optional<PlcServiceWords> {
    plc_->request(7, 1);
    auto out = plc_->wait_for_outcome(kGenerous);
    plc_->clear_request();
    if (!plc_->wait_until([](const PlcServiceWords& w) { return !w.ack && !w.done && !w.fault; }, kGenerous)) {
      return std::nullopt;
    }
    return out;
  };
  auto out = cycle();
  ASSERT_TRUE(out.has_value()) << log();
  ASSERT_EQ(out->result_code, PlcResultCode::kTablePushed) << log();

  auto second_path = commanded_path_from_program(dir_ / "nc" / "CAM_INTAKE_L1.SPF");
  ASSERT_TRUE(second_path.ok()) << second_path.error().message;
  auto second = grind_part(pf->part, *second_path, machine, 1);
  ASSERT_TRUE(second.ok()) << second.error().message;
  ASSERT_TRUE(sim_->load_ground_part(second->reading_mm).ok());
  out = cycle();
  ASSERT_TRUE(out.has_value()) << log();
  EXPECT_EQ(out->result_code, PlcResultCode::kTablePushed) << log();
  EXPECT_EQ(out->table_version, 2);

  auto store = RunStore::open(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok());
  auto runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 2u) << log();
  // Newest first: the second part, then the first. The part is judged by its true lift error
  // (the flat probe on the ground lobe against the design, no gauge); the stored run is the
  // gauge's view of it: 0.3 um RMS noise per sample, averaged over 3 revolutions is 0.17 um
  // per degree, and 4 sigma of that (0.7 um) bounds the difference of the two maxima.
  auto design_lift = PeriodicSpline::fit(design->angle_deg, design->lift_mm);
  ASSERT_TRUE(design_lift.ok());
  auto design_reading = flat_probe_reading(*design_lift, pf->part);
  ASSERT_TRUE(design_reading.ok());
  const TrueLiftError second_true = true_lift_error(second->reading_mm, *design_reading);
  EXPECT_GT((*runs)[1].max_abs_error_um, 13.0);
  EXPECT_LE(second_true.max_abs_um, 2.6) << "first part " << (*runs)[1].max_abs_error_um << " um";
  EXPECT_NEAR((*runs)[0].max_abs_error_um, second_true.max_abs_um, 0.7);

  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
}

TEST_F(PlcServiceTest, UnknownPartOrPartTemperatureOutOfRangeIsAFaultAndNoRunAndALostLinkComesBack) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  ASSERT_GT(service.port(), 0) << log();
  wait_until_polled();

  // The PLC drops the link: the service logs it once and reconnects.
  const std::uint16_t before = plc_->service_words().heartbeat;
  plc_->drop_connections();
  ASSERT_TRUE(
      plc_->wait_until(
              [before](const PlcServiceWords& w) { return static_cast<std::uint16_t>(w.heartbeat - before) >= 5; },
              kGenerous)
          .has_value())
      << log();
  EXPECT_NE(log().find("PLC link up at"), std::string::npos) << log();

  plc_->request(99, 1);
  auto out = plc_->wait_for_outcome(kGenerous);
  ASSERT_TRUE(out.has_value()) << log();
  EXPECT_TRUE(out->fault);
  EXPECT_FALSE(out->done);
  EXPECT_EQ(out->result_code, PlcResultCode::kUnknownPart);
  EXPECT_EQ(out->run_id, 0u);
  plc_->clear_request();
  ASSERT_TRUE(plc_->wait_until([](const PlcServiceWords& w) { return !w.ack && !w.fault; }, kGenerous).has_value());

  plc_->request(7, 2);  // part 7 has no lobe 2 here
  out = plc_->wait_for_outcome(kGenerous);
  ASSERT_TRUE(out.has_value()) << log();
  EXPECT_EQ(out->result_code, PlcResultCode::kUnknownPart);
  plc_->clear_request();
  ASSERT_TRUE(plc_->wait_until([](const PlcServiceWords& w) { return !w.ack && !w.fault; }, kGenerous).has_value());

  // A part temperature word out of range (150.1 deg C): fault, its own result code, no run, and
  // the event names the word and its holding register (base address 100).
  ASSERT_TRUE(plc_->set_part_temperature_c(150.1).ok());
  plc_->request(7, 1);
  out = plc_->wait_for_outcome(kGenerous);
  ASSERT_TRUE(out.has_value()) << log();
  EXPECT_TRUE(out->fault);
  EXPECT_EQ(out->result_code, PlcResultCode::kBadPartTemperature) << log();
  EXPECT_EQ(out->run_id, 0u);

  auto store = RunStore::open(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok());
  auto runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  EXPECT_TRUE(runs->empty()) << "an unknown part number never starts a run";
  EXPECT_TRUE(wait_for_event(EventKind::kInfo, "plc fault")) << log();
  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();
  // Its events are written by the time the service has exited.
  bool named = false;
  for (const StoredEvent& e : events(EventKind::kInfo)) {
    named = named || (e.event.code == "plc fault" &&
                      e.event.message.find("result code 10 (bad part temperature): PLC part temperature: word 37 "
                                           "(holding register 137) is 1501, 150.1 deg C") != std::string::npos);
  }
  EXPECT_TRUE(named) << log();
}

TEST_F(PlcServiceTest, SigtermMidCycleStoresTheRunAndAnswersThePlcBeforeExiting) {
  ServiceProcess service(dir_ / "gaugeloop.toml", dir_ / "serve.log");
  ASSERT_GT(service.port(), 0) << log();
  wait_until_polled();
  plc_->request(7, 1);
  ASSERT_TRUE(plc_->wait_until([](const PlcServiceWords& w) { return w.busy; }, kGenerous).has_value()) << log();
  service.signal(SIGTERM);
  EXPECT_EQ(service.wait(), 0) << log();

  const PlcServiceWords last = plc_->service_words();
  EXPECT_TRUE(last.done) << log();
  EXPECT_FALSE(last.busy);
  EXPECT_EQ(last.result_code, PlcResultCode::kTablePushed);
  auto store = RunStore::open(dir_ / "runs.sqlite");
  ASSERT_TRUE(store.ok());
  auto runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  ASSERT_EQ(runs->size(), 1u) << log();
  EXPECT_EQ((*runs)[0].id, static_cast<std::int64_t>(last.run_id));
}

TEST(ServiceConfigFile, ExampleConfigChecksAndABadOneNamesFileLineAndKey) {
  const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
  testing::CommandResult ok =
      testing::run_command("serve --check --config " + (examples / "service" / "gaugeloop.toml").string());
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("intake_flat lobe 1, exhaust_roller lobe 2"), std::string::npos) << ok.output;

  const testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
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

  // A database or NC directory the service could not write is refused at --check, naming the
  // key and the directory in the way (here a file where a directory should be).
  std::ofstream(dir / "afile") << "not a directory\n";
  const std::string nc = "[nc]\ntemplate = \"" + (examples / "sinumerik" / "cam_table.spf").string() + "\"\n";
  const std::string part = "[gauge]\n[[part]]\nfile = \"" + (examples / "intake_flat.toml").string() + "\"\n";
  std::ofstream(dir / "db.toml") << part << nc << "[database]\npath = \"afile/runs.sqlite\"\n";
  testing::CommandResult db = testing::run_command("serve --check --config " + (dir / "db.toml").string());
  EXPECT_EQ(db.exit_code, 2) << db.output;
  EXPECT_NE(db.output.find("db.toml:7"), std::string::npos) << db.output;
  EXPECT_NE(db.output.find((dir / "afile").string() + " is not a directory"), std::string::npos) << db.output;
  std::ofstream(dir / "ncdir.toml") << part << "[nc]\ndir = \"afile/nc\"\ntemplate = \""
                                    << (examples / "sinumerik" / "cam_table.spf").string() << "\"\n";
  testing::CommandResult ncdir = testing::run_command("serve --check --config " + (dir / "ncdir.toml").string());
  EXPECT_EQ(ncdir.exit_code, 2) << ncdir.output;
  EXPECT_NE(ncdir.output.find("ncdir.toml:5"), std::string::npos) << ncdir.output;
  EXPECT_NE(ncdir.output.find("NC directory"), std::string::npos) << ncdir.output;
}

TEST(ServiceConfigFile, PlcSettingsAndPartNumbersAreCheckedAtLoad) {
  const fs::path examples = fs::path(GAUGELOOP_SOURCE_DIR) / "examples";
  const testing::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  const std::string intake = "[[part]]\nfile = \"" + (examples / "intake_flat.toml").string() + "\"\n";
  const std::string exhaust = "[[part]]\nfile = \"" + (examples / "exhaust_roller.toml").string() + "\"\n";
  const std::string nc = "[nc]\ntemplate = \"" + (examples / "sinumerik" / "cam_table.spf").string() + "\"\n";
  auto check = [&dir](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return testing::run_command("serve --check --config " + (dir / name).string());
  };

  testing::CommandResult ok =
      check("ok.toml", "[gauge]\n" + intake + "plc_part_number = 7\n" + exhaust + "plc_part_number = 8\n" + nc +
                           "[plc]\nhost = \"10.0.0.5\"\nbase_address = 200\n");
  EXPECT_EQ(ok.exit_code, 0) << ok.output;
  EXPECT_NE(ok.output.find("PLC tcp:10.0.0.5:502 base 200"), std::string::npos) << ok.output;
  EXPECT_NE(ok.output.find("7 lobe 1 = intake_flat"), std::string::npos) << ok.output;

  testing::CommandResult twice = check("twice.toml", "[gauge]\n" + intake + "plc_part_number = 7\n" + exhaust +
                                                         "plc_part_number = 7\n" + nc + "[plc]\n");
  EXPECT_EQ(twice.exit_code, 2) << twice.output;
  EXPECT_NE(twice.output.find("twice.toml:7: key `part.plc_part_number`"), std::string::npos) << twice.output;
  EXPECT_NE(twice.output.find("already names part intake_flat"), std::string::npos) << twice.output;

  testing::CommandResult typo =
      check("typo.toml", "[gauge]\n" + intake + "plc_part_number = 7\n" + nc + "[plc]\npoll_ms = 50\n");
  EXPECT_EQ(typo.exit_code, 2) << typo.output;
  EXPECT_NE(typo.output.find("poll_ms"), std::string::npos) << typo.output;

  testing::CommandResult range = check("range.toml", "[gauge]\n" + intake + "plc_part_number = 0\n" + nc + "[plc]\n");
  EXPECT_EQ(range.exit_code, 2) << range.output;
  EXPECT_NE(range.output.find("plc_part_number"), std::string::npos) << range.output;

  testing::CommandResult unnumbered = check("unnumbered.toml", "[gauge]\n" + intake + nc + "[plc]\n");
  EXPECT_EQ(unnumbered.exit_code, 2) << unnumbered.output;
  EXPECT_NE(unnumbered.output.find("no [[part]] has a plc_part_number"), std::string::npos) << unnumbered.output;
}

}  // namespace
}  // namespace gaugeloop
