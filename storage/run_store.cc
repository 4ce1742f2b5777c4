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

namespace {

std::filesystem::path nc_normal_absolute(const std::filesystem::path& p) {
  std::error_code ec;
  std::filesystem::path a = std::filesystem::absolute(p, ec);
  return (ec ? p : a).lexically_normal();
}

bool nc_bare_name(std::string_view name) { return !name.empty() && name.find('/') == std::string_view::npos; }

// The NC directory in force: the one set, else the history's.
const std::filesystem::path& nc_dir_in_force(const Connection& conn) {
  return conn.nc_dir.empty() ? conn.nc_recorded : conn.nc_dir;
}

}  // namespace

std::string nc_key(const Connection& conn, std::string_view nc_file) {
  const std::filesystem::path& dir = nc_dir_in_force(conn);
  if (dir.empty() || nc_bare_name(nc_file)) return std::string(nc_file);
  const std::filesystem::path file = nc_normal_absolute(std::filesystem::path(nc_file));
  if (file.has_filename() && file.parent_path() == nc_normal_absolute(dir)) return file.filename().string();
  return std::string(nc_file);
}

std::string nc_path(const Connection& conn, std::string nc_key) {
  const std::filesystem::path& dir = nc_dir_in_force(conn);
  if (dir.empty() || !nc_bare_name(nc_key)) return nc_key;
  return (dir / nc_key).string();
}

void load_nc_directory(Connection& conn) {
  conn.nc_recorded.clear();
  Result<Statement> q = Statement::prepare(conn, "SELECT path FROM nc_directory WHERE id = 1", "read the NC directory");
  if (!q.ok()) return;  // before schema 18 (a reader does not migrate)
  Result<bool> row = q->step();
  if (row.ok() && *row) conn.nc_recorded = q->column<std::string>(0);
}

Status note_nc_directory(Connection& conn, std::string_view nc_file, const std::string& operation) {
  if (nc_file.empty() || nc_bare_name(nc_file)) return {};
  // What the file says now, inside the caller's transaction: a write rolled back earlier may
  // have left this connection believing a directory the file never kept.
  load_nc_directory(conn);
  const std::filesystem::path dir = std::filesystem::path(nc_file).parent_path();  // as given, as it is read back
  const std::filesystem::path dir_absolute = nc_normal_absolute(dir);
  const bool first = conn.nc_recorded.empty() && conn.nc_dir.empty();
  const bool moved = !conn.nc_dir.empty() && dir_absolute == nc_normal_absolute(conn.nc_dir) &&
                     (conn.nc_recorded.empty() || dir_absolute != nc_normal_absolute(conn.nc_recorded));
  if (!first && !moved) return {};
  Result<Statement> up = Statement::prepare(
      conn, "INSERT INTO nc_directory (id, path) VALUES (1, :path) ON CONFLICT (id) DO UPDATE SET path = :path",
      operation);
  if (!up.ok()) return up.error();
  up->bind(":path", dir.string());
  if (Status s = up->run(); !s.ok()) return s;
  conn.nc_recorded = dir;
  return {};
}

std::string nc_path_column(const Statement& s, int col) { return nc_path(s.connection(), s.column<std::string>(col)); }

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

RunStore::RunStore(std::unique_ptr<Connection> conn) : conn_(std::move(conn)) {
  storage_internal::load_nc_directory(*conn_);
}
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

void RunStore::set_nc_dir(const std::filesystem::path& nc_dir) { conn_->nc_dir = nc_dir; }

const std::filesystem::path& RunStore::nc_dir() const { return conn_->nc_dir; }

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
