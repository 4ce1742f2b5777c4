// A real PostgreSQL 15 cluster for tests: initdb into a fresh temporary directory, started on
// a free loopback port (127.0.0.1 only, the socket in the same directory), a fresh database per
// test, stopped (pg_ctl stop -m fast) and removed after. As root (CI) initdb and the server run
// as the `postgres` user, which owns the directory.
#pragma once

#include <filesystem>
#include <string>

#include "tests/support/free_port.h"

namespace gaugeloop::testing {

class PostgresServer {
 public:
  PostgresServer() = default;
  // Set before start(): the server flushes its commits to disk as a plant's would (fsync on).
  // Off by default: a test cluster need not survive a power cut, and the disk is shared.
  bool durable = false;
  ~PostgresServer();  // stops the server and removes its directory
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  // initdb and start, retrying on another free port if the server cannot bind its port (up to 5
  // times); waits for the server to accept connections (pg_ctl -w, up to 60 s). Returns "" on
  // success or what failed, with the server's log.
  std::string start();
  void stop();
  // Stops the server as a crash or an administrator would (pg_ctl stop -m immediate), keeping
  // its files, and starts it again on the same port: "" or what failed.
  std::string kill_server();
  std::string start_again();

  bool running() const { return running_; }
  // The server's log (pg_ctl -l), in its directory: removed with it by stop().
  std::filesystem::path log_path() const { return dir_ / "server.log"; }
  int port() const { return port_; }
  // postgresql://postgres@127.0.0.1:<port>/<database>
  std::string url(const std::string& database) const;
  // A new, empty database named after the running test (unique per call); returns its URL, or
  // "" (and a gtest failure) if it could not be made.
  std::string create_database();
  // psql -At -c SQL against `database` as the superuser: the output, or "ERROR..." text.
  std::string psql(const std::string& database, const std::string& sql) const;

 private:
  std::string run_as_owner(const std::string& command) const;  // returns output; sets last_exit_
  std::string server_options() const;                          // postgres -o: port, socket, loopback
  std::filesystem::path dir_;
  int port_ = 0;
  bool running_ = false;
  int databases_ = 0;
  mutable int last_exit_ = 0;
};

// The one server of a test executable: postgres_server.cc registers a gtest Environment that
// starts it before the first test and stops it after the last, so tests share the cluster and
// each makes its own database (create_database).
PostgresServer& shared_postgres();

}  // namespace gaugeloop::testing
