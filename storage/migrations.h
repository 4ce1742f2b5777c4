// The run database schema as an ordered list of migrations, versioned by PRAGMA user_version.
// Internal to storage/ (and its tests).
#pragma once

#include <span>
#include <string_view>

#include "core/result.h"

namespace gaugeloop::storage_internal {

struct Connection;

// One step of the schema. Invariant: migrations() lists versions 1, 2, ... in order, and a
// released migration is never edited: a change to the schema is a new migration.
struct Migration {
  int version;
  std::string_view description;
  std::string_view sql;  // one or more statements, run inside the migration's transaction
};

std::span<const Migration> migrations();

// The user_version of a database that has every migration applied.
int latest_schema_version();

// Applies, in order, each migration newer than the database's user_version, each in its own
// write transaction that also sets user_version, so a crash leaves the schema at a whole
// version. Safe against another process migrating the same file at the same time.
// A database newer than latest_schema_version() is refused (kStorage).
Status apply_migrations(Connection& conn);

}  // namespace gaugeloop::storage_internal
