// A real PostgreSQL 15 cluster for tests (see postgres_server.h).
#include "tests/support/postgres_server.h"

#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <pwd.h>
#include <stdlib.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>

namespace gaugeloop::testing {

namespace {

constexpr const char* kBin = "/usr/lib/postgresql/15/bin/";

std::string shell_quoted(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') {
      out += "'\\''";
    } else {
      out += c;
    }
  }
  return out + "'";
}

std::string read_all(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

PostgresServer::~PostgresServer() { stop(); }

std::string PostgresServer::server_options() const {
  // fsync off unless durable: a test cluster need not survive a power cut, and the disk is
  // shared. Commits stay synchronous, so a server stopped abruptly keeps every committed
  // transaction.
  return "-p " + std::to_string(port_) + " -k " + dir_.string() + " -c listen_addresses=127.0.0.1" +
         (durable ? "" : " -c fsync=off");
}

std::string PostgresServer::run_as_owner(const std::string& command) const {
  // initdb and postgres refuse to run as root.
  const std::string line =
      (::geteuid() == 0 ? "runuser -u postgres -- sh -c " + shell_quoted(command) : "sh -c " + shell_quoted(command)) +
      " 2>&1";
  std::string out;
  FILE* pipe = ::popen(line.c_str(), "r");
  if (pipe == nullptr) {
    last_exit_ = -1;
    return "popen failed";
  }
  char buf[4096];
  while (std::fgets(buf, sizeof buf, pipe) != nullptr) out += buf;
  const int status = ::pclose(pipe);
  last_exit_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return out;
}

std::string PostgresServer::start() {
  std::string pattern = (std::filesystem::temp_directory_path() / "gaugeloop-postgres-XXXXXX").string();
  if (::mkdtemp(pattern.data()) == nullptr) return "mkdtemp failed for " + pattern;
  dir_ = pattern;
  if (::geteuid() == 0) {
    const passwd* pw = ::getpwnam("postgres");
    if (pw == nullptr) return "there is no postgres user to run the server as (install postgresql-15)";
    if (::chown(dir_.c_str(), pw->pw_uid, pw->pw_gid) != 0) return "cannot chown " + dir_.string();
  }
  const std::string data = (dir_ / "data").string();
  std::string out = run_as_owner(std::string(kBin) + "initdb -D " + shell_quoted(data) +
                                 " -U postgres -A trust -E UTF8 --locale=C --no-sync --no-instructions");
  if (last_exit_ != 0) return "initdb failed: " + out;
  std::string log;
  for (int attempt = 0; attempt < 5; ++attempt) {
    port_ = free_loopback_port();
    if (port_ == 0) return "no free loopback port";
    const std::string options = server_options();
    out = run_as_owner(std::string(kBin) + "pg_ctl start -D " + shell_quoted(data) + " -l " +
                       shell_quoted((dir_ / "server.log").string()) + " -w -t 60 -o " + shell_quoted(options));
    if (last_exit_ == 0) {
      running_ = true;
      return "";
    }
    // Another process took the port between the probe and the server's bind: try another.
    log = out + read_all(dir_ / "server.log");
  }
  return "pg_ctl start failed 5 times: " + log;
}

void PostgresServer::stop() {
  if (running_) {
    run_as_owner(std::string(kBin) + "pg_ctl stop -D " + shell_quoted((dir_ / "data").string()) + " -m fast -w -t 60");
    running_ = false;
  }
  if (!dir_.empty()) {
    std::error_code ec;
    std::filesystem::remove_all(dir_, ec);
    dir_.clear();
  }
}

std::string PostgresServer::kill_server() {
  const std::string out = run_as_owner(std::string(kBin) + "pg_ctl stop -D " + shell_quoted((dir_ / "data").string()) +
                                       " -m immediate -w -t 60");
  if (last_exit_ != 0) return "pg_ctl stop failed: " + out;
  running_ = false;
  return "";
}

std::string PostgresServer::start_again() {
  const std::string options = server_options();
  const std::string out =
      run_as_owner(std::string(kBin) + "pg_ctl start -D " + shell_quoted((dir_ / "data").string()) + " -l " +
                   shell_quoted((dir_ / "server.log").string()) + " -w -t 60 -o " + shell_quoted(options));
  if (last_exit_ != 0) return "pg_ctl start failed: " + out + read_all(dir_ / "server.log");
  running_ = true;
  return "";
}

std::string PostgresServer::url(const std::string& database) const {
  return "postgresql://postgres@127.0.0.1:" + std::to_string(port_) + "/" + database;
}

std::string PostgresServer::psql(const std::string& database, const std::string& sql) const {
  std::string out =
      run_as_owner(std::string(kBin) + "psql -X -q -At -v ON_ERROR_STOP=1 -h 127.0.0.1 -p " + std::to_string(port_) +
                   " -U postgres -d " + shell_quoted(database) + " -c " + shell_quoted(sql));
  while (!out.empty() && out.back() == '\n') out.pop_back();
  return out;
}

std::string PostgresServer::create_database() {
  const ::testing::TestInfo* t = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = "t" + std::to_string(++databases_) + "_";
  for (char c : t == nullptr ? std::string("test") : std::string(t->name())) {
    if ((c >= 'a' && c <= 'z') || (c >= '0' && c <= '9')) {
      name += c;
    } else if (c >= 'A' && c <= 'Z') {
      name += static_cast<char>(c - 'A' + 'a');
    }
  }
  name = name.substr(0, 60);
  const std::string out = run_as_owner(std::string(kBin) + "createdb -h 127.0.0.1 -p " + std::to_string(port_) +
                                       " -U postgres " + shell_quoted(name));
  EXPECT_EQ(last_exit_, 0) << "createdb " << name << ": " << out;
  return last_exit_ == 0 ? url(name) : std::string();
}

namespace {

PostgresServer*& shared_slot() {
  static PostgresServer* server = nullptr;
  return server;
}

class PostgresEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    shared_slot() = new PostgresServer;
    const std::string failed = shared_slot()->start();
    ASSERT_EQ(failed, "") << "cannot start the test's PostgreSQL 15 cluster";
  }
  void TearDown() override {
    delete shared_slot();
    shared_slot() = nullptr;
  }
};

// Registered before main runs: every test executable that links this file gets the cluster.
[[maybe_unused]] ::testing::Environment* const kEnvironment =
    ::testing::AddGlobalTestEnvironment(new PostgresEnvironment);

}  // namespace

PostgresServer& shared_postgres() { return *shared_slot(); }

}  // namespace gaugeloop::testing
