// The run database schema as an ordered list of migrations, versioned by PRAGMA user_version.
// Internal to storage/ (and its tests). docs/storage.md documents the schema for sqlite3 users.
#pragma once

#include <span>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop::storage_internal {

struct Connection;

// One step of the schema. Invariant: migrations() lists versions 1, 2, ... in order, and a
// released migration is never edited: a change to the schema is a new migration.
// Inside one write transaction: `sql`, then `convert` (if any: data the SQL cannot move, such
// as JSON text to compact BLOBs), then `sql_after`, then user_version is set.
struct Migration {
  int version;
  std::string_view description;
  std::string sql;  // one or more statements
  Status (*convert)(Connection& conn) = nullptr;
  std::string sql_after;
};

std::span<const Migration> migrations();

// The user_version of a database that has every migration applied.
int latest_schema_version();

// The SQL of version 1 alone, exactly as released: tests build version-1 databases with it.
std::string_view schema_v1_sql();

// Applies, in order, each migration newer than the database's user_version, each in its own
// write transaction that also sets user_version, so a crash leaves the schema at a whole
// version. Safe against another process migrating the same file at the same time.
// A database newer than latest_schema_version() is refused (kStorage).
Status apply_migrations(Connection& conn);

// Applies migrations up to and including `version` only (tests of the upgrade path).
Status apply_migrations_up_to(Connection& conn, int version);

// The database's user_version (0: no schema yet); a version newer than
// latest_schema_version() is refused (kStorage) as apply_migrations refuses it.
Result<int> schema_version_not_newer(Connection& conn);

// Refuses (kStorage, naming the file and its tables) a database gaugeloop did not write: no
// schema version (user_version 0) yet tables in it, another program's SQLite file. An empty
// database (a new file) is fine: gaugeloop creates its schema there; so, here, is a file that
// cannot be read as a database at all (the caller reports it as damaged).
Status refuse_foreign_database(Connection& conn);

}  // namespace gaugeloop::storage_internal
