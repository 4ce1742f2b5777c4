// RAII over the SQLite C API for storage/: a connection that opens and configures itself,
// prepared statements bound by name or in order and read with typed columns, transactions.
// Internal: includes sqlite3.h, so only storage/*.cc (and tests) may include it; sqlite_db.cc
// is the only file of storage/ that calls the SQLite C API.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "core/result.h"

namespace gaugeloop::storage_internal {

// How long a writer waits for another connection's write lock before SQLITE_BUSY.
inline constexpr int kBusyTimeoutMs = 5000;

// How Connection::open opens a file and sets the connection up.
enum class OpenMode {
  // RunStore::open: read-write, creating the file. Refused if SQLite would open it read-only
  // or it has no write permission bits. Busy timeout, foreign keys on, WAL journal (except
  // in memory); synchronous stays at its default, FULL, so a committed run survives a power cut.
  kWriter,
  // Checking a file at any schema version: read-write on an existing file, so that SQLite
  // loads the CHECK constraints; writes nothing. Busy timeout.
  kChecker,
  // Reading only, through a "file:...?mode=ro" URI (the caller builds it). Busy timeout, for
  // the only time a reader waits: while the -wal is recovered after a crash.
  kReader,
  // The empty file a backup is copied into: read-write, existing. Nobody else has it open, so
  // no busy timeout.
  kBackupCopy,
};

// One open connection and the file it was opened on (for messages). Not movable: statements
// and transactions hold a pointer to it and must not outlive it.
// `db` is public for the tests that build an old schema by hand on a raw sqlite3_open.
struct Connection {
  sqlite3* db = nullptr;
  std::filesystem::path path;
  bool read_only = false;  // opened as OpenMode::kReader: errors get the reader's hints
  // Set by back_up_before_upgrade: the version the file had and where it was copied first.
  int upgraded_from_version = 0;  // 0: the schema was not upgraded by this connection
  std::filesystem::path upgrade_backup;
  // The NC directory in force (RunStore::set_nc_dir): a program in it is stored by its name
  // alone and read back inside it. Empty: names are read back as stored.
  std::filesystem::path nc_dir;
  // The directory the history's pushes went to (table nc_directory), as its first push gave
  // it: the NC directory when none is set. Empty: none recorded.
  std::filesystem::path nc_recorded;

  Connection() = default;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  ~Connection();  // closes db; every statement must be finalized by then

  // Opens `file` (a path, or for kReader a URI) as `mode` describes; `shown` names it in
  // messages (and becomes `path`). A connection with a NOMUTEX handle: one thread only.
  // Errors: kStorage, naming `shown`, SQLite's reason and what to do.
  static Result<std::unique_ptr<Connection>> open(const std::string& file, OpenMode mode,
                                                  const std::filesystem::path& shown);

  // The rowid of the last row this connection inserted.
  std::int64_t last_insert_rowid() const;
  // Rows changed by the last INSERT, UPDATE or DELETE on this connection.
  std::int64_t changes() const;
  // The extended result code and message of the last failed call on this connection.
  int last_error_code() const;
  std::string last_error_message() const;
};

// A kStorage error for a failed SQLite call: "run database <path>: cannot <operation>:
// <SQLite's message>" and, for the codes a person can act on, what to do.
// `rc` is the (extended) result code of the failed call.
Error sqlite_error(const Connection& conn, std::string_view operation, int rc);

// Runs one or more statements that return no rows we need (DDL, PRAGMA, BEGIN/COMMIT).
Status exec(Connection& conn, const char* sql, std::string_view operation);

// Copies every page of `from`'s main database into `to`'s, in one step under one read lock:
// one consistent snapshot, and in WAL mode a writer is never blocked by it. Errors name `to`.
Status copy_database(Connection& from, Connection& to, std::string_view operation);

// A value bound as a BLOB, not TEXT. The bytes are copied by SQLite.
struct Blob {
  std::string_view bytes;
};

// A prepared statement, finalized in the destructor.
//
// Parameters are bound by name (":run_id", as written in the SQL) or by 1-based index, or all
// in order with bind_all. A std::optional binds NULL when empty; std::nullopt binds NULL.
// Text is copied by SQLite. Note SQLite stores a NaN double as NULL: callers validate before
// binding. A failed bind (an unknown name, a value too big) is reported by the next step() or
// run(), naming the parameter.
//
// Columns are 0-based and read with column<T>(), valid only after step() returned true. T is
// one of std::int64_t, int, double, bool, std::string (NULL reads as "") or std::optional of
// one of those (NULL reads as empty); any other T does not compile. column_blob() reads bytes.
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

