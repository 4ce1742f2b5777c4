// The run database: every measurement run, its analysis and its correction, kept in SQLite.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

namespace storage_internal {
struct Connection;  // SQLite connection; defined in storage/sqlite_db.h, never exposed
}  // namespace storage_internal

// Everything one run stores, written in one transaction by RunStore::insert_run.
// Timestamps are ISO 8601 UTC to the second, exactly "YYYY-MM-DDTHH:MM:SSZ", so that text
// order is time order.
struct RunRecord {
  std::string started_utc;    // "2026-11-22T02:34:44Z"
  std::string finished_utc;   // not earlier than started_utc
  std::string machine;        // e.g. "grinder-1"; not empty
  std::string part;           // part name; not empty
  int lobe = 1;               // 1-based
  std::string gauge;          // gauge address, e.g. "tcp:127.0.0.1:1502"
  std::string note;           // operator note, may be empty
  MeasuredRun measured;       // raw revolutions: >= 3, machine frame, amplifier revolution
                              // numbers strictly increasing, every value finite
  LobeAnalysis analysis;      // cam frame per-degree tables and summary figures, all finite
  DegreeTable correction_um;  // the correction computed from this run, cam frame, finite
  // The run whose correction was in force when the measured part was ground (it must be in
  // the database); empty: the part was ground from the design.
  std::optional<std::int64_t> correction_in_force_run;
};

// One row of the run list.
struct RunSummary {
  std::int64_t id = 0;
  std::string started_utc;
  std::string machine;
  std::string part;
  int lobe = 1;
  std::string status;        // "measured", or "pushed" once an NC file was written
  int revolutions = 0;       // complete revolutions stored
  int degrees_captured = 0;  // samples stored: revolutions * 360
  double max_abs_error_um = 0.0;
  double rms_error_um = 0.0;
  double repeatability_um = 0.0;
  std::string nc_file;  // the NC program last pushed from this run; empty if none
};

// A run as read back. Raw lifts come back to 1e-6 mm (the database keeps 6 decimals);
// every other number comes back exactly as written.
struct StoredRun {
  RunSummary summary;
  std::vector<RevolutionSamples> revolutions;  // machine frame, in the order measured
  LobeAnalysis analysis;                       // cam frame
  DegreeTable correction_um{};                 // cam frame
  // The rest of the record, for reports.
  std::string finished_utc;
  std::string gauge;
  std::string note;
  std::int64_t polls = 0;
  std::int64_t reconnects = 0;
  std::int64_t discarded_revolutions = 0;
  std::optional<std::int64_t> correction_in_force_run;
};

struct RunQuery {
  int limit = 50;    // at most this many runs; must be >= 1
  std::string part;  // exact part name; empty = any part
};

// The run database on one file. Owns one SQLite connection.
// Thread: use one RunStore per thread; any number of stores (threads or processes) may open
// the same file. The database runs in WAL mode, so readers are never blocked by a writer;
// a writer waits up to 5 s for another writer before failing with kStorage.
// Movable, not copyable; a moved-from store may only be destroyed or assigned to.
// Errors: kStorage for anything SQLite refuses (the message names the operation, the file
// and SQLite's reason), kIo if the directory cannot be created, kInvalidInput for a record
// or query that breaks the contracts above, kNotFound for an unknown run id.
class RunStore {
 public:
  // Opens (creating the parent directories and the file if need be) and brings the schema
  // up to date. ":memory:" opens a private in-memory database. A database written by a
  // newer gaugeloop (higher schema version) is refused.
  static Result<RunStore> open(const std::filesystem::path& db_path);

  RunStore(RunStore&& other) noexcept;
  RunStore& operator=(RunStore&& other) noexcept;
  RunStore(const RunStore&) = delete;
  RunStore& operator=(const RunStore&) = delete;
  ~RunStore();

  // Stores the whole record with status "measured" and returns its id. All or nothing: on
  // any error no row of the run is left behind. The record is validated before anything is
  // written; a non-finite value is kInvalidInput naming the table, column and degree.
  Result<std::int64_t> insert_run(const RunRecord& run);

  // Marks the run "pushed" and remembers the NC program written from it (replacing any
  // earlier one). kNotFound if there is no such run; kInvalidInput if nc_path is empty.
  Status record_nc_file(std::int64_t run_id, const std::string& nc_path);

  // Runs newest first (by started_utc, then by id).
  Result<std::vector<RunSummary>> list_runs(const RunQuery& q) const;

  // The newest run of this machine, part and lobe whose table was pushed: the table in
  // force, with which the next part is ground. Empty if none was pushed yet.
  Result<std::optional<std::int64_t>> last_pushed_run(const std::string& machine, const std::string& part,
                                                      int lobe) const;

  // One run, read in a single snapshot. kNotFound if absent.
  Result<StoredRun> load_run(std::int64_t run_id) const;

  // The file this store was opened on, as given to open().
  const std::filesystem::path& path() const;

 private:
  explicit RunStore(std::unique_ptr<storage_internal::Connection> conn);

  // Heap-allocated so its address survives a move of the store.
  std::unique_ptr<storage_internal::Connection> conn_;
};

}  // namespace gaugeloop
