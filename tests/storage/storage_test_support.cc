// Helpers for storage tests: a temporary directory, sample runs, and a raw SQLite handle.
#include <sched.h>
#include <sys/mount.h>
#include <sys/wait.h>
#include <unistd.h>

#include "storage_test_support.h"

#include <gtest/gtest.h>
#include <stdlib.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

namespace gaugeloop::testing {

namespace {

// Runs `body` in a forked child and returns what it returned ("" on success); the child's
// changes to its own process (user, mount namespace) end with it.
std::string run_in_child(const std::function<std::string()>& body) {
  int fds[2];
  if (::pipe(fds) != 0) return "pipe failed";
  const pid_t pid = ::fork();
  if (pid < 0) return "fork failed";
  if (pid == 0) {
    ::close(fds[0]);
    const std::string result = body();
    [[maybe_unused]] auto n = ::write(fds[1], result.data(), result.size());
    ::close(fds[1]);
    ::_exit(result.empty() ? 0 : 1);
  }
  ::close(fds[1]);
  std::string out;
  char buf[512];
  ssize_t n;
  while ((n = ::read(fds[0], buf, sizeof buf)) > 0) out.append(buf, static_cast<size_t>(n));
  ::close(fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  if (!WIFEXITED(status)) return "the check in a child process crashed";
  if (WEXITSTATUS(status) != 0 && out.empty()) return "the check in a child process failed";
  return out;
}

std::string errno_text(const std::string& what) { return what + ": " + std::strerror(errno); }

}  // namespace

std::string run_unprivileged(const std::function<std::string()>& check) {
  if (::geteuid() != 0) return check();
  return run_in_child([&check]() -> std::string {
    if (::setgid(65534) != 0 || ::setuid(65534) != 0) return "cannot switch to user nobody";
    return check();
  });
}

std::string run_on_read_only_mount(const std::filesystem::path& dir,
                                   const std::function<std::string(const std::filesystem::path&)>& check) {
  const std::filesystem::path mount_point = dir.parent_path() / (dir.filename().string() + "-read-only");
  std::error_code ec;
  std::filesystem::create_directory(mount_point, ec);
  if (ec) return "cannot create the mount point " + mount_point.string() + ": " + ec.message();
  return run_in_child([&]() -> std::string {
    if (::unshare(CLONE_NEWNS) != 0) return std::string(kSkipped) + errno_text("unshare(CLONE_NEWNS)");
    if (::mount(nullptr, "/", nullptr, MS_REC | MS_PRIVATE, nullptr) != 0) {
      return std::string(kSkipped) + errno_text("making / private");
    }
    if (::mount(dir.c_str(), mount_point.c_str(), nullptr, MS_BIND, nullptr) != 0) {
      return std::string(kSkipped) + errno_text("bind mount");
    }
    if (::mount(nullptr, mount_point.c_str(), nullptr, MS_REMOUNT | MS_BIND | MS_RDONLY, nullptr) != 0) {
      return std::string(kSkipped) + errno_text("remount read-only");
    }
    return check(mount_point);
  });
}

double sample_lift_mm(int revolution_index, int degree) {
  return 1.5 + 3.2 * std::sin(degree * 0.0174532925199) + 0.0000123456789 * revolution_index + 1e-7 * degree;
}

RunRecord make_record(const std::string& part, const std::string& started_utc, int revolutions) {
  RunRecord r;
  r.started_utc = started_utc;
  r.finished_utc = started_utc;
  r.machine = "grinder-1";
  r.part = part;
  r.lobe = 2;
  r.gauge = "tcp:127.0.0.1:1502";
  r.note = "first shift, wheel dressed";
  for (int i = 0; i < revolutions; ++i) {
    RevolutionSamples rev;
    rev.revolution = 100 + i;
    for (int deg = 0; deg < kDegreesPerRevolution; ++deg) {
      rev.lift_mm[static_cast<std::size_t>(deg)] = sample_lift_mm(i, deg);
    }
    r.measured.revolutions.push_back(rev);
  }
  r.measured.polls = 1234;
  r.measured.reconnects = 1;
  r.measured.discarded_revolutions = 2;
  for (std::size_t d = 0; d < static_cast<std::size_t>(kDegreesPerRevolution); ++d) {
    const double x = static_cast<double>(d);
    r.analysis.design_lift_mm[d] = 0.01 * x + 1.0 / 3.0;
    r.analysis.mean_lift_mm[d] = 0.01 * x + 1.0 / 7.0;
    r.analysis.spread_um[d] = 0.1 + x / 1000.0;
    r.analysis.error_um[d] = std::cos(x) * 4.0;
    r.correction_um[d] = -std::cos(x) * 4.0 + 1.0 / 11.0;
  }
  r.analysis.zero_offset_mm = 0.123456789012;
  r.analysis.max_abs_error_um = 4.0;
  r.analysis.rms_error_um = 2.8284271247;
  r.analysis.peak_to_valley_um = 8.0;
  r.analysis.repeatability_um = 0.459;
  r.analysis.phase_error_deg = -0.1234567;
  r.analysis.base_circle_runout_um = 1.75;
  for (std::size_t h = 0; h < r.analysis.harmonic_amplitude_um.size(); ++h) {
    r.analysis.harmonic_amplitude_um[h] = 1.0 / (1.0 + static_cast<double>(h)) + 1e-13;
  }
  r.settings = "analysis.base_circle_window_deg = 150..210\ncompensation.gain = 1\n";
  Part g;
  g.follower = FollowerKind::kRoller;
  g.follower_radius_mm = 12.0;
  g.base_circle_radius_mm = 18.0;
  g.wheel_radius_mm = 300.0;
  g.rotation_sense = -1;
  g.c_offset_deg = 12.5;
  g.probe_offset_deg = 30.0;
  r.geometry = g;
  return r;
}

RawDb::RawDb(const std::filesystem::path& path) {
  const int rc = sqlite3_open_v2(path.c_str(), &db_, SQLITE_OPEN_READWRITE, nullptr);
  EXPECT_EQ(rc, SQLITE_OK) << "raw open of " << path << ": " << sqlite3_errstr(rc);
}

RawDb::~RawDb() { sqlite3_close_v2(db_); }

int RawDb::exec(const std::string& sql) { return sqlite3_exec(db_, sql.c_str(), nullptr, nullptr, nullptr); }

namespace {

// Steps `sql` once and hands the statement to `read` if there is a row.
template <typename T, typename Read>
T query_one(sqlite3* db, const std::string& sql, T empty, Read read) {
  sqlite3_stmt* stmt = nullptr;
  int rc = sqlite3_prepare_v2(db, sql.c_str(), -1, &stmt, nullptr);
  EXPECT_EQ(rc, SQLITE_OK) << sql << ": " << sqlite3_errmsg(db);
  T value = empty;
  if (rc == SQLITE_OK) {
    rc = sqlite3_step(stmt);
    EXPECT_TRUE(rc == SQLITE_ROW || rc == SQLITE_DONE) << sql << ": " << sqlite3_errmsg(db);
    if (rc == SQLITE_ROW) value = read(stmt);
  }
  sqlite3_finalize(stmt);
  return value;
}

}  // namespace

std::int64_t RawDb::query_int(const std::string& sql) {
  return query_one<std::int64_t>(db_, sql, 0, [](sqlite3_stmt* s) { return sqlite3_column_int64(s, 0); });
}

double RawDb::query_double(const std::string& sql) {
  return query_one<double>(db_, sql, 0.0, [](sqlite3_stmt* s) { return sqlite3_column_double(s, 0); });
}

std::string RawDb::query_text(const std::string& sql) {
  return query_one<std::string>(db_, sql, std::string(), [](sqlite3_stmt* s) {
    const unsigned char* text = sqlite3_column_text(s, 0);
    return text != nullptr ? std::string(reinterpret_cast<const char*>(text)) : std::string();
  });
}

std::string RawDb::query_plan(const std::string& sql) {
  sqlite3_stmt* st = nullptr;
  const std::string explain = "EXPLAIN QUERY PLAN " + sql;
  EXPECT_EQ(sqlite3_prepare_v2(db_, explain.c_str(), -1, &st, nullptr), SQLITE_OK) << sql << ": " << errmsg();
  std::string plan;
  while (st != nullptr && sqlite3_step(st) == SQLITE_ROW) {
    plan += reinterpret_cast<const char*>(sqlite3_column_text(st, 3)) + std::string("\n");
  }
  sqlite3_finalize(st);
  return plan;
}

RawDb::Counts RawDb::counts() {
  return {query_int("SELECT count(*) FROM runs"), query_int("SELECT count(*) FROM run_raw"),
          query_int("SELECT count(*) FROM run_tables")};
}

}  // namespace gaugeloop::testing
