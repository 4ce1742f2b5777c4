// RAII over the SQLite C API for storage/: a connection, prepared statements, transactions.
// The only file of storage/ that calls the SQLite C API.
#include "storage/sqlite_db.h"

#include <climits>
#include <utility>

#include "storage/maintenance_internal.h"

namespace gaugeloop::storage_internal {
namespace {

// What a person can do about a failure, by primary result code; empty if nothing useful.
std::string_view hint_for(int rc) {
  switch (rc & 0xff) {
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      return "another connection held the write lock for more than 5 s; "
             "look for a stuck gaugeloop or sqlite3 session on this file";
    case SQLITE_CANTOPEN:
    case SQLITE_READONLY:
    case SQLITE_PERM:
      return "check the --data-dir and the database file are writable by this user";
    case SQLITE_FULL:
      return "the disk is full; free space where the --data-dir lives";
    case SQLITE_IOERR:
      return "the operating system failed a read or write; check the disk and the mount";
    case SQLITE_CORRUPT:
    case SQLITE_NOTADB:
      return "the file is damaged or not a gaugeloop run database; "
             "restore a backup or point --data-dir elsewhere";
    default:
      return {};
  }
}

// The same for a connection opened read-only (see connect_read_only).
std::string_view read_only_hint_for(int rc) {
  switch (rc & 0xff) {
    case SQLITE_READONLY:
      return "the database was opened for reading only";
    case SQLITE_CANTOPEN:
    case SQLITE_PERM:
      return "check the file and its directory are readable by this user";
    default:
      return hint_for(rc);
  }
}

}  // namespace

Connection::~Connection() {
  // sqlite3_close_v2 so that a statement leaked by a bug delays the close, not fails it.
  if (db != nullptr) sqlite3_close_v2(db);
}

namespace {

int open_flags(OpenMode mode) {
  // NOMUTEX: a connection is used by one thread only (see RunStore). EXRESCODE: extended
  // result codes, which the messages and is-it-damage checks read.
  const int common = SQLITE_OPEN_NOMUTEX | SQLITE_OPEN_EXRESCODE;
  switch (mode) {
    case OpenMode::kWriter:
      return common | SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
    case OpenMode::kChecker:
    case OpenMode::kBackupCopy:
      return common | SQLITE_OPEN_READWRITE;
    case OpenMode::kReader:
      return common | SQLITE_OPEN_READONLY | SQLITE_OPEN_URI;
  }
  return common | SQLITE_OPEN_READONLY;
}

std::string_view open_operation(OpenMode mode) {
  switch (mode) {
    case OpenMode::kChecker:
      return "open the file to check it";
    case OpenMode::kReader:
      return "open the file for reading";
    case OpenMode::kBackupCopy:
      return "create the backup";
    case OpenMode::kWriter:
      break;
  }
  return "open the file";
}

// The writer's set-up after the file is open: it must be writable, and in WAL mode.
Status configure_writer(Connection& conn) {
  const std::string shown = conn.path.string();
  // SQLite silently falls back to read-only when the file exists but is not writable; we
  // would only find out at the first insert, after a whole measurement. A file without write
  // bits is refused for root too: readers open it immutable (RunStore::open_read_only).
  if (sqlite3_db_readonly(conn.db, "main") == 1 || has_no_write_bits(conn.path)) {
    return make_error(ErrorCode::kStorage, "cannot open run database " + shown +
                                               " for writing: the file is read-only; check the file and the "
                                               "--data-dir are writable by this user");
  }
  sqlite3_busy_timeout(conn.db, kBusyTimeoutMs);
  Status s = exec(conn, "PRAGMA foreign_keys = ON", "enable foreign keys");
  if (!s.ok()) return s;
  Result<Statement> wal = Statement::prepare(conn, "PRAGMA journal_mode = WAL", "switch to WAL journal mode");
  if (!wal.ok()) return wal.error();
  Result<std::optional<std::string>> mode = wal->first([](const Statement& st) { return st.column<std::string>(0); });
  if (!mode.ok()) return mode.error();
  const std::string journal = mode->value_or(std::string());
  if (conn.path != ":memory:" && journal != "wal") {
    return make_error(ErrorCode::kStorage, "run database " + shown + ": cannot switch to WAL journal mode (it stays '" +
                                               journal +
                                               "'), so readers would block the writer; keep the --data-dir on a "
                                               "local file system");
  }
  return {};
}

}  // namespace

Result<std::unique_ptr<Connection>> Connection::open(const std::string& file, OpenMode mode,
                                                     const std::filesystem::path& shown) {
  auto conn = std::make_unique<Connection>();
  conn->path = shown;
  conn->read_only = mode == OpenMode::kReader;
  const int rc = sqlite3_open_v2(file.c_str(), &conn->db, open_flags(mode), nullptr);
  if (rc != SQLITE_OK) {
    if (mode != OpenMode::kWriter) return sqlite_error(*conn, open_operation(mode), rc);
    const std::string reason = conn->db != nullptr ? sqlite3_errmsg(conn->db) : sqlite3_errstr(rc);
    return make_error(ErrorCode::kStorage, "cannot open run database " + shown.string() + ": " + reason +
                                               "; check the --data-dir is writable");
  }
  if (mode == OpenMode::kWriter) {
    if (Status s = configure_writer(*conn); !s.ok()) return s.error();
  } else if (mode != OpenMode::kBackupCopy) {
    sqlite3_busy_timeout(conn->db, kBusyTimeoutMs);
  }
  // Up to 8 MiB of pages kept between statements (SQLite's default is 2 MiB, fewer pages than a
  // trend of 200 runs with their characteristics touches at a million runs, so each request
  // read them again from the file). Filled only as pages are read; kept while the file does not
  // change. A hint: it reads the schema, so a file that is not a database fails it, and the
  // caller's first statement reports that as it would have.
  (void)sqlite3_exec(conn->db, "PRAGMA cache_size = -8192", nullptr, nullptr, nullptr);
  return conn;
}

std::int64_t Connection::last_insert_rowid() const { return sqlite3_last_insert_rowid(db); }

std::int64_t Connection::changes() const { return sqlite3_changes64(db); }

int Connection::last_error_code() const { return sqlite3_extended_errcode(db); }

std::string Connection::last_error_message() const { return sqlite3_errmsg(db); }

Error sqlite_error(const Connection& conn, std::string_view operation, int rc) {
  std::string message = "run database " + conn.path.string() + ": cannot ";
  message += operation;
  message += ": ";
  // sqlite3_errmsg describes the most recent failure on the connection, which is the one
  // that produced rc as long as callers build the error straight after the failed call.
  message += conn.db != nullptr ? sqlite3_errmsg(conn.db) : sqlite3_errstr(rc);
  const std::string_view hint = conn.read_only ? read_only_hint_for(rc) : hint_for(rc);
  if (!hint.empty()) {
    message += "; ";
    message += hint;
  }
  return make_error(ErrorCode::kStorage, std::move(message));
}

Status exec(Connection& conn, const char* sql, std::string_view operation) {
  const int rc = sqlite3_exec(conn.db, sql, nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK) return sqlite_error(conn, operation, rc);
  return {};
}

Status copy_database(Connection& from, Connection& to, std::string_view operation) {
  sqlite3_backup* backup = sqlite3_backup_init(to.db, "main", from.db, "main");
  if (backup == nullptr) return sqlite_error(to, operation, sqlite3_extended_errcode(to.db));
  const int rc = sqlite3_backup_step(backup, -1);
  sqlite3_backup_finish(backup);
  if (rc != SQLITE_DONE) return sqlite_error(to, operation, rc);
  return {};
}

// ---- Statement ----

Result<Statement> Statement::prepare(Connection& conn, std::string_view sql, std::string_view operation) {
  sqlite3_stmt* stmt = nullptr;
  if (sql.size() > static_cast<std::size_t>(INT_MAX)) {
    return sqlite_error(conn, operation, SQLITE_TOOBIG);
  }
  const int rc = sqlite3_prepare_v2(conn.db, sql.data(), static_cast<int>(sql.size()), &stmt, nullptr);
  if (rc != SQLITE_OK) {
    sqlite3_finalize(stmt);
    return sqlite_error(conn, operation, rc);
  }
  return Statement(conn, stmt, operation);
}

Statement::Statement(Connection& conn, sqlite3_stmt* stmt, std::string_view operation)
    : conn_(&conn), stmt_(stmt), operation_(operation) {}

Statement::Statement(Statement&& other) noexcept
    : conn_(other.conn_),
      stmt_(std::exchange(other.stmt_, nullptr)),
      operation_(std::move(other.operation_)),
      bind_rc_(other.bind_rc_),
      bind_failed_(std::move(other.bind_failed_)) {}

Statement::~Statement() { sqlite3_finalize(stmt_); }  // no-op on nullptr

void Statement::note_bind(int rc, int index) {
  if (bind_rc_ != SQLITE_OK || rc == SQLITE_OK) return;
  bind_rc_ = rc;
  if (bind_failed_.empty()) {
    const char* name = sqlite3_bind_parameter_name(stmt_, index);
    bind_failed_ = name != nullptr ? std::string(name) : "?" + std::to_string(index);
  }
}

int Statement::parameter_index(std::string_view name) {
  const std::string terminated(name);
  const int index = sqlite3_bind_parameter_index(stmt_, terminated.c_str());
  if (index == 0 && bind_rc_ == SQLITE_OK) {
    // A programmer's mistake, reported by step() like any other failed bind.
    bind_rc_ = SQLITE_RANGE;
    bind_failed_ = terminated + " (the statement has no such parameter)";
  }
  return index;
}

void Statement::bind(int index, std::int64_t value) { note_bind(sqlite3_bind_int64(stmt_, index, value), index); }

void Statement::bind(int index, int value) { note_bind(sqlite3_bind_int(stmt_, index, value), index); }

void Statement::bind(int index, double value) { note_bind(sqlite3_bind_double(stmt_, index, value), index); }

void Statement::bind(int index, std::string_view text) {
  int rc = SQLITE_TOOBIG;
  if (text.size() <= static_cast<std::size_t>(INT_MAX)) {
    // A non-null pointer even for "", so the value is an empty text, not NULL.
    rc = sqlite3_bind_text(stmt_, index, text.empty() ? "" : text.data(), static_cast<int>(text.size()),
                           SQLITE_TRANSIENT);
  }
  note_bind(rc, index);
}

void Statement::bind(int index, Blob blob) {
  int rc = SQLITE_TOOBIG;
  if (blob.bytes.size() <= static_cast<std::size_t>(INT_MAX)) {
    // A non-null pointer even when empty, so the value is an empty BLOB, not NULL.
    rc = sqlite3_bind_blob(stmt_, index, blob.bytes.empty() ? "" : blob.bytes.data(),
                           static_cast<int>(blob.bytes.size()), SQLITE_TRANSIENT);
  }
  note_bind(rc, index);
}

void Statement::bind(int index, std::nullopt_t) { note_bind(sqlite3_bind_null(stmt_, index), index); }

Result<bool> Statement::step() {
  if (bind_rc_ != SQLITE_OK) {
    // sqlite3_errmsg may describe an older failure; the code is the reliable part here.
    return make_error(ErrorCode::kStorage, "run database " + conn_->path.string() + ": cannot " + operation_ +
                                               ": binding parameter " + bind_failed_ +
                                               " failed: " + sqlite3_errstr(bind_rc_));
  }
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  return sqlite_error(*conn_, operation_, rc);
}

Status Statement::run() {
  for (;;) {
    Result<bool> row = step();
    if (!row.ok()) return row.error();
    if (!*row) return {};
  }
}

void Statement::reset() {
  // The result of sqlite3_reset repeats the last step's error, already reported by step().
  sqlite3_reset(stmt_);
}

std::int64_t Statement::column_int64(int col) const { return sqlite3_column_int64(stmt_, col); }

int Statement::column_int(int col) const { return sqlite3_column_int(stmt_, col); }

double Statement::column_double(int col) const { return sqlite3_column_double(stmt_, col); }

std::string Statement::column_text(int col) const {
  const unsigned char* text = sqlite3_column_text(stmt_, col);
  if (text == nullptr) return {};
  const int size = sqlite3_column_bytes(stmt_, col);
  return std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(size));
}

