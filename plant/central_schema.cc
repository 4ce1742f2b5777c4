// The central history's schema (PostgreSQL), versioned by the rows of central_schema_version.
#include "plant/central_schema.h"

#include <array>
#include <string>

#include "core/utc_time.h"
#include "plant/central_internal.h"

namespace gaugeloop {

namespace {

// Version 1. Text columns compare byte by byte (COLLATE "C"), as SQLite compares them, so a
// query orders and filters exactly as the grinder's file does whatever the server's locale.
// Times stay the text the grinder stored ("2026-11-22T02:34:44Z"): printed byte for byte as
// the local file prints them, and text order is time order. Numbers are float8, read back
// exactly. Records are keyed by their UUID, so a record synced twice is kept once; local_id is
// the record's id in its grinder's file, source_machine and source the grinder and the file it
// was synced from.
constexpr std::string_view kCentralV1 = R"sql(
CREATE TABLE runs (
  uuid                  text COLLATE "C" PRIMARY KEY CHECK (length(uuid) = 36),
  source_machine        text COLLATE "C" NOT NULL,  -- the grinder it was synced from (plant sync --machine)
  source                text COLLATE "C" NOT NULL,  -- the file it was synced from
  local_id              bigint NOT NULL,            -- runs.id in that file
  started_utc           text COLLATE "C" NOT NULL,
  finished_utc          text COLLATE "C" NOT NULL,
  machine               text COLLATE "C" NOT NULL,  -- as the run recorded it
  part                  text COLLATE "C" NOT NULL,
  lobe                  integer NOT NULL CHECK (lobe >= 1),
  gauge                 text COLLATE "C" NOT NULL,
  note                  text COLLATE "C" NOT NULL DEFAULT '',
  status                text COLLATE "C" NOT NULL CHECK (status IN ('measured', 'pushed')),
  revolutions           integer NOT NULL,
  degrees_captured      integer NOT NULL,
  polls                 bigint NOT NULL,
  reconnects            bigint NOT NULL,
  discarded_revolutions bigint NOT NULL,
  zero_offset_mm        float8 NOT NULL,
  max_abs_error_um      float8 NOT NULL,
  rms_error_um          float8 NOT NULL,
  peak_to_valley_um     float8 NOT NULL,
  repeatability_um      float8 NOT NULL,
  nc_file               text COLLATE "C",          -- the NC program last pushed from the run
  phase_error_deg       float8,
  base_circle_runout_um float8,
  harmonic_amplitude_um text,                      -- JSON array, harmonics 0..30
  correction_in_force_run bigint,                  -- a local id in the same file
  settings_hash         text COLLATE "C",
  settings              text,
  raw_pruned_utc        text COLLATE "C",          -- as the file said when the run was synced
  ground_with_version   integer,
  ground_with_source    text COLLATE "C",
  inspection            boolean NOT NULL,
  serial                text COLLATE "C",
  operator              text COLLATE "C",
  verdict               text COLLATE "C" NOT NULL CHECK (verdict IN ('in', 'out', 'not_judged')),
  lift_error_reference  text COLLATE "C" NOT NULL,
  max_abs_residual_um   float8,
  rms_residual_um       float8,
  peak_to_valley_residual_um float8,
  dial_runout_um        float8,
  roundness_um          float8,
  synced_utc            text COLLATE "C" NOT NULL
);
-- The query commands' filters, newest first.
CREATE INDEX runs_by_started ON runs (started_utc DESC, local_id DESC);
CREATE INDEX runs_by_machine_started ON runs (machine, started_utc DESC);
CREATE INDEX runs_by_part_lobe_started ON runs (part, lobe, started_utc DESC);
CREATE INDEX runs_by_machine_part_lobe_started ON runs (machine, part, lobe, started_utc DESC);
CREATE INDEX runs_by_serial ON runs (serial, started_utc DESC) WHERE serial IS NOT NULL;
CREATE INDEX runs_by_verdict ON runs (verdict, started_utc DESC);

CREATE TABLE run_characteristics (
  run_uuid    text COLLATE "C" NOT NULL REFERENCES runs (uuid) ON DELETE CASCADE,
  position    integer NOT NULL CHECK (position >= 0),
  key         text COLLATE "C" NOT NULL,
  unit        text COLLATE "C" NOT NULL,
  value       float8 NOT NULL,
  min_value   float8 NOT NULL,
  max_value   float8 NOT NULL,
  lower_limit float8,
  upper_limit float8,
  verdict     text COLLATE "C" NOT NULL CHECK (verdict IN ('in', 'out', 'not_judged')),
  from_deg    integer,
  to_deg      integer,
  PRIMARY KEY (run_uuid, position)
);

-- No reference to runs: a push may be synced before a run stored after the sync read the runs.
CREATE TABLE nc_pushes (
  uuid              text COLLATE "C" PRIMARY KEY CHECK (length(uuid) = 36),
  run_uuid          text COLLATE "C" NOT NULL,
  machine           text COLLATE "C" NOT NULL,  -- the run's
  source_machine    text COLLATE "C" NOT NULL,
  source            text COLLATE "C" NOT NULL,
  local_id          bigint NOT NULL,            -- nc_pushes.id in the file: push order
  local_run_id      bigint NOT NULL,
  pushed_utc        text COLLATE "C" NOT NULL,
  nc_file           text COLLATE "C" NOT NULL,
  table_version     integer NOT NULL,
  reason            text,
  interpolation     text COLLATE "C",
  block_count       integer,
  command_error_um  float8,
  point_count       integer,
  correction_max_um float8,
  program_hash      text COLLATE "C",
  synced_utc        text COLLATE "C" NOT NULL
);
CREATE INDEX nc_pushes_by_run ON nc_pushes (run_uuid, local_id);
CREATE INDEX nc_pushes_by_machine_pushed ON nc_pushes (machine, pushed_utc DESC);

CREATE TABLE events (
  uuid           text COLLATE "C" PRIMARY KEY CHECK (length(uuid) = 36),
  source_machine text COLLATE "C" NOT NULL,
  source         text COLLATE "C" NOT NULL,
  local_id       bigint NOT NULL,
  at_utc         text COLLATE "C" NOT NULL,
  kind           text COLLATE "C" NOT NULL CHECK (kind IN ('fault', 'refusal', 'info')),
  code           text COLLATE "C" NOT NULL,
  machine        text COLLATE "C" NOT NULL,  -- as the event recorded it (may be empty)
  part           text COLLATE "C" NOT NULL,
  lobe           integer NOT NULL,
  local_run_id   bigint,
  message        text NOT NULL,
  synced_utc     text COLLATE "C" NOT NULL
);
CREATE INDEX events_by_machine_at ON events (machine, at_utc DESC);
CREATE INDEX events_by_at ON events (at_utc DESC);

-- Where each grinder's sync stopped: the last record copied per table, with its UUID so a
-- file replaced since (other records under the same ids) is noticed.
CREATE TABLE sync_progress (
  machine       text COLLATE "C" NOT NULL,
  source        text COLLATE "C" NOT NULL,
  table_name    text COLLATE "C" NOT NULL CHECK (table_name IN ('runs', 'nc_pushes', 'events')),
  last_local_id bigint NOT NULL DEFAULT 0,
  last_uuid     text COLLATE "C",
  updated_utc   text COLLATE "C" NOT NULL,
  PRIMARY KEY (machine, source, table_name)
);
)sql";

// A sync from the start keeps its own place, so one stopped part-way resumes there and never
// moves the plain sync's progress back (NULL: no such sync under way).
constexpr std::string_view kCentralV2 = R"sql(
ALTER TABLE sync_progress ADD COLUMN rescan_local_id bigint, ADD COLUMN rescan_uuid text COLLATE "C";
)sql";

