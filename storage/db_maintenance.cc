// Keeping the run database file sound: integrity checks and online backups.
#include "storage/db_maintenance.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <ctime>
#include <utility>

#include "core/utc_time.h"
#include "storage/degree_blob.h"
#include "storage/maintenance_internal.h"
#include "storage/migrations.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {
namespace storage_internal {
namespace {

namespace fs = std::filesystem;

constexpr std::size_t kProblemsShown = 3;

bool is_damage(int rc) { return (rc & 0xff) == SQLITE_CORRUPT || (rc & 0xff) == SQLITE_NOTADB; }

// Runs `sql` and adds a problem for each row `describe` words (empty: not a problem). A file
// SQLite finds malformed or not a database while doing so is a problem, not an error.
template <typename Describe>
Status add_problems(Connection& conn, const char* sql, std::string_view operation, Describe describe,
                    std::vector<std::string>& problems) {
  auto damage_or_error = [&](const Error& e) -> Status {
    if (!is_damage(conn.last_error_code())) return e;
    problems.emplace_back(conn.last_error_message());
    return {};
  };
  Result<Statement> st = Statement::prepare(conn, sql, operation);
  if (!st.ok()) return damage_or_error(st.error());
  for (;;) {
    Result<bool> row = st->step();
    if (!row.ok()) return damage_or_error(row.error());
    if (!*row) return {};
    std::string problem = describe(*st);
    if (!problem.empty()) problems.push_back(std::move(problem));
  }
}

std::string page_problem(const Statement& st) {
  std::string text = st.column<std::string>(0);
  return text == "ok" ? std::string() : text;
}

// foreign_key_check rows: table, rowid (NULL for a table without rowid), parent, fk index.
std::string foreign_key_problem(const Statement& st) {
  const std::string row = st.column_is_null(1) ? "a row" : "row " + std::to_string(st.column<std::int64_t>(1));
  return st.column<std::string>(0) + " " + row + ": refers to a missing " + st.column<std::string>(2) + " row";
}

Error io_error(const std::string& what, int err) {
  return make_error(ErrorCode::kIo, what + ": " + std::strerror(err));
}

Status check_destination(const Connection& conn, const fs::path& dest, bool overwrite) {
  std::error_code ec;
  const std::string shown = dest.string();
  if (fs::is_directory(dest, ec)) {
    return make_error(ErrorCode::kInvalidInput, "backup " + shown + " is a directory; name the backup file");
  }
  if (fs::exists(dest, ec) && fs::equivalent(conn.path, dest, ec)) {
    return make_error(ErrorCode::kInvalidInput,
                      "backup " + shown + " is the database itself; name another file for the backup");
  }
  if (fs::exists(dest, ec) && !overwrite) {
    return make_error(ErrorCode::kInvalidInput,
                      "backup " + shown + " exists already; name another file, or pass --force to replace it");
  }
  if (!fs::is_directory(directory_of(dest), ec)) {
    return make_error(ErrorCode::kIo, "backup " + shown + ": directory " + directory_of(dest).string() +
                                          " does not exist; create it first");
  }
  return {};
}

// An empty file beside `dest`, with the database file's permission bits plus owner write.
Result<fs::path> make_temporary_beside(const Connection& conn, const fs::path& dest) {
  std::string pattern = dest.string() + ".tmp-XXXXXX";
  const int fd = ::mkstemp(pattern.data());
  if (fd < 0) {
    return io_error("backup " + dest.string() + ": cannot create a file in " + directory_of(dest).string() +
                        " (check it is writable)",
                    errno);
  }
  struct stat st {};
  if (::stat(conn.path.c_str(), &st) == 0) ::fchmod(fd, (st.st_mode & 07777) | S_IWUSR);
  ::close(fd);
  return fs::path(pattern);
}

Status copy_and_verify(Connection& source, const fs::path& tmp, const fs::path& dest) {
  // Closed at return: before the file is moved into place.
  Result<std::unique_ptr<Connection>> copy = Connection::open(tmp.string(), OpenMode::kBackupCopy, dest);
  if (!copy.ok()) return copy.error();
  if (Status s = copy_database(source, **copy, "copy " + source.path.string() + " into it"); !s.ok()) return s;
  Result<std::vector<std::string>> problems = find_problems(**copy, IntegrityCheck::kFull);
  if (!problems.ok()) return problems.error();
  if (problems->empty()) return {};
  Error damaged = damaged_database(source.path, *problems);
  damaged.message = "backup " + dest.string() + " not written, the copy is not sound: " + damaged.message;
  return damaged;
}

Status sync_path(const fs::path& p, const std::string& what) {
  const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return io_error(what + ": cannot open " + p.string() + " to flush it", errno);
  const int synced = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (synced != 0) return io_error(what + ": cannot flush " + p.string() + " to disk", err);
  return {};
}

// rename() replaces; link() refuses an existing name atomically, so a backup written meanwhile
// by someone else is never replaced without --force.
Status move_into_place(const fs::path& tmp, const fs::path& dest, bool overwrite) {
  const std::string what = "backup " + dest.string();
  if (overwrite) {
    if (::rename(tmp.c_str(), dest.c_str()) != 0) return io_error(what + ": cannot rename the copy into place", errno);
  } else {
    if (::link(tmp.c_str(), dest.c_str()) != 0) {
      if (errno == EEXIST) {
        return make_error(ErrorCode::kInvalidInput, what +
                                                        " appeared while copying; name another file, or pass "
                                                        "--force to replace it");
      }
      return io_error(what + ": cannot link the copy into place", errno);
    }
    ::unlink(tmp.c_str());
  }
  return sync_path(directory_of(dest), what);
}

void remove_leftovers(const fs::path& tmp) {
  std::error_code ec;
  for (const char* suffix : {"", "-journal", "-wal", "-shm"}) fs::remove(tmp.string() + suffix, ec);
}

// The first column of the one row `sql` returns, as a number.
Result<std::int64_t> query_number(Connection& conn, const char* sql, std::string_view operation) {
  Result<Statement> st = Statement::prepare(conn, sql, operation);
  if (!st.ok()) return st.error();
  Result<bool> row = st->step();
  if (!row.ok()) return row.error();
  return *row ? st->column<std::int64_t>(0) : 0;
}

// Whether the file holds a run or an event (the tables every record hangs on; events came
// with version 2). One that holds neither is a creation that was interrupted: nothing to keep.
Result<bool> holds_records(Connection& conn) {
  const std::string_view operation = "look for runs and events";
  Result<std::int64_t> has_events =
      query_number(conn, "SELECT count(*) FROM sqlite_schema WHERE name = 'events'", operation);
  if (!has_events.ok()) return has_events.error();
  const char* sql = *has_events != 0 ? "SELECT EXISTS (SELECT 1 FROM runs) OR EXISTS (SELECT 1 FROM events)"
                                     : "SELECT EXISTS (SELECT 1 FROM runs)";
  Result<std::int64_t> found = query_number(conn, sql, operation);
  if (!found.ok()) return found.error();
  return *found != 0;
}

// A text kept with the hash of what was written: `select`'s rows give the hash (column 0) and the
// text (column 1), then what `problem` names a mismatch by. Nothing when `present` (a count)
// finds no such table or column (a schema before it).
template <typename Problem>
Status add_hash_problems(Connection& conn, const char* present, const char* select, std::string_view operation,
                         Problem problem, std::vector<std::string>& problems) {
  Result<std::int64_t> there = query_number(conn, present, operation);
  if (!there.ok()) return there.error();
  if (*there == 0) return {};
  return add_problems(
      conn, select, operation,
      [&problem](const Statement& st) {
        return settings_hash(st.column<std::string>(1)) == st.column<std::string>(0) ? std::string() : problem(st);
      },
      problems);
}

// Every stored text against its hash, and every run's per-degree numbers against the checksum
// kept with them (schema 19 on; rows stored before have none): a page changed outside SQLite,
// which its own checks do not see in a text's or a BLOB's bytes, named by what it damaged.
Status add_checksum_problems(Connection& conn, std::vector<std::string>& problems) {
  // The program texts of the pushes (from version 3 on), the settings texts (version 2 on) and
  // the files written beside a table (main program, speed subprogram, Y table; version 20 on).
  if (Status s = add_hash_problems(
          conn, "SELECT count(*) FROM pragma_table_info('nc_pushes') WHERE name = 'program_text'",
          "SELECT program_hash, program_text, id, nc_file, table_version FROM nc_pushes "
          "WHERE program_text IS NOT NULL AND program_text <> '' AND program_hash IS NOT NULL AND program_hash <> ''",
          "check the pushed programs' hashes",
          [](const Statement& st) {
            return "push " + std::to_string(st.column<std::int64_t>(2)) + " (table version " +
                   std::to_string(st.column<std::int64_t>(4)) + " of " + st.column<std::string>(3) +
                   "): its program text does not match the hash stored with it";
          },
          problems);
      !s.ok()) {
    return s;
  }
  if (Status s = add_hash_problems(
          conn, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'settings'",
          "SELECT hash, text FROM settings", "check the settings texts against their hashes",
          [](const Statement& st) {
            return "settings " + st.column<std::string>(0) +
                   ": the text does not match the hash it is stored under (every run stored with these settings is "
                   "refused when read)";
          },
          problems);
      !s.ok()) {
    return s;
  }
  if (Status s = add_hash_problems(
          conn, "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = 'nc_push_files'",
          "SELECT f.hash, f.text, i.table_version, f.role, f.file FROM nc_push_files AS f"
          " JOIN nc_push_intents AS i ON i.id = f.intent_id WHERE f.text IS NOT NULL",
          "check the hashes of the files pushed beside the tables",
          [](const Statement& st) {
            return "the " + st.column<std::string>(3) + " file " + st.column<std::string>(4) + " of table version " +
                   std::to_string(st.column<std::int64_t>(2)) + ": its text does not match the hash stored with it";
          },
          problems);
      !s.ok()) {
    return s;
  }
  Result<std::int64_t> has = query_number(
      conn, "SELECT count(*) FROM pragma_table_info('run_tables') WHERE name = 'checksum'", "look for checksums");
  if (!has.ok() || *has == 0) return has.ok() ? Status{} : Status(has.error());
  const auto mismatch = [](const Statement& st, const char* what, bool same) {
    return same ? std::string()
                : "run " + std::to_string(st.column<std::int64_t>(0)) + ": " + what +
                      " do not match the checksum stored with them (a page changed outside SQLite)";
  };
  if (Status s = add_problems(
          conn, "SELECT run_id, amplifier_revolutions, lift, checksum FROM run_raw WHERE checksum IS NOT NULL",
          "check the raw revolutions' checksums",
          [&](const Statement& st) {
            return mismatch(st, "its raw revolutions (run_raw)",
                            st.column<std::int64_t>(3) == raw_checksum(st.column<std::string>(1), st.column_blob(2)));
          },
          problems);
      !s.ok()) {
    return s;
  }
  return add_problems(
      conn,
      "SELECT run_id, design_lift, mean_lift, spread, error, correction, residual_error, checksum FROM run_tables "
      "WHERE checksum IS NOT NULL",
      "check the per-degree tables' checksums",
      [&](const Statement& st) {
        return mismatch(st, "its profile and correction (run_tables)",
                        st.column<std::int64_t>(7) == tables_checksum_of_row(st, 1));
      },
      problems);
}

fs::path free_upgrade_backup_name(const fs::path& db, int version) {
  const std::string base = db.string() + ".schema" + std::to_string(version) + "-backup-" + utc_file_stamp();
  fs::path name = base;
  std::error_code ec;
  for (int n = 2; fs::exists(name, ec); ++n) name = base + "-" + std::to_string(n);
  return name;
}

}  // namespace

Result<std::unique_ptr<Connection>> connect_for_checking(const fs::path& db_path, bool& constraints_checked) {
  constraints_checked = may_write(db_path);
  if (!constraints_checked) return connect_read_only(db_path);
  return Connection::open(db_path.string(), OpenMode::kChecker, db_path);
}

Result<std::vector<std::string>> find_problems(Connection& conn, IntegrityCheck depth) {
  std::vector<std::string> problems;
  const char* pages = depth == IntegrityCheck::kQuick ? "PRAGMA quick_check" : "PRAGMA integrity_check";
  if (Status s = add_problems(conn, pages, "check the database pages", page_problem, problems); !s.ok()) {
    return s.error();
  }
  if (!problems.empty()) return problems;  // the keys of damaged pages would only repeat it
  if (Status s = add_problems(conn, "PRAGMA foreign_key_check", "check the references between tables",
                              foreign_key_problem, problems);
      !s.ok()) {
    return s.error();
  }
  if (depth == IntegrityCheck::kFull) {
    if (Status s = add_checksum_problems(conn, problems); !s.ok()) return s.error();
    // Commits lost before any writer noticed them (a writer raises the ids past them).
    Result<std::optional<LostCommits>> lost = find_lost_commits(conn);
    if (!lost.ok()) {
      problems.push_back(lost.error().message);
    } else if (*lost) {
      problems.push_back(lost_commits_text(conn.path, **lost));
    }
  }
  return problems;
}

Status backup_connection(Connection& conn, const fs::path& dest, bool overwrite) {
  if (Status s = check_destination(conn, dest, overwrite); !s.ok()) return s;
  Result<fs::path> tmp = make_temporary_beside(conn, dest);
  if (!tmp.ok()) return tmp.error();
  Status s = copy_and_verify(conn, *tmp, dest);
  if (s.ok()) s = sync_path(*tmp, "backup " + dest.string());
  if (s.ok()) s = move_into_place(*tmp, dest, overwrite);
  if (!s.ok()) remove_leftovers(*tmp);
  return s;
}

Status back_up_before_upgrade(Connection& conn) {
  if (conn.path == ":memory:") return {};
  Result<int> version = schema_version_not_newer(conn);
  if (!version.ok()) return version.error();
  if (*version == 0 || *version >= latest_schema_version()) return {};
  Result<bool> worth_keeping = holds_records(conn);
  if (!worth_keeping.ok()) return worth_keeping.error();
  if (!*worth_keeping) return {};
  const fs::path backup = free_upgrade_backup_name(conn.path, *version);
  if (Status s = backup_connection(conn, backup, false); !s.ok()) {
    Error e = s.error();
    e.message = "run database " + conn.path.string() + " not upgraded from schema version " + std::to_string(*version) +
                ": the backup made first failed: " + e.message;
    return e;
  }
  conn.upgraded_from_version = *version;
  conn.upgrade_backup = backup;
  return {};
}

}  // namespace storage_internal

