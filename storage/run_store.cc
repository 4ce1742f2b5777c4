// The run database: every measurement run, its analysis and its correction, kept in SQLite.
// This file opens the store and holds what its other files share; the methods are defined by
// subject in run_store_runs.cc, run_store_pushes.cc, run_store_pending.cc and
// run_store_events.cc, and records are checked in record_checks.cc.
#include "storage/run_store.h"

#include <cstdio>
#include <system_error>
#include <utility>

#include "storage/maintenance_internal.h"
#include "storage/migrations.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::Connection;
using storage_internal::Transaction;

namespace storage_internal {

Error damaged_run(const Connection& conn, std::int64_t run_id, const std::string& what) {
  return make_error(ErrorCode::kStorage, "run database " + conn.path.string() + ": run " + std::to_string(run_id) +
                                             " is damaged: " + what +
                                             "; the rows were changed outside gaugeloop, restore a backup");
}

Error run_not_found(const Connection& conn, std::int64_t run_id, const std::string& operation) {
  return make_error(ErrorCode::kNotFound, "cannot " + operation + ": run " + std::to_string(run_id) +
                                              " is not in run database " + conn.path.string());
}

Status require_run(Connection& conn, std::int64_t run_id, const std::string& operation) {
  Result<Statement> run = Statement::prepare(conn, "SELECT 1 FROM runs WHERE id = :run_id", operation);
  if (!run.ok()) return run.error();
  run->bind(":run_id", run_id);
  Result<bool> row = run->step();
  if (!row.ok()) return row.error();
  if (!*row) return run_not_found(conn, run_id, operation);
  return {};
}

void WhereClause::start_condition() { sql_ += sql_.empty() ? " WHERE " : " AND "; }

void WhereClause::add(std::string_view column_op, std::string value) {
  values_.push_back(std::move(value));
  start_condition();
  sql_ += std::string(column_op) + " :where" + std::to_string(values_.size());
}

void WhereClause::add_literal(const std::string& condition) {
  start_condition();
  sql_ += condition;
}

void WhereClause::bind(Statement& st) const {
  for (std::size_t i = 0; i < values_.size(); ++i) {
    st.bind(":where" + std::to_string(i + 1), std::string_view(values_[i]));
  }
}

namespace {

// Creates the parent directories, then opens the file as the writer (sqlite_db.h, kWriter);
// the schema is not touched.
Result<std::unique_ptr<Connection>> connect(const std::filesystem::path& db_path) {
  if (db_path != ":memory:" && db_path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(db_path.parent_path(), ec);
    if (ec) {
      return make_error(ErrorCode::kIo, "cannot create directory " + db_path.parent_path().string() +
                                            " for run database " + db_path.string() + ": " + ec.message() +
                                            "; check the --data-dir is writable");
    }
  }
  return Connection::open(db_path.string(), OpenMode::kWriter, db_path);
}

}  // namespace
}  // namespace storage_internal

RunStore::RunStore(std::unique_ptr<Connection> conn) : conn_(std::move(conn)) {}
RunStore::RunStore(RunStore&& other) noexcept = default;
RunStore& RunStore::operator=(RunStore&& other) noexcept = default;
RunStore::~RunStore() = default;

Result<RunStore> RunStore::open(const std::filesystem::path& db_path) {
  if (db_path.empty()) {
    return make_error(ErrorCode::kInvalidInput, "no run database path given; set --data-dir");
  }
  // Another program's file is refused before the writer's set-up (WAL mode) touches it.
  std::error_code ec;
  if (db_path != ":memory:" && std::filesystem::file_size(db_path, ec) > 0 && !ec) {
    Result<std::unique_ptr<Connection>> peek = storage_internal::connect_read_only(db_path);
    if (peek.ok()) {
      if (Status foreign = storage_internal::refuse_foreign_database(**peek); !foreign.ok()) return foreign.error();
    }
  }
  Result<std::unique_ptr<Connection>> conn = storage_internal::connect(db_path);
  if (!conn.ok()) return conn.error();
  Status backed_up = storage_internal::back_up_before_upgrade(**conn);
  if (!backed_up.ok()) return backed_up.error();
  Status migrated = storage_internal::apply_migrations(**conn);
  if (!migrated.ok()) return migrated.error();
  return RunStore(std::move(*conn));
}

const std::filesystem::path& RunStore::path() const { return conn_->path; }

Status RunStore::check_writable() {
  Result<Transaction> tx =
      Transaction::begin(*conn_, Transaction::Mode::kWrite, "take the write lock before measuring");
  if (!tx.ok()) return tx.error();
  return {};  // the transaction rolls back: nothing was written
}

std::string settings_hash(std::string_view text) {
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a 64-bit offset basis
  for (const char c : text) {
    h ^= static_cast<unsigned char>(c);
    h *= 1099511628211ull;  // FNV 64-bit prime
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

}  // namespace gaugeloop