// Events name their run by its UUID too, the central history's key for a run (local_run_id is
// only the grinder's file's): events copied before are given theirs from the runs copied from
// the same file.
constexpr std::string_view kCentralV3 = R"sql(
ALTER TABLE events ADD COLUMN run_uuid text COLLATE "C";
UPDATE events AS e SET run_uuid = r.uuid FROM runs AS r
WHERE e.local_run_id IS NOT NULL AND r.source = e.source AND r.local_id = e.local_run_id;
CREATE INDEX events_by_run ON events (run_uuid) WHERE run_uuid IS NOT NULL;
)sql";

// The newest runs of a part across its lobes (`runs list --db ... --part P`) by an index, not a
// sort of all the part's runs.
constexpr std::string_view kCentralV4 = R"sql(
CREATE INDEX runs_by_part_started ON runs (part, started_utc DESC);
)sql";

// A run's characteristics in one row of arrays (position i of each array is the characteristic
// at position i), one row and one index entry a run instead of one each per characteristic:
// what PostgreSQL spent most of a sync on, and most of the history's index. The rows as before
// are a view of the same name and columns.
constexpr std::string_view kCentralV5 = R"sql(
CREATE TABLE run_characteristic_sets (
  run_uuid              text COLLATE "C" PRIMARY KEY REFERENCES runs (uuid) ON DELETE CASCADE,
  key_list              text[] COLLATE "C" NOT NULL,
  unit_list             text[] COLLATE "C" NOT NULL,
  value_list            float8[] NOT NULL,
  min_value_list        float8[] NOT NULL,
  max_value_list        float8[] NOT NULL,
  lower_limit_list      float8[] NOT NULL,
  upper_limit_list      float8[] NOT NULL,
  verdict_list          text[] COLLATE "C" NOT NULL,
  from_deg_list         integer[] NOT NULL,
  to_deg_list           integer[] NOT NULL,
  CHECK (array_ndims(key_list) = 1 AND cardinality(key_list) > 0),
  CHECK (cardinality(unit_list) = cardinality(key_list) AND cardinality(value_list) = cardinality(key_list)
         AND cardinality(min_value_list) = cardinality(key_list) AND cardinality(max_value_list) = cardinality(key_list)
         AND cardinality(lower_limit_list) = cardinality(key_list)
         AND cardinality(upper_limit_list) = cardinality(key_list)
         AND cardinality(verdict_list) = cardinality(key_list) AND cardinality(from_deg_list) = cardinality(key_list)
         AND cardinality(to_deg_list) = cardinality(key_list)),
  CHECK (array_position(key_list, NULL) IS NULL AND array_position(unit_list, NULL) IS NULL
         AND array_position(value_list, NULL) IS NULL AND array_position(min_value_list, NULL) IS NULL
         AND array_position(max_value_list, NULL) IS NULL),
  CHECK (verdict_list <@ ARRAY['in', 'out', 'not_judged']::text[])
);
INSERT INTO run_characteristic_sets
SELECT run_uuid, array_agg(key ORDER BY position), array_agg(unit ORDER BY position),
       array_agg(value ORDER BY position), array_agg(min_value ORDER BY position),
       array_agg(max_value ORDER BY position), array_agg(lower_limit ORDER BY position),
       array_agg(upper_limit ORDER BY position), array_agg(verdict ORDER BY position),
       array_agg(from_deg ORDER BY position), array_agg(to_deg ORDER BY position)