Error damaged_database(const std::filesystem::path& db_path, const std::vector<std::string>& problems) {
  std::string listed;
  for (std::size_t i = 0; i < problems.size() && i < storage_internal::kProblemsShown; ++i) {
    listed += (i == 0 ? "" : "; ") + problems[i];
  }
  if (problems.size() > storage_internal::kProblemsShown) {
    listed += " (and " + std::to_string(problems.size() - storage_internal::kProblemsShown) + " more)";
  }
  return make_error(ErrorCode::kStorage,
                    "database " + db_path.string() + " is damaged: " + listed +
                        "; stop gaugeloop, move the damaged file aside and put the last sound backup in its place "
                        "(`gaugeloop db check --db BACKUP` checks one, `gaugeloop db backup FILE` makes one)");
}

void CheckCancel::cancel() {
  std::lock_guard<std::mutex> lock(mutex_);
  cancelled_ = true;
  if (db_ != nullptr) sqlite3_interrupt(db_);
}

bool CheckCancel::cancelled() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return cancelled_;
}

// The checking connection known to a CheckCancel while the check runs: detached before the
// connection closes, so cancel() never interrupts a closed handle. The interrupt also sets
// SQLite's flag for statements begun after it, until none runs: the progress handler catches
// a cancel between two statements.
struct CheckCancelScope {
  CheckCancelScope(CheckCancel* c, sqlite3* db) : cancel(c) {
    if (cancel == nullptr) return;
    std::lock_guard<std::mutex> lock(cancel->mutex_);
    cancel->db_ = db;
    sqlite3_progress_handler(db, 1000, ask, cancel);
  }
  ~CheckCancelScope() {
    if (cancel == nullptr) return;
    std::lock_guard<std::mutex> lock(cancel->mutex_);
    sqlite3_progress_handler(cancel->db_, 0, nullptr, nullptr);
    cancel->db_ = nullptr;
  }
  CheckCancelScope(const CheckCancelScope&) = delete;
  CheckCancelScope& operator=(const CheckCancelScope&) = delete;
  static int ask(void* c) { return static_cast<CheckCancel*>(c)->cancelled() ? 1 : 0; }
  CheckCancel* cancel;
};

