// Read-only connections, online backups and the backup before a schema upgrade, shared by
// RunStore and storage/db_maintenance.cc. Internal to storage/ (and its tests).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/atomic_file.h"
#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop::storage_internal {

struct Connection;

using gaugeloop::directory_of;  // core/atomic_file.h

// True for an existing file without any write permission bit (0444): frozen (see
// RunStore::open_read_only); false if it does not exist.
bool has_no_write_bits(const std::filesystem::path& db_path);

// True if this process may write the file and create files beside it (the -wal and -shm).
bool may_write(const std::filesystem::path& db_path);

// Opens an existing file with SQLITE_OPEN_READONLY (immutable when nothing can be writing it;
// see RunStore::open_read_only), whatever its schema. Nothing is read yet: SQLite reports a
// file it cannot read at the first statement. kNotFound if the file does not exist.
Result<std::unique_ptr<Connection>> connect_read_only(const std::filesystem::path& db_path);

// A connection for checking a file at any schema version: read-write (never creating the
// file, never writing it) where this process may write it, because SQLite leaves CHECK
// constraints out of a read-only connection's schema and so integrity_check and quick_check
// verify them only with write access; read-only (connect_read_only) elsewhere, and then
// `constraints_checked` is false.
Result<std::unique_ptr<Connection>> connect_for_checking(const std::filesystem::path& db_path,
                                                         bool& constraints_checked);

// The problems `depth`'s PRAGMA and foreign_key_check find (see IntegrityReport); a page
// SQLite finds malformed while checking is a problem too. kStorage if the check cannot run.
Result<std::vector<std::string>> find_problems(Connection& conn, IntegrityCheck depth);

// Copies conn's main database to `dest` as backup_database_file describes.
Status backup_connection(Connection& conn, const std::filesystem::path& dest, bool overwrite);

// Before migrating: a file at schema version 1..latest-1 that holds a run or an event is
// backed up to "<path>.schema<N>-backup-<UTC>" and conn.upgraded_from_version and
// conn.upgrade_backup are set; a new file (version 0, or a creation interrupted before any
// record), an up-to-date one and ":memory:" are left alone.
Status back_up_before_upgrade(Connection& conn);

}  // namespace gaugeloop::storage_internal