FROM run_characteristics GROUP BY run_uuid;
DROP TABLE run_characteristics;
CREATE VIEW run_characteristics AS
SELECT s.run_uuid, (c.ordinality - 1)::integer AS position, c.key, c.unit, c.value, c.min_value, c.max_value,
       c.lower_limit, c.upper_limit, c.verdict, c.from_deg, c.to_deg
FROM run_characteristic_sets AS s,
     unnest(s.key_list, s.unit_list, s.value_list, s.min_value_list, s.max_value_list, s.lower_limit_list,
            s.upper_limit_list, s.verdict_list, s.from_deg_list, s.to_deg_list)
       WITH ORDINALITY AS c (key, unit, value, min_value, max_value, lower_limit, upper_limit, verdict, from_deg,
                             to_deg, ordinality);
)sql";

// A push's program text, copied when the sync is asked to (plant sync --programs,
// [plant.central] programs = true); NULL otherwise.
constexpr std::string_view kCentralV6 = R"sql(
ALTER TABLE nc_pushes ADD COLUMN program_text text;
)sql";

// A run's per-degree tables and raw revolutions, copied when the sync is asked to (plant sync
// --per-degree, [plant.central] per_degree = true): index d of a table is cam degree d (0..359),
// lift_mm[r][d] is revolution r's reading at degree d of C (machine frame, as measured), the
// values as the grinder's file reads them back. The raw revolutions are deleted here when the
// grinder prunes them; sync_progress keeps where the sync of a file stands in its prunes.
constexpr std::string_view kCentralV7 = R"sql(
CREATE TABLE run_tables (
  run_uuid          text COLLATE "C" PRIMARY KEY REFERENCES runs (uuid) ON DELETE CASCADE,
  design_lift_mm    float8[] NOT NULL CHECK (array_ndims(design_lift_mm) = 1 AND cardinality(design_lift_mm) = 360),
  mean_lift_mm      float8[] NOT NULL CHECK (array_ndims(mean_lift_mm) = 1 AND cardinality(mean_lift_mm) = 360),
  spread_um         float8[] NOT NULL CHECK (array_ndims(spread_um) = 1 AND cardinality(spread_um) = 360),
  error_um          float8[] NOT NULL CHECK (array_ndims(error_um) = 1 AND cardinality(error_um) = 360),
  correction_um     float8[] NOT NULL CHECK (array_ndims(correction_um) = 1 AND cardinality(correction_um) = 360),
  residual_error_um float8[] NOT NULL
                    CHECK (array_ndims(residual_error_um) = 1 AND cardinality(residual_error_um) = 360)
);
CREATE TABLE run_raw (
  run_uuid              text COLLATE "C" PRIMARY KEY REFERENCES runs (uuid) ON DELETE CASCADE,
  amplifier_revolutions bigint[] NOT NULL
                        CHECK (array_ndims(amplifier_revolutions) = 1 AND cardinality(amplifier_revolutions) >= 3),
  lift_mm               float8[] NOT NULL
                        CHECK (array_ndims(lift_mm) = 2 AND array_length(lift_mm, 2) = 360
                               AND array_length(lift_mm, 1) = cardinality(amplifier_revolutions))
);
ALTER TABLE sync_progress ADD COLUMN pruned_through_utc text COLLATE "C", ADD COLUMN pruned_through_id bigint;
)sql";

