// RAII over the SQLite C API for storage/: a connection, prepared statements, transactions.
// Internal: includes sqlite3.h, so only storage/*.cc (and storage tests) may include it.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop::storage_internal {

// How long a writer waits for another connection's write lock before SQLITE_BUSY.
inline constexpr int kBusyTimeoutMs = 5000;

// One open connection and the file it was opened on (for messages). Not movable: statements
// and transactions hold a pointer to it and must not outlive it.
struct Connection {
  sqlite3* db = nullptr;
  std::filesystem::path path;
  bool read_only = false;  // opened by connect_read_only (storage/maintenance_internal.h)
  // Set by back_up_before_upgrade: the version the file had and where it was copied first.
  int upgraded_from_version = 0;  // 0: the schema was not upgraded by this connection
  std::filesystem::path upgrade_backup;

  Connection() = default;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  ~Connection();  // closes db; every statement must be finalized by then
};

// A kStorage error for a failed SQLite call: "run database <path>: cannot <operation>:
// <SQLite's message>" and, for the codes a person can act on, what to do.
// `rc` is the (extended) result code of the failed call.
Error sqlite_error(const Connection& conn, std::string_view operation, int rc);

// Runs one or more statements that return no rows we need (DDL, PRAGMA, BEGIN/COMMIT).
Status exec(Connection& conn, const char* sql, std::string_view operation);

// A prepared statement, finalized in the destructor.
class Statement {
 public:
  // `operation` says what the statement is for, in the words of an error message
  // ("insert the run profile").
  static Result<Statement> prepare(Connection& conn, std::string_view sql, std::string_view operation);

  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&&) = delete;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement();

  // Parameters are 1-based. A failed bind is reported by the next step() or run().
  // Note SQLite stores a NaN double as NULL: callers validate before binding.
  void bind(int index, std::int64_t value);
  void bind(int index, int value);
  void bind(int index, double value);
  void bind(int index, std::string_view text);        // copied by SQLite
  void bind_blob(int index, std::string_view bytes);  // copied by SQLite; a BLOB, not TEXT
  void bind_null(int index);

  // true: a row is ready to read; false: the statement is done.
  Result<bool> step();
  // Steps a statement that returns no rows to completion.
  Status run();
  // Makes the statement ready to run again; bindings are kept until rebound.
  void reset();

  // Columns are 0-based; valid only after step() returned true.
  std::int64_t column_int64(int col) const;
  int column_int(int col) const;
  double column_double(int col) const;
  std::string column_text(int col) const;  // "" for NULL
  std::string column_blob(int col) const;  // the bytes; "" for NULL
  bool column_is_null(int col) const;

 private:
  Statement(Connection& conn, sqlite3_stmt* stmt, std::string_view operation);

  Connection* conn_;
  sqlite3_stmt* stmt_;
  std::string operation_;
  int bind_rc_ = SQLITE_OK;  // first failed bind, reported by step()
};

// A transaction on one connection. Rolls back in the destructor unless committed; the
// destructor never throws and ignores a rollback that fails (SQLite may already have
// rolled back after an I/O error).
class Transaction {
 public:
  enum class Mode {
    kRead,   // BEGIN DEFERRED: one consistent snapshot for several SELECTs
    kWrite,  // BEGIN IMMEDIATE: takes the write lock now (waiting up to the busy timeout),
             // so a writer never fails half way through for lack of the lock
  };

  static Result<Transaction> begin(Connection& conn, Mode mode, std::string_view operation);

  Transaction(Transaction&& other) noexcept;
  Transaction& operator=(Transaction&&) = delete;
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();

  // On failure the transaction is still open and the destructor rolls it back.
  Status commit();

 private:
  Transaction(Connection& conn, std::string_view operation);

  Connection* conn_;
  std::string operation_;
  bool active_ = true;
};

}  // namespace gaugeloop::storage_internal