  void bind(int index, std::int64_t value);
  void bind(int index, int value);
  void bind(int index, double value);
  void bind(int index, std::string_view text);
  void bind(int index, Blob bytes);
  void bind(int index, std::nullopt_t);
  template <typename T>
  void bind(int index, const std::optional<T>& value) {
    if (value) {
      bind(index, *value);
    } else {
      bind(index, std::nullopt);
    }
  }
  // By name; the name includes its ':'.
  template <typename T>
  void bind(std::string_view name, const T& value) {
    bind(parameter_index(name), value);
  }
  // Binds ?1, ?2, ... to the values in order.
  template <typename... Values>
  void bind_all(const Values&... values) {
    int index = 0;
    (bind(++index, values), ...);
  }

  // true: a row is ready to read; false: the statement is done.
  Result<bool> step();
  // Steps a statement that returns no rows to completion.
  Status run();
  // Makes the statement ready to run again; bindings are kept until rebound.
  void reset();

  // Every remaining row, each made by `read_row(const Statement&)`.
  template <typename ReadRow>
  auto collect(ReadRow read_row) -> Result<std::vector<std::invoke_result_t<ReadRow&, const Statement&>>> {
    std::vector<std::invoke_result_t<ReadRow&, const Statement&>> rows;
    for (;;) {
      Result<bool> row = step();
      if (!row.ok()) return row.error();
      if (!*row) return rows;
      rows.push_back(read_row(*this));
    }
  }
  // The next row made by `read_row`, or empty if there is none.
  template <typename ReadRow>
  auto first(ReadRow read_row) -> Result<std::optional<std::invoke_result_t<ReadRow&, const Statement&>>> {
    using Row = std::invoke_result_t<ReadRow&, const Statement&>;
    Result<bool> row = step();
    if (!row.ok()) return row.error();
    if (!*row) return std::optional<Row>();
    return std::optional<Row>(read_row(*this));
  }

  template <typename T>
  T column(int col) const {
    if constexpr (is_optional<T>::value) {
      using Value = typename T::value_type;
      if (column_is_null(col)) return std::nullopt;
      return T(column<Value>(col));
    } else {
      static_assert(std::is_same_v<T, std::int64_t> || std::is_same_v<T, int> || std::is_same_v<T, double> ||
                        std::is_same_v<T, bool> || std::is_same_v<T, std::string>,
                    "column<T>: T is std::int64_t, int, double, bool, std::string or an optional of one");
      if constexpr (std::is_same_v<T, std::int64_t>) return column_int64(col);
      if constexpr (std::is_same_v<T, int>) return column_int(col);
      if constexpr (std::is_same_v<T, double>) return column_double(col);
      if constexpr (std::is_same_v<T, bool>) return column_int64(col) != 0;
      if constexpr (std::is_same_v<T, std::string>) return column_text(col);
    }
  }
  std::string column_blob(int col) const;  // the bytes; "" for NULL
  bool column_is_null(int col) const;
  // The connection the statement was prepared on.
  const Connection& connection() const { return *conn_; }

 private:
  template <typename T>
  struct is_optional : std::false_type {};
  template <typename T>
  struct is_optional<std::optional<T>> : std::true_type {};

  Statement(Connection& conn, sqlite3_stmt* stmt, std::string_view operation);

  // 0 for a name the statement does not have; the failure is kept for step().
  int parameter_index(std::string_view name);
  void note_bind(int rc, int index);

  std::int64_t column_int64(int col) const;
  int column_int(int col) const;
  double column_double(int col) const;
  std::string column_text(int col) const;  // "" for NULL

  Connection* conn_;
  sqlite3_stmt* stmt_;
  std::string operation_;
  int bind_rc_ = SQLITE_OK;  // first failed bind, reported by step()
  std::string bind_failed_;  // which parameter it was, in words
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
