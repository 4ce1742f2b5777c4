// Opening the run database for reading only: on a file without write permission, in a
// read-only directory or mount, never creating, migrating or writing anything.
#include <unistd.h>

#include <cstdio>
#include <string>
#include <system_error>
#include <utility>

#include "storage/maintenance_internal.h"
#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {
namespace storage_internal {
namespace {

namespace fs = std::filesystem;

// A URI, so that mode=ro and immutable=1 can be given: "%", "?" and "#" and bytes outside
// printable ASCII in the path are percent-encoded (SQLite decodes them back to bytes).
std::string read_only_uri(const fs::path& db_path, bool immutable) {
  std::string uri = "file:";
  for (const char ch : fs::absolute(db_path).lexically_normal().string()) {
    const auto c = static_cast<unsigned char>(ch);
    if (c == '%' || c == '?' || c == '#' || c <= 0x20 || c >= 0x7f) {
      char hex[4];
      std::snprintf(hex, sizeof hex, "%%%02X", c);
      uri += hex;
    } else {
      uri += ch;
    }
  }
  return uri + (immutable ? "?mode=ro&immutable=1" : "?mode=ro");
}

bool exists_with_content(const fs::path& p) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(p, ec);
  return !ec && size > 0;
}

// True when no process can be changing the file, so SQLite may skip locking and the -shm
// (immutable). Invariant relied on: a writer in WAL mode keeps a -wal (and -shm) beside the
// file while it has it open; so with neither present, a file no one may write (no write
// bits: open() refuses it) or in a directory this process cannot write (a read-only mount,
// or another user's directory, where a plain read-only open fails for want of a -shm)
// stays as it is while we read. A race remains only with a writer starting in that
// directory during the read, and it changes the file itself only at a checkpoint.
bool nobody_is_writing(const fs::path& db_path) {
  const std::string db = db_path.string();
  std::error_code ec;
  if (exists_with_content(db + "-wal") || fs::exists(db + "-shm", ec)) return false;
  return has_no_write_bits(db_path) || ::access(directory_of(db_path).c_str(), W_OK) != 0;
}

}  // namespace

bool has_no_write_bits(const fs::path& db_path) {
  std::error_code ec;
  const fs::perms perms = fs::status(db_path, ec).permissions();
  constexpr fs::perms kWrite = fs::perms::owner_write | fs::perms::group_write | fs::perms::others_write;
  return !ec && fs::exists(db_path, ec) && (perms & kWrite) == fs::perms::none;
}

bool may_write(const fs::path& db_path) {
  return !has_no_write_bits(db_path) && ::access(db_path.c_str(), W_OK) == 0 &&
         ::access(directory_of(db_path).c_str(), W_OK) == 0;
}

Result<std::unique_ptr<Connection>> connect_read_only(const fs::path& db_path) {
  const std::string shown = db_path.string();
  if (db_path.empty() || shown == ":memory:") {
    return make_error(ErrorCode::kInvalidInput, "no run database file given to read; set --data-dir");
  }
  std::error_code ec;
  if (!fs::exists(db_path, ec)) {
    return make_error(ErrorCode::kNotFound, "no run database at " + shown + "; check --data-dir");
  }
  return Connection::open(read_only_uri(db_path, nobody_is_writing(db_path)), OpenMode::kReader, db_path);
}

namespace {

// What SQLite's "unable to open" means for a reader when the log holds changes.
Error unreadable_log(const Connection& conn, const Error& e) {
  const std::string shown = conn.path.string();
  if (!exists_with_content(shown + "-wal")) return e;
  return make_error(ErrorCode::kStorage,
                    "run database " + shown + ": cannot read it: its write-ahead log " + shown +
                        "-wal holds changes not yet in the file, and SQLite reads the log only with a " + shown +
                        "-shm, which is missing and cannot be created here; open the file once with write access "
                        "(`gaugeloop db upgrade --db " +
                        shown +
                        "` does, and changes nothing else if the schema is current), or copy it with its -wal to a "
                        "writable directory");
}

Status check_schema_for_reading(Connection& conn) {
  Result<int> version = schema_version_not_newer(conn);
  if (!version.ok()) {
    const bool cannot_open = (conn.last_error_code() & 0xff) == SQLITE_CANTOPEN;
    return cannot_open ? unreadable_log(conn, version.error()) : version.error();
  }
  const std::string shown = conn.path.string();
  if (*version == 0) {
    return make_error(ErrorCode::kStorage, "run database " + shown +
                                               " has no gaugeloop schema (user_version 0): it is not a gaugeloop "
                                               "run database, or nothing was ever stored in it; check --data-dir");
  }
  if (*version < latest_schema_version()) {
    return make_error(ErrorCode::kStorage,
                      "run database " + shown + " has schema version " + std::to_string(*version) +
                          ", older than this gaugeloop's (" + std::to_string(latest_schema_version()) +
                          "), and reading commands never upgrade it: run `gaugeloop db upgrade --db " + shown +
                          "` (it backs the file up first)");
  }
  return {};
}

}  // namespace
}  // namespace storage_internal

Result<RunStore> RunStore::open_read_only(const std::filesystem::path& db_path) {
  Result<std::unique_ptr<storage_internal::Connection>> conn = storage_internal::connect_read_only(db_path);
  if (!conn.ok()) return conn.error();
  if (Status s = storage_internal::check_schema_for_reading(**conn); !s.ok()) return s.error();
  return RunStore(std::move(*conn));
}

}  // namespace gaugeloop
