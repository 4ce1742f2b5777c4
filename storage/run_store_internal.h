// What the files of RunStore (run_store*.cc) share: row readers, WHERE clauses, the steps of
// recording a push inside a caller's transaction. Internal to storage/.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"

namespace gaugeloop::storage_internal {

// tables_checksum of the row's run_tables BLOBs, read from column `first` on in their order
// (design_lift, mean_lift, spread, error, correction, residual_error; NULL residual: absent).
std::int64_t tables_checksum_of_row(const Statement& st, int first);

// NULL for empty text: the columns that say "not recorded" with NULL.
inline std::optional<std::string_view> text_or_null(std::string_view text) {
  if (text.empty()) return std::nullopt;
  return text;
}

// An NC program as the history names it: a file in the NC directory in force (conn.nc_dir) by
// its name alone, so that a data directory copied, moved or restored from a backup keeps its
// history for the directory it is used with; any other path as given.
std::string nc_key(const Connection& conn, std::string_view nc_file);
// The path of a program the history names: a bare name inside the NC directory in force (as
// stored when none is set); a path as stored.
std::string nc_path(const Connection& conn, std::string nc_key);
// nc_path of column `col` of the statement's row.
std::string nc_path_column(const Statement& s, int col);
// Reads the directory the history's pushes went to into conn.nc_recorded (none: a history
// from before schema 18 opened read-only, or nothing pushed yet).
void load_nc_directory(Connection& conn);
// Before a program `nc_file` is written into the history (a push, its intent, a pending table,
// a gear run), inside the caller's write transaction: its directory becomes the history's when
// it is the NC directory in force and the history recorded another (the data directory was
// moved), or when the history recorded none.
Status note_nc_directory(Connection& conn, std::string_view nc_file, const std::string& operation);

// <db>.ids against the database's sequences (RunStore::find_lost_commits).
Result<std::optional<LostCommits>> find_lost_commits(Connection& conn);

// kStorage: run `run_id` has rows that contradict each other or are missing.
Error damaged_run(const Connection& conn, std::int64_t run_id, const std::string& what);

// kNotFound "cannot <operation>: run <id> is not in run database <file>" unless the run is stored.
Status require_run(Connection& conn, std::int64_t run_id, const std::string& operation);
Error run_not_found(const Connection& conn, std::int64_t run_id, const std::string& operation);

// The WHERE clause of a list query, from the filters it sets; text values are bound by name.
class WhereClause {
 public:
  // Adds "<column_op> :where<N>", bound to `value` by bind(): add("r.part =", q.part).
  void add(std::string_view column_op, std::string value);
  // Adds a condition without a parameter: "r.lobe = 3".
  void add_literal(const std::string& condition);
  // " WHERE a AND b", or "" without conditions.
  const std::string& sql() const { return sql_; }
  void bind(Statement& st) const;

 private:
  void start_condition();

  std::string sql_;
  std::vector<std::string> values_;
};

// The five table columns of nc_pushes, nc_push_intents and nc_pending, in this order where a
// query selects them: interpolation, block_count, command_error_um, point_count,
// correction_max_um. Bound by name (:interpolation ...) and read from column `first` on.
void bind_table_facts(Statement& s, const TableFacts& table);
TableFacts read_table_facts(const Statement& s, int first);

// Columns 0..12 of nc_pushes AS p, read by read_push(); program_text, when selected, follows.
inline constexpr std::string_view kPushColumns =
    "p.id, p.run_id, p.pushed_utc, p.nc_file, p.table_version, p.reason, p.interpolation, p.block_count, "
    "p.command_error_um, p.point_count, p.correction_max_um, p.program_hash, p.uuid";
NcPush read_push(const Statement& s, bool with_text);

// The next table version of `nc_file`: 1 + the highest recorded (1 if none).
Result<int> next_version_of(Connection& conn, std::string_view nc_file, const std::string& operation);

// A push's reason when none is given: "run <id>", or "new program" for run 0 (a program
// written from a drawing by nc new, with no run behind it).
std::string default_reason(std::int64_t run_id);

// Records one push inside the caller's write transaction, which makes the version check and
// the insert one step for other writers: marks the run pushed (run 0: there is none; run_id is
// stored NULL), takes (or checks) the file's next table version and inserts the nc_pushes row.
// Returns its id. `push` was checked.
Result<std::int64_t> insert_push(Connection& conn, std::int64_t run_id, const NcPush& push, std::string_view text,
                                 const std::string& operation);

// Inside the caller's write transaction: records `push` as the approved push of pending table
// `pending_id` and marks the table approved, as RunStore::record_approved_push describes.
// Returns the push's id.
Result<std::int64_t> approve_in_transaction(Connection& conn, std::int64_t pending_id, const NcPush& push,
                                            const std::string& by, const std::string& note,
                                            const std::string& operation);

// The statements RunStore::metrics_snapshot runs, in order: tests check their query plans.
std::vector<std::string_view> metrics_snapshot_queries();

}  // namespace gaugeloop::storage_internal
