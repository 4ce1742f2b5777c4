// The run database schema as an ordered list of migrations, versioned by PRAGMA user_version.
#include "storage/migrations.h"

#include <array>
#include <string>

#include "storage/sqlite_db.h"

namespace gaugeloop::storage_internal {
namespace {

// Version 1. Angles: run_profile is in the cam frame (0 at the nose); raw revolutions and the
// run_samples view are in the machine frame (degrees of C), as the gauge was read.
constexpr std::string_view kSchemaV1 = R"sql(
-- One row per measurement run. AUTOINCREMENT so that an id, once printed on an NC program,
-- never names another run, even after rows were deleted by hand.
CREATE TABLE runs (
  id                    INTEGER PRIMARY KEY AUTOINCREMENT,
  started_utc           TEXT    NOT NULL,  -- ISO 8601 UTC, "2026-11-22T02:34:44Z"
  finished_utc          TEXT    NOT NULL,
  machine               TEXT    NOT NULL,
  part                  TEXT    NOT NULL,
  lobe                  INTEGER NOT NULL CHECK (lobe >= 1),
  gauge                 TEXT    NOT NULL,
  note                  TEXT    NOT NULL DEFAULT '',
  status                TEXT    NOT NULL DEFAULT 'measured'
                                CHECK (status IN ('measured', 'pushed')),
  revolutions           INTEGER NOT NULL CHECK (revolutions >= 3),
  degrees_captured      INTEGER NOT NULL CHECK (degrees_captured = revolutions * 360),
  polls                 INTEGER NOT NULL DEFAULT 0,
  reconnects            INTEGER NOT NULL DEFAULT 0,
  discarded_revolutions INTEGER NOT NULL DEFAULT 0,
  zero_offset_mm        REAL    NOT NULL,
  max_abs_error_um      REAL    NOT NULL,
  rms_error_um          REAL    NOT NULL,
  peak_to_valley_um     REAL    NOT NULL,
  repeatability_um      REAL    NOT NULL,
  nc_file               TEXT,              -- the NC program last pushed from this run
  -- The run whose correction was in force when this part was ground; NULL: the design.
  correction_in_force_run INTEGER REFERENCES runs (id),
  CHECK ((status = 'pushed') = (nc_file IS NOT NULL))
);
CREATE INDEX runs_by_part_lobe_started ON runs (part, lobe, started_utc);
CREATE INDEX runs_by_started ON runs (started_utc);

-- Raw gauge readings, one row per complete revolution: lift_mm is a JSON array of the 360
-- readings (mm, 6 decimals), index = machine degree of C.
CREATE TABLE run_revolutions (
  run_id               INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  revolution_index     INTEGER NOT NULL CHECK (revolution_index >= 0),  -- 0-based in the run
  amplifier_revolution INTEGER NOT NULL,  -- the amplifier's unwrapped revolution count
  lift_mm              TEXT    NOT NULL
                       CHECK (json_valid(lift_mm) AND json_array_length(lift_mm) = 360),
  PRIMARY KEY (run_id, revolution_index),
  UNIQUE (run_id, amplifier_revolution)
) WITHOUT ROWID;

-- The analysed lobe and the correction, one row per cam degree.
CREATE TABLE run_profile (
  run_id         INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  angle_deg      INTEGER NOT NULL CHECK (angle_deg BETWEEN 0 AND 359),  -- cam frame
  design_lift_mm REAL    NOT NULL,
  mean_lift_mm   REAL    NOT NULL,  -- zeroed on the base circle
  spread_um      REAL    NOT NULL,  -- standard deviation across revolutions
  error_um       REAL    NOT NULL,  -- mean - design
  correction_um  REAL    NOT NULL,
  PRIMARY KEY (run_id, angle_deg)
) WITHOUT ROWID;

-- Raw samples one per row, for plain SQL: angle_deg here is the machine degree of C.
CREATE VIEW run_samples (run_id, revolution_index, angle_deg, lift_mm) AS
  SELECT r.run_id, r.revolution_index, s.key, s.value
  FROM run_revolutions AS r, json_each(r.lift_mm) AS s;
)sql";

constexpr std::array<Migration, 1> kMigrations{{
    {1, "runs, run_revolutions, run_profile, run_samples view", kSchemaV1},
}};

Result<int> read_user_version(Connection& conn) {
  Result<Statement> stmt = Statement::prepare(conn, "PRAGMA user_version", "read the schema version");
  if (!stmt.ok()) return stmt.error();
  Result<bool> row = stmt->step();
  if (!row.ok()) return row.error();
  return *row ? stmt->column_int(0) : 0;
}

Error too_new(const Connection& conn, int version) {
  return make_error(ErrorCode::kStorage, "run database " + conn.path.string() + " has schema version " +
                                             std::to_string(version) + ", newer than this gaugeloop understands (" +
                                             std::to_string(latest_schema_version()) +
                                             "); run a newer gaugeloop or point --data-dir elsewhere");
}

}  // namespace

std::span<const Migration> migrations() { return kMigrations; }

int latest_schema_version() { return kMigrations.back().version; }

Status apply_migrations(Connection& conn) {
  Result<int> version = read_user_version(conn);
  if (!version.ok()) return version.error();
  if (*version > latest_schema_version()) return too_new(conn, *version);

  for (const Migration& m : kMigrations) {
    if (m.version <= *version) continue;
    const std::string operation = "migrate the schema to version " + std::to_string(m.version);
    Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
    if (!tx.ok()) return tx.error();
    // Read again under the write lock: another process may have migrated meanwhile.
    version = read_user_version(conn);
    if (!version.ok()) return version.error();
    if (*version > latest_schema_version()) return too_new(conn, *version);
    if (m.version <= *version) continue;  // the transaction rolls back, nothing was written

    const std::string sql = std::string(m.sql) + "\nPRAGMA user_version = " + std::to_string(m.version) + ";";
    Status applied = exec(conn, sql.c_str(), operation);
    if (!applied.ok()) return applied;
    Status committed = tx->commit();
    if (!committed.ok()) return committed;
    *version = m.version;
  }
  return {};
}

}  // namespace gaugeloop::storage_internal