namespace {

Result<IntegrityReport> check_file(const std::filesystem::path& db_path, IntegrityCheck depth, CheckCancel* cancel) {
  if (!std::filesystem::exists(db_path)) {
    return make_error(ErrorCode::kNotFound, "no run database at " + db_path.string());
  }
  // A device or a directory reads as an empty database; an empty file is one: neither is a
  // run database to call sound.
  std::error_code ec;
  if (!std::filesystem::is_regular_file(db_path, ec)) {
    return make_error(ErrorCode::kStorage, db_path.string() +
                                               " is not a regular file (a device, a directory?): no "
                                               "run database to check; give the database file");
  }
  if (std::filesystem::file_size(db_path, ec) == 0 && !ec) {
    return make_error(ErrorCode::kStorage,
                      db_path.string() + " is empty (0 bytes): no run database was ever written there");
  }
  IntegrityReport report;
  Result<std::unique_ptr<storage_internal::Connection>> conn =
      storage_internal::connect_for_checking(db_path, report.constraints_checked);
  if (!conn.ok()) return conn.error();
  if (Status foreign = storage_internal::refuse_foreign_database(**conn); !foreign.ok()) return foreign.error();
  Result<std::vector<std::string>> problems = [&] {
    const CheckCancelScope scope(cancel, (*conn)->db);
    if (cancel != nullptr && cancel->cancelled()) return Result<std::vector<std::string>>(std::vector<std::string>{});
    return storage_internal::find_problems(**conn, depth);
  }();
  if (cancel != nullptr && cancel->cancelled()) {
    return make_error(ErrorCode::kRefused, "the check of " + db_path.string() + " was cancelled");
  }
  if (!problems.ok()) return problems.error();
  report.problems = std::move(*problems);
  return report;
}

}  // namespace