constexpr std::array<CentralMigration, 7> kMigrations{{
    {1, "runs, run_characteristics, nc_pushes, events and sync_progress", kCentralV1},
    {2, "sync_progress: where a sync from the start stands (rescan_local_id, rescan_uuid)", kCentralV2},
    {3, "events: the run's UUID (run_uuid)", kCentralV3},
    {4, "runs: an index by part and time (runs_by_part_started)", kCentralV4},
    {5, "run_characteristic_sets: a run's characteristics in one row; run_characteristics a view of them", kCentralV5},
    {6, "nc_pushes: the program text (program_text), when synced", kCentralV6},
    {7, "run_tables and run_raw: a run's per-degree tables and raw revolutions, when synced; the prunes followed",
     kCentralV7},
}};

// Any 64-bit number of our own: held by whoever migrates, so two grinders syncing into an
// empty database do not both create the tables.
constexpr std::int64_t kMigrationLock = 0x6761756765;  // "gauge"

constexpr std::string_view kCreateVersionTable = R"sql(
CREATE TABLE IF NOT EXISTS central_schema_version (
  version     integer PRIMARY KEY,
  applied_utc text NOT NULL,
  description text NOT NULL
))sql";

}  // namespace

std::span<const CentralMigration> central_migrations() { return kMigrations; }