std::string Statement::column_blob(int col) const {
  const void* bytes = sqlite3_column_blob(stmt_, col);
  if (bytes == nullptr) return {};
  const int size = sqlite3_column_bytes(stmt_, col);
  return std::string(static_cast<const char*>(bytes), static_cast<std::size_t>(size));
}

bool Statement::column_is_null(int col) const { return sqlite3_column_type(stmt_, col) == SQLITE_NULL; }

// ---- Transaction ----

Result<Transaction> Transaction::begin(Connection& conn, Mode mode, std::string_view operation) {
  const char* sql = mode == Mode::kWrite ? "BEGIN IMMEDIATE" : "BEGIN DEFERRED";
  Status began = exec(conn, sql, operation);
  if (!began.ok()) return began.error();
  return Transaction(conn, operation);
}

Transaction::Transaction(Connection& conn, std::string_view operation) : conn_(&conn), operation_(operation) {}

Transaction::Transaction(Transaction&& other) noexcept
    : conn_(other.conn_), operation_(std::move(other.operation_)), active_(std::exchange(other.active_, false)) {}

Transaction::~Transaction() {
  // After some errors (SQLITE_FULL, SQLITE_IOERR, ...) SQLite has already rolled back and
  // the connection is in autocommit mode again; a second ROLLBACK would only fail.
  if (active_ && sqlite3_get_autocommit(conn_->db) == 0) {
    sqlite3_exec(conn_->db, "ROLLBACK", nullptr, nullptr, nullptr);
  }
}

Status Transaction::commit() {
  Status committed = exec(*conn_, "COMMIT", operation_);
  if (committed.ok()) active_ = false;
  return committed;
}

}  // namespace gaugeloop::storage_internal