Result<IntegrityReport> check_database_file(const std::filesystem::path& db_path, IntegrityCheck depth) {
  return check_file(db_path, depth, nullptr);
}

Result<IntegrityReport> check_database_file(const std::filesystem::path& db_path, IntegrityCheck depth,
                                            CheckCancel& cancel) {
  return check_file(db_path, depth, &cancel);
}

Status check_database_header(const std::filesystem::path& db_path) {
  if (!std::filesystem::exists(db_path)) {
    return make_error(ErrorCode::kNotFound, "no run database at " + db_path.string());
  }
  Result<std::unique_ptr<storage_internal::Connection>> conn = storage_internal::connect_read_only(db_path);
  if (!conn.ok()) return conn.error();
  Result<std::int64_t> tables =
      storage_internal::query_number(**conn, "SELECT count(*) FROM sqlite_schema", "read the database's schema");
  if (!tables.ok()) return tables.error();
  Result<int> version = storage_internal::schema_version_not_newer(**conn);
  if (!version.ok()) return version.error();
  return storage_internal::refuse_foreign_database(**conn);
}

Status backup_database_file(const std::filesystem::path& db_path, const std::filesystem::path& dest, bool overwrite) {
  Result<std::unique_ptr<storage_internal::Connection>> conn = storage_internal::connect_read_only(db_path);
  if (!conn.ok()) return conn.error();
  return storage_internal::backup_connection(**conn, dest, overwrite);
}

