// RAII over the SQLite C API for storage/: a connection, prepared statements, transactions.
#include "storage/sqlite_db.h"

#include <climits>
#include <utility>

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
      bind_rc_(other.bind_rc_) {}

Statement::~Statement() { sqlite3_finalize(stmt_); }  // no-op on nullptr

void Statement::bind(int index, std::int64_t value) {
  const int rc = sqlite3_bind_int64(stmt_, index, value);
  if (bind_rc_ == SQLITE_OK) bind_rc_ = rc;
}

void Statement::bind(int index, int value) {
  const int rc = sqlite3_bind_int(stmt_, index, value);
  if (bind_rc_ == SQLITE_OK) bind_rc_ = rc;
}

void Statement::bind(int index, double value) {
  const int rc = sqlite3_bind_double(stmt_, index, value);
  if (bind_rc_ == SQLITE_OK) bind_rc_ = rc;
}

void Statement::bind(int index, std::string_view text) {
  int rc = SQLITE_TOOBIG;
  if (text.size() <= static_cast<std::size_t>(INT_MAX)) {
    // A non-null pointer even for "", so the value is an empty text, not NULL.
    rc = sqlite3_bind_text(stmt_, index, text.empty() ? "" : text.data(), static_cast<int>(text.size()),
                           SQLITE_TRANSIENT);
  }
  if (bind_rc_ == SQLITE_OK) bind_rc_ = rc;
}

void Statement::bind_blob(int index, std::string_view bytes) {
  int rc = SQLITE_TOOBIG;
  if (bytes.size() <= static_cast<std::size_t>(INT_MAX)) {
    // A non-null pointer even when empty, so the value is an empty BLOB, not NULL.
    rc = sqlite3_bind_blob(stmt_, index, bytes.empty() ? "" : bytes.data(), static_cast<int>(bytes.size()),
                           SQLITE_TRANSIENT);
  }
  if (bind_rc_ == SQLITE_OK) bind_rc_ = rc;
}

void Statement::bind_null(int index) {
  const int rc = sqlite3_bind_null(stmt_, index);
  if (bind_rc_ == SQLITE_OK) bind_rc_ = rc;
}

Result<bool> Statement::step() {
  if (bind_rc_ != SQLITE_OK) {
    // sqlite3_errmsg may describe an older failure; the code is the reliable part here.
    return make_error(ErrorCode::kStorage, "run database " + conn_->path.string() + ": cannot " + operation_ +
                                               ": binding a parameter failed: " + sqlite3_errstr(bind_rc_));
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