int latest_central_schema_version() { return kMigrations.back().version; }

namespace central_internal {

namespace {

int version_in(pqxx::transaction_base& tx) {
  pqxx::result has = tx.exec("SELECT to_regclass('central_schema_version') IS NOT NULL");
  if (!has[0][0].as<bool>()) return 0;
  pqxx::result v = tx.exec("SELECT coalesce(max(version), 0) FROM central_schema_version");
  return v[0][0].as<int>();
}

Error too_new(const CentralConnection& c, int version) {
  return make_error(ErrorCode::kStorage, "the central history at " + c.url.shown + " has schema version " +
                                             std::to_string(version) + ", newer than this gaugeloop understands (" +
                                             std::to_string(latest_central_schema_version()) +
                                             "); run a newer gaugeloop, or give the URL of another database");
}

}  // namespace

Result<int> read_central_version(CentralConnection& c) {
  // One statement outside a transaction, one round trip: every query command pays it.
  try {
    pqxx::nontransaction tx(*c.conn);
    return tx.exec("SELECT coalesce(max(version), 0) FROM central_schema_version")[0][0].as<int>();
  } catch (const pqxx::undefined_table&) {
    return 0;  // no central history in this database
  } catch (const std::exception& e) {
    return database_error(c.url, "read the schema version", e);
  }
}

Status migrate(CentralConnection& c) {
  // Up to date (the usual case): nothing is created, so a grinder's user needs no CREATE
  // privilege once the schema is there.
  Result<int> current = read_central_version(c);
  if (!current.ok()) return current.error();
  if (*current > latest_central_schema_version()) return too_new(c, *current);
  if (*current == latest_central_schema_version()) return {};
  for (const CentralMigration& m : kMigrations) {
    const std::string operation = "migrate the central history to schema version " + std::to_string(m.version);
    try {
      pqxx::work tx(*c.conn);
      tx.exec("SELECT pg_advisory_xact_lock(" + std::to_string(kMigrationLock) + ")");
      // Read again under the lock: another grinder may have migrated meanwhile.
      tx.exec(std::string(kCreateVersionTable));
      const int version = version_in(tx);
      if (version > latest_central_schema_version()) return too_new(c, version);
      if (m.version <= version) continue;  // the transaction rolls back, nothing was written
      tx.exec(std::string(m.sql));
      Params p;
      p.integer(std::int64_t{m.version}).text(utc_now()).text(m.description);
      exec(tx, "INSERT INTO central_schema_version (version, applied_utc, description) VALUES ($1, $2, $3)", p);
      tx.commit();
    } catch (const std::exception& e) {
      return database_error(c.url, operation, e);
    }
  }
  // A newer schema than every migration here: refused even when there was nothing to apply.
  Result<int> version = read_central_version(c);
  if (!version.ok()) return version.error();
  if (*version > latest_central_schema_version()) return too_new(c, *version);
  return {};
}

Status require_latest(CentralConnection& c) {
  Result<int> version = read_central_version(c);
  if (!version.ok()) return version.error();
  if (*version > latest_central_schema_version()) return too_new(c, *version);
  if (*version == 0) {
    return make_error(ErrorCode::kStorage, "the database at " + c.url.shown +
                                               " holds no central history yet; copy a grinder's runs into it with "
                                               "`gaugeloop plant sync --to " +
                                               c.url.shown + "`");
  }
  if (*version < latest_central_schema_version()) {
    return make_error(ErrorCode::kStorage, "the central history at " + c.url.shown + " has schema version " +
                                               std::to_string(*version) + ", older than this gaugeloop's (" +
                                               std::to_string(latest_central_schema_version()) +
                                               "); `gaugeloop plant sync --to " + c.url.shown + "` upgrades it");
  }
  return {};
}

}  // namespace central_internal
}  // namespace gaugeloop