Result<int> database_schema_version(const std::filesystem::path& db_path) {
  Result<std::unique_ptr<storage_internal::Connection>> conn = storage_internal::connect_read_only(db_path);
  if (!conn.ok()) return conn.error();
  return storage_internal::schema_version_not_newer(**conn);
}

int latest_database_schema_version() { return storage_internal::latest_schema_version(); }

Status RunStore::check_integrity(IntegrityCheck depth) const {
  Result<std::vector<std::string>> problems = storage_internal::find_problems(*conn_, depth);
  if (!problems.ok()) return problems.error();
  if (problems->empty()) return {};
  return damaged_database(conn_->path, *problems);
}

std::optional<SchemaUpgrade> RunStore::schema_upgrade() const {
  if (conn_->upgraded_from_version == 0) return std::nullopt;
  return SchemaUpgrade{conn_->upgraded_from_version, conn_->upgrade_backup};
}

Result<RunStore> open_checked_for_writing(const std::filesystem::path& db_path) {
  if (std::filesystem::exists(db_path)) {
    Result<IntegrityReport> report = check_database_file(db_path, IntegrityCheck::kFull);
    if (!report) return report.error();
    if (!report->sound()) return damaged_database(db_path, report->problems);
  }
  return RunStore::open(db_path);
}

}  // namespace gaugeloop
