// Keeping the run database file sound: integrity checks and online backups of any file,
// whatever its schema version (a backup of an older gaugeloop's file included).
#pragma once

#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "core/result.h"
#include "storage/run_store.h"

struct sqlite3;

namespace gaugeloop {

// The verdict of IntegrityCheck plus PRAGMA foreign_key_check on a file.
struct IntegrityReport {
  // Empty: the file is sound. Otherwise each problem as one line, in SQLite's words for the
  // page checks ("Tree 5 page 5 cell 0: ..."), "<table> row <id>: refers to a missing <parent>
  // row" for the foreign keys; at most 100 page problems are listed.
  std::vector<std::string> problems;
  // False when the file could only be opened read-only: SQLite then does not know the CHECK
  // constraints, so a value that breaks one (a flipped byte in a run's row) goes unseen.
  bool constraints_checked = true;
  bool sound() const { return problems.empty(); }
};

// Checks a database file at any schema version, never writing it: opened read-write (but
// neither created nor migrated) where this process may write it, so that the CHECK
// constraints are verified too, and read-only (as RunStore::open_read_only opens it)
// elsewhere, e.g. on a read-only mount. Safe beside the service. A file SQLite finds
// malformed or not a database at all is a report with that problem, not an error.
// Errors: kNotFound if there is no file; kStorage if it cannot be read at all.
Result<IntegrityReport> check_database_file(const std::filesystem::path& db_path,
                                            IntegrityCheck depth = IntegrityCheck::kFull);
// Stops a check under way from another thread: cancel() interrupts SQLite where it is, within
// a few pages even in the page walk of PRAGMA integrity_check (one step of SQLite's virtual
// machine for the whole file, where no progress callback is asked), so a check of a large file
// never holds up a service that is stopping. Any thread; cancel() before the check starts makes
// it return at once.
class CheckCancel {
 public:
  void cancel();
  bool cancelled() const;

 private:
  friend struct CheckCancelScope;
  mutable std::mutex mutex_;
  bool cancelled_ = false;
  sqlite3* db_ = nullptr;  // the checking connection while a check runs
};

// The same, stopped by `cancel` (kRefused, "cancelled") once it is cancelled.
Result<IntegrityReport> check_database_file(const std::filesystem::path& db_path, IntegrityCheck depth,
                                            CheckCancel& cancel);

// What a service checks at start, in a moment at any size: the file is a SQLite database whose
// header and schema read (sqlite_schema and user_version), of a schema this gaugeloop knows.
// Reads a few pages, never the whole file: the whole check runs later, beside the service
// (check_database_file). Errors: kNotFound if there is no file; kStorage naming the file for
// one SQLite cannot read as a database.
Status check_database_header(const std::filesystem::path& db_path);

// "database <db> is damaged: <the first three problems> (and N more); ..." with what to do:
// stop gaugeloop, and restore the last sound backup. kStorage.
Error damaged_database(const std::filesystem::path& db_path, const std::vector<std::string>& problems);

// Copies the database at `db_path` (read-only; any schema version; safe while gaugeloop
// writes it: the copy is one consistent snapshot) to `dest` with SQLite's online backup API:
// into a temporary file beside `dest`, checked with integrity_check, flushed to disk, then
// renamed into place, so `dest` is either absent or a whole, sound copy. The copy gets the
// database file's permission bits (plus owner write). An existing `dest` is refused
// (kInvalidInput) unless `overwrite`; so is `dest` naming the database itself.
// Errors: kNotFound if `db_path` does not exist, kIo if `dest`'s directory is missing or not
// writable, kStorage if SQLite fails or the copy is not sound (then nothing is left behind).
Status backup_database_file(const std::filesystem::path& db_path, const std::filesystem::path& dest, bool overwrite);

// The schema version of the file (PRAGMA user_version), read-only; 0 for a file without a
// gaugeloop schema. For `gaugeloop db upgrade` and reports. Errors as check_database_file.
Result<int> database_schema_version(const std::filesystem::path& db_path);
// The schema version this gaugeloop writes: a file below it is upgraded when opened for writing.
int latest_database_schema_version();

// What the service does at start and `db upgrade` does: an existing file is checked whole
// (integrity_check; a damaged one is refused, kStorage, and nothing is upgraded), then opened
// for writing, which creates a new file and upgrades an older schema after backing it up
// (RunStore::schema_upgrade says whether it did, for the caller to tell).
Result<RunStore> open_checked_for_writing(const std::filesystem::path& db_path);

}  // namespace gaugeloop
