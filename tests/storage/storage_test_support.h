// Helpers for storage tests: a temporary directory, sample runs, and a raw SQLite handle.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>

#include "storage/run_store.h"
#include "tests/support/store_test.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop::testing {

// Runs `check` as an unprivileged user, so permission checks mean something when the tests
// run as root (as CI does): as root it forks, switches the child to nobody (65534) and runs
// `check` there; otherwise it runs `check` in place. `check` returns "" on success or what
// went wrong. Files `check` touches must be reachable by nobody (see TempDir::share).
std::string run_unprivileged(const std::function<std::string()>& check);

// What run_on_read_only_mount's result starts with when this machine cannot mount.
inline constexpr std::string_view kSkipped = "skipped: ";

// Runs `check` in a child process that sees `dir` bind-mounted read-only at a sibling
// directory "<dir>-read-only" (created here), in a mount namespace of its own: no other process
// sees the mount and nothing stays mounted. `check` gets the read-only path and returns "" on
// success. Needs root with CAP_SYS_ADMIN; otherwise the result is kSkipped and the reason.
std::string run_on_read_only_mount(const std::filesystem::path& dir,
                                   const std::function<std::string(const std::filesystem::path&)>& check);

// The raw lift the sample run holds at (revolution index, machine degree): deliberately not
// a multiple of 1e-6 mm, so the 6-decimal JSON rounding shows.
double sample_lift_mm(int revolution_index, int degree);

// A valid record: `revolutions` revolutions (amplifier counts 100, 101, ...), every table
// filled with distinct values, so any mix-up between columns or degrees shows; inspection
// figures, settings text and geometry (sense -1, c0 12.5, probe offset 30) set.
RunRecord make_record(const std::string& part, const std::string& started_utc, int revolutions = 3);

// A second, plain SQLite connection to a database file, for what RunStore does not expose.
// Test failures are reported through gtest; every call is deterministic (no busy waits: the
// busy timeout is 0).
class RawDb {
 public:
  explicit RawDb(const std::filesystem::path& path);
  ~RawDb();
  RawDb(const RawDb&) = delete;
  RawDb& operator=(const RawDb&) = delete;

  // Returns the SQLite result code; expects SQLITE_OK unless told otherwise.
  int exec(const std::string& sql);
  // The first column of the first row, as an integer (0 if there is no row).
  std::int64_t query_int(const std::string& sql);
  double query_double(const std::string& sql);
  std::string query_text(const std::string& sql);
  std::string errmsg() const { return sqlite3_errmsg(db_); }

  // How SQLite plans `sql` (EXPLAIN QUERY PLAN): each step's detail, one a line.
  std::string query_plan(const std::string& sql);

  // Rows of runs, run_raw (one per run with raw samples) and run_tables (one per run).
  struct Counts {
    std::int64_t runs, raw, tables;
  };
  Counts counts();

 private:
  sqlite3* db_ = nullptr;
};

}  // namespace gaugeloop::testing
