// The run database schema as an ordered list of migrations, versioned by PRAGMA user_version.
#include "storage/migrations.h"

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "storage/degree_blob.h"
#include "storage/degree_json.h"
#include "storage/migration_v2.h"
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

// Version 2. Compact per-degree tables (docs/storage.md has the numbers behind the choice):
// every per-degree table is a BLOB of 360 big-endian int32 counts of 0.1 nm, one row per run,
// and the version-1 names run_samples and run_profile become views that decode them, so SQL
// written against version 1 still reads the same columns. Also: the part and lobe catalogue,
// inspection figures, the settings a run was made with, NC pushes and events.
constexpr std::string_view kSchemaV2Before = R"sql(
-- Parts and lobes ever measured. Geometry columns hold the latest values a run reported;
-- NULL: not known (runs stored by version 1 did not report them).
CREATE TABLE parts (
  name                  TEXT PRIMARY KEY,
  follower              TEXT CHECK (follower IN ('flat', 'roller', 'knife_edge')),
  follower_radius_mm    REAL,
  base_circle_radius_mm REAL,
  wheel_radius_mm       REAL
) WITHOUT ROWID;

CREATE TABLE lobes (
  part             TEXT    NOT NULL REFERENCES parts (name),
  lobe             INTEGER NOT NULL CHECK (lobe >= 1),
  -- Machine angle C = rotation_sense * psi + c_offset_deg; the probe sits probe_offset_deg
  -- of C from the wheel contact (the cam-grinding kinematics). Latest values a run reported.
  rotation_sense   INTEGER CHECK (rotation_sense IN (-1, 1)),
  c_offset_deg     REAL,
  probe_offset_deg REAL,
  PRIMARY KEY (part, lobe)
) WITHOUT ROWID;

INSERT INTO parts (name) SELECT DISTINCT part FROM runs;
INSERT INTO lobes (part, lobe) SELECT DISTINCT part, lobe FROM runs;

-- Every run's part and lobe is in the catalogue, however the run was inserted.
CREATE TRIGGER runs_enter_the_catalogue AFTER INSERT ON runs BEGIN
  INSERT OR IGNORE INTO parts (name) VALUES (NEW.part);
  INSERT OR IGNORE INTO lobes (part, lobe) VALUES (NEW.part, NEW.lobe);
END;

-- The settings a run was made with, as canonical "key = value" lines, stored once per
-- distinct text. hash: 16 hex digits of the 64-bit FNV-1a hash of text.
CREATE TABLE settings (
  hash TEXT PRIMARY KEY,
  text TEXT NOT NULL
) WITHOUT ROWID;

ALTER TABLE runs ADD COLUMN settings_hash TEXT REFERENCES settings (hash);
-- Inspection figures; NULL for runs stored by version 1, which did not compute them.
ALTER TABLE runs ADD COLUMN phase_error_deg REAL;
ALTER TABLE runs ADD COLUMN base_circle_runout_um REAL;
ALTER TABLE runs ADD COLUMN harmonic_amplitude_um TEXT  -- JSON array, harmonics 0..30
  CHECK (harmonic_amplitude_um IS NULL OR
         (json_valid(harmonic_amplitude_um) AND json_array_length(harmonic_amplitude_um) = 31));
-- The frame mapping in force for this run (see lobes); NULL: not known.
ALTER TABLE runs ADD COLUMN rotation_sense INTEGER CHECK (rotation_sense IN (-1, 1));
ALTER TABLE runs ADD COLUMN c_offset_deg REAL;
ALTER TABLE runs ADD COLUMN probe_offset_deg REAL;
-- When `gaugeloop runs prune` removed the raw samples; NULL: they are still there.
ALTER TABLE runs ADD COLUMN raw_pruned_utc TEXT;

CREATE INDEX runs_by_machine_started ON runs (machine, started_utc);

-- 0..359, to expand the per-degree BLOBs into rows in the views.
CREATE TABLE degrees (angle_deg INTEGER PRIMARY KEY);
WITH RECURSIVE d (a) AS (SELECT 0 UNION ALL SELECT a + 1 FROM d WHERE a < 359)
INSERT INTO degrees (angle_deg) SELECT a FROM d;

-- Raw gauge readings, one row per run: `lift` holds the revolutions one after the other,
-- 360 counts each, index = machine degree of C. Deleted by prune.
CREATE TABLE run_raw (
  run_id                INTEGER PRIMARY KEY REFERENCES runs (id) ON DELETE CASCADE,
  amplifier_revolutions TEXT NOT NULL  -- JSON array: the amplifier's count of each revolution
    CHECK (json_valid(amplifier_revolutions) AND json_array_length(amplifier_revolutions) >= 3),
  lift                  BLOB NOT NULL
    CHECK (typeof(lift) = 'blob' AND length(lift) = 1440 * json_array_length(amplifier_revolutions))
);

-- The analysed lobe and the correction, cam frame, one row per run.
CREATE TABLE run_tables (
  run_id      INTEGER PRIMARY KEY REFERENCES runs (id) ON DELETE CASCADE,
  design_lift BLOB NOT NULL CHECK (typeof(design_lift) = 'blob' AND length(design_lift) = 1440),
  mean_lift   BLOB NOT NULL CHECK (typeof(mean_lift) = 'blob' AND length(mean_lift) = 1440),
  spread      BLOB NOT NULL CHECK (typeof(spread) = 'blob' AND length(spread) = 1440),
  error       BLOB NOT NULL CHECK (typeof(error) = 'blob' AND length(error) = 1440),
  correction  BLOB NOT NULL CHECK (typeof(correction) = 'blob' AND length(correction) = 1440)
);

-- Every NC program written from a run, oldest first.
CREATE TABLE nc_pushes (
  id                INTEGER PRIMARY KEY AUTOINCREMENT,
  run_id            INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  pushed_utc        TEXT    NOT NULL,
  nc_file           TEXT    NOT NULL,
  -- NULL: not recorded (pushes made before version 2).
  point_count       INTEGER,
  correction_max_um REAL,
  program_hash      TEXT    -- 64-bit FNV-1a of the program text, 16 hex digits
);
CREATE INDEX nc_pushes_by_run ON nc_pushes (run_id);
INSERT INTO nc_pushes (run_id, pushed_utc, nc_file)
  SELECT id, finished_utc, nc_file FROM runs WHERE nc_file IS NOT NULL ORDER BY id;

-- Faults and refusals: what went wrong when no run (or no push) came of it.
CREATE TABLE events (
  id      INTEGER PRIMARY KEY AUTOINCREMENT,
  at_utc  TEXT    NOT NULL,
  kind    TEXT    NOT NULL CHECK (kind IN ('fault', 'refusal')),
  code    TEXT    NOT NULL,  -- e.g. 'gauge timeout', 'refused'
  machine TEXT    NOT NULL DEFAULT '',
  part    TEXT    NOT NULL DEFAULT '',
  lobe    INTEGER,           -- NULL: not about one lobe
  run_id  INTEGER REFERENCES runs (id) ON DELETE SET NULL,
  message TEXT    NOT NULL
);
CREATE INDEX events_by_time ON events (at_utc);
)sql";

// Version 3: NC pushes a controls engineer can audit and reverse, and tables awaiting approval.
// nc_pushes is rebuilt (SQLite cannot add a NOT NULL column or a UNIQUE constraint to a
// table) keeping every id; pushes from version 2 are numbered 1, 2, 3... per nc_file in id
// order, which is push order.
constexpr std::string_view kSchemaV3 = R"sql(
CREATE TABLE nc_pushes_v3 (
  id                INTEGER PRIMARY KEY AUTOINCREMENT,  -- push order
  run_id            INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  pushed_utc        TEXT    NOT NULL,
  nc_file           TEXT    NOT NULL,
  -- 1, 2, 3... per nc_file: the version the program's header carries.
  table_version     INTEGER NOT NULL CHECK (table_version >= 1),
  reason            TEXT,     -- "run 12", "approved by anna", "rollback to version 3"; NULL before v3
  interpolation     TEXT,     -- "G1", "CSPLINE"...; NULL: unknown
  block_count       INTEGER CHECK (block_count >= 0),
  command_error_um  REAL    CHECK (command_error_um >= 0),
  -- NULL: not recorded (pushes made before version 2).
  point_count       INTEGER,
  correction_max_um REAL,
  program_hash      TEXT,     -- 64-bit FNV-1a of the program text, 16 hex digits
  program_text      TEXT,     -- the whole program as written; NULL: not recorded (before v3)
  UNIQUE (nc_file, table_version)
);
INSERT INTO nc_pushes_v3 (id, run_id, pushed_utc, nc_file, table_version, point_count,
                          correction_max_um, program_hash)
  SELECT id, run_id, pushed_utc, nc_file, row_number() OVER (PARTITION BY nc_file ORDER BY id),
         point_count, correction_max_um, program_hash
  FROM nc_pushes;
-- Keep the AUTOINCREMENT high-water mark, so an id of a push deleted by hand is never reused.
UPDATE sqlite_sequence
  SET seq = max(seq, coalesce((SELECT seq FROM sqlite_sequence WHERE name = 'nc_pushes'), 0))
  WHERE name = 'nc_pushes_v3';
INSERT INTO sqlite_sequence (name, seq)
  SELECT 'nc_pushes_v3', seq FROM sqlite_sequence WHERE name = 'nc_pushes'
    AND NOT EXISTS (SELECT 1 FROM sqlite_sequence WHERE name = 'nc_pushes_v3');
DROP TABLE nc_pushes;
ALTER TABLE nc_pushes_v3 RENAME TO nc_pushes;
CREATE INDEX nc_pushes_by_run ON nc_pushes (run_id);

-- Rendered programs that were not written: waiting for a person's approval, or held by
-- compensation. Only 'pending' rows change; at most one per nc_file is pending.
CREATE TABLE nc_pending (
  id                INTEGER PRIMARY KEY AUTOINCREMENT,
  run_id            INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  created_utc       TEXT    NOT NULL,
  nc_file           TEXT    NOT NULL,
  program_text      TEXT    NOT NULL,
  verdict           TEXT    NOT NULL CHECK (verdict IN ('apply', 'hold')),
  reason            TEXT    NOT NULL DEFAULT '',
  interpolation     TEXT,
  block_count       INTEGER CHECK (block_count >= 0),
  command_error_um  REAL    CHECK (command_error_um >= 0),
  correction_max_um REAL,
  point_count       INTEGER,
  status            TEXT    NOT NULL DEFAULT 'pending'
                            CHECK (status IN ('pending', 'approved', 'rejected', 'superseded')),
  decided_utc       TEXT,     -- when it left 'pending'
  decided_by        TEXT,     -- who approved or rejected it
  note              TEXT,
  push_id           INTEGER REFERENCES nc_pushes (id) ON DELETE SET NULL,  -- 'approved'
  superseded_by     INTEGER REFERENCES nc_pending (id) ON DELETE SET NULL, -- 'superseded'
  CHECK ((status = 'pending') = (decided_utc IS NULL))
);
CREATE UNIQUE INDEX nc_pending_one_per_file ON nc_pending (nc_file) WHERE status = 'pending';
CREATE INDEX nc_pending_by_run ON nc_pending (run_id);
)sql";

// Version 4: events of kind 'info' (a PLC request, a cycle's outcome, a config reload). SQLite
// cannot change a CHECK constraint, so events is rebuilt keeping every id.
constexpr std::string_view kSchemaV4 = R"sql(
CREATE TABLE events_v4 (
  id      INTEGER PRIMARY KEY AUTOINCREMENT,
  at_utc  TEXT    NOT NULL,
  kind    TEXT    NOT NULL CHECK (kind IN ('fault', 'refusal', 'info')),
  code    TEXT    NOT NULL,  -- e.g. 'gauge timeout', 'refused', 'plc request'
  machine TEXT    NOT NULL DEFAULT '',
  part    TEXT    NOT NULL DEFAULT '',
  lobe    INTEGER,           -- NULL: not about one lobe
  run_id  INTEGER REFERENCES runs (id) ON DELETE SET NULL,
  message TEXT    NOT NULL
);
INSERT INTO events_v4 (id, at_utc, kind, code, machine, part, lobe, run_id, message)
  SELECT id, at_utc, kind, code, machine, part, lobe, run_id, message FROM events ORDER BY id;
-- An event id, once shown, never names another: the counter carries over, deleted rows too.
DELETE FROM sqlite_sequence WHERE name = 'events_v4';
INSERT INTO sqlite_sequence (name, seq) SELECT 'events_v4', seq FROM sqlite_sequence WHERE name = 'events';
DROP TABLE events;
ALTER TABLE events_v4 RENAME TO events;
CREATE INDEX events_by_time ON events (at_utc);
)sql";

// Version 5: the push journal and the table that ground each part.
//  - nc_push_intents: a push is recorded as an intent (with the program text) before its file
//    is renamed into place, and completed (its nc_pushes row) after; an intent still open
//    when a command next opens the store is reconciled with the file on the control.
//  - runs.ground_with_version: the table version of the run's NC file that ground the
//    measured part (NULL: the design, or not known); ground_with_source says who said so:
//    'plc', 'option' (measure --ground-with) or 'assumed' (the table in force).
//  - runs.inspection: 1 for a run measured only to inspect (measure --inspect): its
//    correction is the one in force, unchanged, and nothing was pushed from it.
constexpr std::string_view kSchemaV5 = R"sql(
CREATE TABLE nc_push_intents (
  id                INTEGER PRIMARY KEY AUTOINCREMENT,
  created_utc       TEXT    NOT NULL,
  run_id            INTEGER NOT NULL REFERENCES runs (id),
  nc_file           TEXT    NOT NULL,
  table_version     INTEGER NOT NULL CHECK (table_version >= 1),
  reason            TEXT    NOT NULL,
  interpolation     TEXT,
  block_count       INTEGER,
  command_error_um  REAL,
  point_count       INTEGER,
  correction_max_um REAL,
  program_hash      TEXT    NOT NULL,
  program_text      TEXT    NOT NULL,  -- emptied once the intent is resolved
  pending_id        INTEGER REFERENCES nc_pending (id),  -- an approval: the table it writes
  approved_by       TEXT,
  note              TEXT,
  state             TEXT    NOT NULL DEFAULT 'open'
                            CHECK (state IN ('open', 'completed', 'abandoned')),
  resolved_utc      TEXT,
  resolution        TEXT,   -- how it was resolved, in words
  push_id           INTEGER REFERENCES nc_pushes (id)
);
-- One push at a time per file.
CREATE UNIQUE INDEX nc_push_intents_one_open ON nc_push_intents (nc_file) WHERE state = 'open';
ALTER TABLE runs ADD COLUMN ground_with_version INTEGER CHECK (ground_with_version >= 1);
ALTER TABLE runs ADD COLUMN ground_with_source TEXT
  CHECK (ground_with_source IN ('plc', 'option', 'assumed'));
ALTER TABLE runs ADD COLUMN inspection INTEGER NOT NULL DEFAULT 0 CHECK (inspection IN (0, 1));
)sql";

// Version 6: what /metrics reads on every scrape, at a cost that does not grow with the history.
//  - runs_by_lobe_started: the newest run of each machine, part and lobe is one index seek per
//    lobe (RunStore::metrics_snapshot walks the index from lobe to lobe).
//  - row_counts: runs by status and events by kind, kept by triggers in the transaction of the
//    write that changes them. SQLite counts rows by reading them: counting 5,000,000 events by
//    kind reads a whole index (about 0.25 s, docs/PERFORMANCE.md), too slow for a scrape.
//    Invariant: every table counted here keeps its three triggers; a later migration that
//    rebuilds runs or events must create them again (DROP TABLE drops them).
constexpr std::string_view kSchemaV6 = R"sql(
CREATE INDEX runs_by_lobe_started ON runs (machine, part, lobe, started_utc);

CREATE TABLE row_counts (
  table_name TEXT    NOT NULL,  -- 'runs', 'events'
  value      TEXT    NOT NULL,  -- runs.status, events.kind
  row_count  INTEGER NOT NULL,
  PRIMARY KEY (table_name, value)
) WITHOUT ROWID;
INSERT INTO row_counts (table_name, value, row_count) SELECT 'runs', status, count(*) FROM runs GROUP BY status;
INSERT INTO row_counts (table_name, value, row_count) SELECT 'events', kind, count(*) FROM events GROUP BY kind;

CREATE TRIGGER runs_counted_on_insert AFTER INSERT ON runs BEGIN
  INSERT INTO row_counts (table_name, value, row_count) VALUES ('runs', NEW.status, 1)
    ON CONFLICT (table_name, value) DO UPDATE SET row_count = row_count + 1;
END;
CREATE TRIGGER runs_counted_on_delete AFTER DELETE ON runs BEGIN
  UPDATE row_counts SET row_count = row_count - 1 WHERE table_name = 'runs' AND value = OLD.status;
END;
CREATE TRIGGER runs_counted_on_status AFTER UPDATE OF status ON runs WHEN OLD.status IS NOT NEW.status BEGIN
  UPDATE row_counts SET row_count = row_count - 1 WHERE table_name = 'runs' AND value = OLD.status;
  INSERT INTO row_counts (table_name, value, row_count) VALUES ('runs', NEW.status, 1)
    ON CONFLICT (table_name, value) DO UPDATE SET row_count = row_count + 1;
END;
CREATE TRIGGER events_counted_on_insert AFTER INSERT ON events BEGIN
  INSERT INTO row_counts (table_name, value, row_count) VALUES ('events', NEW.kind, 1)
    ON CONFLICT (table_name, value) DO UPDATE SET row_count = row_count + 1;
END;
CREATE TRIGGER events_counted_on_delete AFTER DELETE ON events BEGIN
  UPDATE row_counts SET row_count = row_count - 1 WHERE table_name = 'events' AND value = OLD.kind;
END;
CREATE TRIGGER events_counted_on_kind AFTER UPDATE OF kind ON events WHEN OLD.kind IS NOT NEW.kind BEGIN
  UPDATE row_counts SET row_count = row_count - 1 WHERE table_name = 'events' AND value = OLD.kind;
  INSERT INTO row_counts (table_name, value, row_count) VALUES ('events', NEW.kind, 1)
    ON CONFLICT (table_name, value) DO UPDATE SET row_count = row_count + 1;
END;
)sql";

// Version 7: which part was measured and who measured it, for a report a quality engineer
// signs. Free text as the shop writes it (at most 64 characters, no control characters:
// check_run_identity); NULL: not given, and for every run stored before version 7.
// runs_by_serial: `runs list --serial` and GET /api/runs?serial= find a part's runs by one
// index seek, whatever the history.
constexpr std::string_view kSchemaV7 = R"sql(
ALTER TABLE runs ADD COLUMN serial TEXT CHECK (serial IS NULL OR length(serial) BETWEEN 1 AND 64);
ALTER TABLE runs ADD COLUMN operator TEXT CHECK (operator IS NULL OR length(operator) BETWEEN 1 AND 64);
CREATE INDEX runs_by_serial ON runs (serial, started_utc) WHERE serial IS NOT NULL;
)sql";

// Version 8: what a quality engineer signs. Every run judged against its lobe's tolerances:
//  - runs.verdict ('in', 'out', 'not_judged'; NULL for runs stored before version 8, read as
//    not judged) and which lift error was judged (lift_error_reference);
//  - the profile error after the best-fit phase (run_tables.residual_error, a degree BLOB like
//    error, and its figures), the base circle as a dial reads it and its roundness;
//  - run_characteristics: one row per characteristic (core/tolerance.h names the keys), in
//    the order judged, with its limits (NULL: none) and verdict;
//  - row_counts 'verdicts': runs by verdict for /metrics, kept by triggers as runs by status.
constexpr std::string_view kSchemaV8 = R"sql(
ALTER TABLE runs ADD COLUMN verdict TEXT CHECK (verdict IS NULL OR verdict IN ('in', 'out', 'not_judged'));
ALTER TABLE runs ADD COLUMN lift_error_reference TEXT
  CHECK (lift_error_reference IS NULL OR lift_error_reference IN ('best_fit', 'nominal'));
ALTER TABLE runs ADD COLUMN max_abs_residual_um REAL;
ALTER TABLE runs ADD COLUMN rms_residual_um REAL;
ALTER TABLE runs ADD COLUMN peak_to_valley_residual_um REAL;
ALTER TABLE runs ADD COLUMN dial_runout_um REAL;
ALTER TABLE runs ADD COLUMN roundness_um REAL;
ALTER TABLE run_tables ADD COLUMN residual_error BLOB;

CREATE TABLE run_characteristics (
  run_id      INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,
  position    INTEGER NOT NULL CHECK (position >= 0),  -- order within the run
  key         TEXT    NOT NULL CHECK (length(key) BETWEEN 1 AND 64),
  unit        TEXT    NOT NULL,
  value       REAL    NOT NULL,
  min_value   REAL    NOT NULL,
  max_value   REAL    NOT NULL,
  lower_limit REAL,     -- NULL: no lower limit
  upper_limit REAL,     -- NULL: no upper limit
  verdict     TEXT    NOT NULL CHECK (verdict IN ('in', 'out', 'not_judged')),
  from_deg    INTEGER,  -- a zone's arc, cam frame, nose at 0; NULL for whole-turn figures
  to_deg      INTEGER,
  PRIMARY KEY (run_id, key)
) WITHOUT ROWID;

-- The view SQL users read: one row per characteristic with its run's identity.
CREATE VIEW run_verdicts (run_id, started_utc, machine, part, lobe, serial, key, unit, value,
                          lower_limit, upper_limit, verdict) AS
  SELECT r.id, r.started_utc, r.machine, r.part, r.lobe, r.serial, c.key, c.unit, c.value,
         c.lower_limit, c.upper_limit, c.verdict
  FROM run_characteristics AS c JOIN runs AS r ON r.id = c.run_id;

INSERT INTO row_counts (table_name, value, row_count)
  SELECT 'verdicts', 'not_judged', count(*) FROM runs;
CREATE TRIGGER runs_verdict_counted_on_insert AFTER INSERT ON runs BEGIN
  INSERT INTO row_counts (table_name, value, row_count) VALUES ('verdicts', coalesce(NEW.verdict, 'not_judged'), 1)
    ON CONFLICT (table_name, value) DO UPDATE SET row_count = row_count + 1;
END;
CREATE TRIGGER runs_verdict_counted_on_delete AFTER DELETE ON runs BEGIN
  UPDATE row_counts SET row_count = row_count - 1
    WHERE table_name = 'verdicts' AND value = coalesce(OLD.verdict, 'not_judged');
END;
CREATE TRIGGER runs_verdict_counted_on_update AFTER UPDATE OF verdict ON runs
  WHEN coalesce(OLD.verdict, 'not_judged') IS NOT coalesce(NEW.verdict, 'not_judged') BEGIN
  UPDATE row_counts SET row_count = row_count - 1
    WHERE table_name = 'verdicts' AND value = coalesce(OLD.verdict, 'not_judged');
  INSERT INTO row_counts (table_name, value, row_count) VALUES ('verdicts', coalesce(NEW.verdict, 'not_judged'), 1)
    ON CONFLICT (table_name, value) DO UPDATE SET row_count = row_count + 1;
END;
CREATE INDEX runs_by_verdict ON runs (verdict, started_utc) WHERE verdict IS NOT NULL;
)sql";

// A random version-4 UUID in SQL, for rows that no gaugeloop wrote (backfill, sqlite3 users):
// gaugeloop itself gives each record core/uuid.h's new_uuid().
#define GL_SQL_UUID                                                                                 \
  "lower(hex(randomblob(4)) || '-' || hex(randomblob(2)) || '-4' || substr(hex(randomblob(2)), 2) " \
  "|| '-' || substr('89ab', 1 + abs(random()) % 4, 1) || substr(hex(randomblob(2)), 2) || '-' || "  \
  "hex(randomblob(6)))"

// Version 9: one plant, many grinders.
//  - runs, nc_pushes and events get a UUID (existing rows a random one), unique, so records
//    of many machines meet in one central history without colliding; a row inserted without
//    one (by hand) gets one from its trigger.
//  - outbox: the plant messages (MQTT), each written by a trigger in the same transaction as
//    the run or push it describes, while outbox_state.enabled is set (by the service with a
//    broker configured). A sender deletes a message when the broker acknowledges it. Bounded:
//    past max_depth the oldest message is dropped and counted.
const std::string kSchemaV9 = std::string(R"sql(
ALTER TABLE runs ADD COLUMN uuid TEXT CHECK (uuid IS NULL OR length(uuid) = 36);
ALTER TABLE nc_pushes ADD COLUMN uuid TEXT CHECK (uuid IS NULL OR length(uuid) = 36);
ALTER TABLE events ADD COLUMN uuid TEXT CHECK (uuid IS NULL OR length(uuid) = 36);
UPDATE runs SET uuid = )sql") +
                              GL_SQL_UUID + R"sql(;
UPDATE nc_pushes SET uuid = )sql" +
                              GL_SQL_UUID + R"sql(;
UPDATE events SET uuid = )sql" +
                              GL_SQL_UUID + R"sql(;
CREATE UNIQUE INDEX runs_by_uuid ON runs (uuid);
CREATE UNIQUE INDEX nc_pushes_by_uuid ON nc_pushes (uuid);
CREATE UNIQUE INDEX events_by_uuid ON events (uuid);
CREATE TRIGGER runs_get_a_uuid AFTER INSERT ON runs WHEN NEW.uuid IS NULL BEGIN
  UPDATE runs SET uuid = )sql" +
                              GL_SQL_UUID + R"sql( WHERE id = NEW.id;
END;
CREATE TRIGGER nc_pushes_get_a_uuid AFTER INSERT ON nc_pushes WHEN NEW.uuid IS NULL BEGIN
  UPDATE nc_pushes SET uuid = )sql" +
                              GL_SQL_UUID + R"sql( WHERE id = NEW.id;
END;
CREATE TRIGGER events_get_a_uuid AFTER INSERT ON events WHEN NEW.uuid IS NULL BEGIN
  UPDATE events SET uuid = )sql" +
                              GL_SQL_UUID + R"sql( WHERE id = NEW.id;
END;

CREATE TABLE outbox_state (
  id            INTEGER PRIMARY KEY CHECK (id = 1),
  enabled       INTEGER NOT NULL DEFAULT 0 CHECK (enabled IN (0, 1)),
  max_depth     INTEGER NOT NULL DEFAULT 100000 CHECK (max_depth >= 1),
  depth         INTEGER NOT NULL DEFAULT 0,  -- messages waiting (kept by triggers)
  sent_total    INTEGER NOT NULL DEFAULT 0,  -- acknowledged by the broker
  dropped_total INTEGER NOT NULL DEFAULT 0   -- dropped over max_depth
);
INSERT INTO outbox_state (id) VALUES (1);
CREATE TABLE outbox (
  id          INTEGER PRIMARY KEY AUTOINCREMENT,  -- delivery order
  uuid        TEXT    NOT NULL UNIQUE CHECK (length(uuid) = 36),  -- the message's identity
  topic       TEXT    NOT NULL CHECK (topic IN ('run', 'nc', 'verdict', 'state')),
  run_id      INTEGER,  -- run, verdict: the run; nc: the push's run
  push_id     INTEGER,  -- nc: the push
  created_utc TEXT    NOT NULL,
  payload     TEXT      -- verdict, state: the JSON published; run, nc: NULL, made from the record
);
CREATE TRIGGER outbox_counted_on_insert AFTER INSERT ON outbox BEGIN
  UPDATE outbox_state SET depth = depth + 1;
  UPDATE outbox_state SET dropped_total = dropped_total + 1 WHERE depth > max_depth;
  DELETE FROM outbox WHERE id = (SELECT min(id) FROM outbox)
    AND (SELECT depth > max_depth FROM outbox_state);
END;
CREATE TRIGGER outbox_counted_on_delete AFTER DELETE ON outbox BEGIN
  UPDATE outbox_state SET depth = depth - 1;
END;
CREATE TRIGGER runs_to_outbox AFTER INSERT ON runs WHEN (SELECT enabled FROM outbox_state) BEGIN
  INSERT INTO outbox (uuid, topic, run_id, created_utc)
    VALUES ()sql" + GL_SQL_UUID +
                              R"sql(, 'run', NEW.id, strftime('%Y-%m-%dT%H:%M:%SZ', 'now'));
  -- The lobe's verdict changed from its previous run's (or it is the lobe's first run).
  INSERT INTO outbox (uuid, topic, run_id, created_utc, payload)
    SELECT )sql" + GL_SQL_UUID +
                              R"sql(, 'verdict', NEW.id, strftime('%Y-%m-%dT%H:%M:%SZ', 'now'),
           json_object('run_id', NEW.id, 'machine', NEW.machine, 'part', NEW.part, 'lobe', NEW.lobe,
                       'started_utc', NEW.started_utc, 'verdict', coalesce(NEW.verdict, 'not_judged'),
                       'previous_verdict', previous.verdict, 'previous_run_id', previous.id)
    FROM (SELECT NULL) LEFT JOIN (SELECT id, coalesce(verdict, 'not_judged') AS verdict FROM runs
                                  WHERE machine = NEW.machine AND part = NEW.part AND lobe = NEW.lobe
                                    AND id < NEW.id
                                  ORDER BY started_utc DESC, id DESC LIMIT 1) AS previous
    WHERE previous.verdict IS NOT coalesce(NEW.verdict, 'not_judged');
END;
CREATE TRIGGER nc_pushes_to_outbox AFTER INSERT ON nc_pushes WHEN (SELECT enabled FROM outbox_state) BEGIN
  INSERT INTO outbox (uuid, topic, run_id, push_id, created_utc)
    VALUES ()sql" + GL_SQL_UUID +
                              R"sql(, 'nc', NEW.run_id, NEW.id, strftime('%Y-%m-%dT%H:%M:%SZ', 'now'));
END;
)sql";
#undef GL_SQL_UUID

// Version 10: a program written from a drawing, before any part was measured (`gaugeloop nc
// new`), is pushed with no run behind it: nc_pushes.run_id and nc_push_intents.run_id may be
// NULL. SQLite's own procedure for dropping a NOT NULL constraint (the ALTER TABLE page,
// "making other kinds of table schema changes"): edit the table's CREATE text in
// sqlite_schema and bump the schema cookie, inside the migration's transaction. A rebuild of
// nc_pushes would fire the ON DELETE SET NULL of nc_pending.push_id while foreign keys are on.
// The edit is refused (the transaction rolls back) unless each CREATE text holds the column
// exactly as earlier versions wrote it.
constexpr std::string_view kSchemaV10 = R"sql(
PRAGMA writable_schema = ON;
UPDATE sqlite_schema
  SET sql = replace(sql, 'run_id            INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,',
                         'run_id            INTEGER REFERENCES runs (id) ON DELETE CASCADE,  -- NULL: written by nc new')
  WHERE type = 'table' AND name = 'nc_pushes';
UPDATE sqlite_schema
  SET sql = replace(sql, 'run_id            INTEGER NOT NULL REFERENCES runs (id),',
                         'run_id            INTEGER REFERENCES runs (id),  -- NULL: written by nc new')
  WHERE type = 'table' AND name = 'nc_push_intents';
PRAGMA writable_schema = OFF;
)sql";

// Runs stored before version 8 were never judged: their verdict says so from version 11, so that
// filtering by verdict is one comparison runs_by_verdict serves (NULL is outside that index).
constexpr std::string_view kSchemaV11 = R"sql(
UPDATE runs SET verdict = 'not_judged' WHERE verdict IS NULL;
)sql";

// Version 12: gears measured on a gear checker, with ids of their own (docs/gears.md, "Gear
// runs"): one row per gear with its ISO 1328-1 summary and verdict, one per lead trace (a tooth
// gap's flank) with its figures and the trace itself as JSON arrays of numbers.
constexpr std::string_view kSchemaV12 = R"sql(
CREATE TABLE gear_runs (
  id                   INTEGER PRIMARY KEY AUTOINCREMENT,
  started_utc          TEXT    NOT NULL,
  machine              TEXT    NOT NULL,
  part                 TEXT    NOT NULL,
  source               TEXT    NOT NULL,  -- where the traces came from: the checker, a file
  serial               TEXT    CHECK (serial IS NULL OR length(serial) BETWEEN 1 AND 64),
  operator             TEXT    CHECK (operator IS NULL OR length(operator) BETWEEN 1 AND 64),
  note                 TEXT    NOT NULL DEFAULT '',
  nc_file              TEXT    NOT NULL,  -- the stroke program the gear was ground from
  ground_with_version  INTEGER CHECK (ground_with_version >= 1),  -- NULL: not known
  required_class       INTEGER CHECK (required_class BETWEEN 1 AND 11),  -- NULL: not judged
  total_tolerance_um   REAL    CHECK (total_tolerance_um > 0),  -- F_betaT of required_class
  verdict              TEXT    NOT NULL CHECK (verdict IN ('in', 'out', 'not_judged')),
  tolerance_class      INTEGER NOT NULL CHECK (tolerance_class BETWEEN 1 AND 12),  -- the worst flank's
  total_max_um         REAL    NOT NULL,  -- F_beta, the worst flank
  total_mean_um        REAL    NOT NULL,
  form_mean_um         REAL    NOT NULL,  -- f_f_beta
  slope_mean_abs_um    REAL    NOT NULL,  -- |f_H_beta|
  pushed_version       INTEGER CHECK (pushed_version >= 1),  -- the stroke pushed from it; NULL: none
  mesh_residual_rms_um REAL,  -- of the fit that pushed it
  CHECK ((verdict = 'not_judged') = (required_class IS NULL)),
  CHECK ((total_tolerance_um IS NULL) = (required_class IS NULL))
);
CREATE INDEX gear_runs_by_part_started ON gear_runs (part, started_utc);
CREATE INDEX gear_runs_by_started ON gear_runs (started_utc);

CREATE TABLE gear_run_traces (
  run_id          INTEGER NOT NULL REFERENCES gear_runs (id) ON DELETE CASCADE,
  gap             INTEGER NOT NULL CHECK (gap >= 1),
  flank           TEXT    NOT NULL CHECK (flank IN ('left', 'right')),
  total_um        REAL    NOT NULL,  -- F_beta
  form_um         REAL    NOT NULL,  -- f_f_beta
  slope_um        REAL    NOT NULL,  -- f_H_beta
  tolerance_class INTEGER NOT NULL CHECK (tolerance_class BETWEEN 1 AND 12),
  from_mm         REAL    NOT NULL,  -- the evaluation range along Z
  to_mm           REAL    NOT NULL,
  z_mm            TEXT    NOT NULL CHECK (json_valid(z_mm) AND json_array_length(z_mm) >= 3),
  deviation_um    TEXT    NOT NULL
                  CHECK (json_valid(deviation_um) AND json_array_length(deviation_um) = json_array_length(z_mm)),
  PRIMARY KEY (run_id, gap, flank)
) WITHOUT ROWID;
)sql";

// Version 13: a gear's stroke corrected from a gear run may wait for approval as a curve table
// does: nc_pending.run_id may be NULL (a stroke has no lobe run behind it) and gear_run_id names
// the gear run instead. The column is added first (ALTER TABLE rewrites the CREATE text from
// the schema it has read), then NOT NULL is dropped in place as version 10 did.
constexpr std::string_view kSchemaV13 = R"sql(
ALTER TABLE nc_pending ADD COLUMN gear_run_id INTEGER REFERENCES gear_runs (id) ON DELETE CASCADE;
PRAGMA writable_schema = ON;
UPDATE sqlite_schema
  SET sql = replace(sql, 'run_id            INTEGER NOT NULL REFERENCES runs (id) ON DELETE CASCADE,',
                         'run_id            INTEGER REFERENCES runs (id) ON DELETE CASCADE,  -- NULL: a gear''s stroke')
  WHERE type = 'table' AND name = 'nc_pending';
PRAGMA writable_schema = OFF;
)sql";

// Version 14: a run may say the part was ground with the table the main program on the control
// coupled (ground_with_source 'main_program'): a push cut after its table and before its main
// program leaves the control grinding the older table. Widening a CHECK in place, as version
// 10 dropped a NOT NULL: every stored row holds under the wider rule.
constexpr std::string_view kSchemaV14 = R"sql(
PRAGMA writable_schema = ON;
UPDATE sqlite_schema
  SET sql = replace(sql, 'CHECK (ground_with_source IN (''plc'', ''option'', ''assumed''))',
                         'CHECK (ground_with_source IN (''plc'', ''option'', ''assumed'', ''main_program''))')
  WHERE type = 'table' AND name = 'runs';
PRAGMA writable_schema = OFF;
)sql";

// Version 15: `runs list --part P` (and GET /api/runs?part=P) without a lobe read every run of
// the part and sorted them (runs_by_part_lobe_started gives no time order across lobes); this
// index gives the newest runs of a part in order.
constexpr std::string_view kSchemaV15 = R"sql(
CREATE INDEX runs_by_part_started ON runs (part, started_utc);
)sql";

// Version 16: a lobe ground at a work speed program has its speed subprogram kept with its
// pending table, so that approving the table writes the speed that goes with it (NULL: a table
// without one, or kept before this version).
constexpr std::string_view kSchemaV16 = R"sql(
ALTER TABLE nc_pending ADD COLUMN speed_program_text TEXT CHECK (speed_program_text <> '');
)sql";

// Version 17: the band of harmonics a run's correction fed back (0..harmonics_fed_back) and the
// amplitude a harmonic had to exceed to count as measured (NULL: the band was fixed, or the
// revolutions showed no spread); both NULL for an inspection and for runs stored before.
constexpr std::string_view kSchemaV17 = R"sql(
ALTER TABLE runs ADD COLUMN harmonics_fed_back INTEGER CHECK (harmonics_fed_back BETWEEN 0 AND 180);
ALTER TABLE runs ADD COLUMN harmonic_threshold_um REAL CHECK (harmonic_threshold_um >= 0);
)sql";

// Version 18: the history names an NC program by its file name inside the NC directory its
// pushes go to (nc_directory), not by an absolute path, so that a data directory copied, moved or
// restored from a backup checks, rolls back and pushes into the directory it is used with. The
// directory of the newest push (else pending table, gear run, pushed run) becomes the history's;
// paths in it become names; paths elsewhere stay as they are (all of them, in a history that
// already holds a bare name).
constexpr std::string_view kSchemaV18 = R"sql(
CREATE TABLE nc_directory (
  id    INTEGER PRIMARY KEY CHECK (id = 1),
  path  TEXT    NOT NULL CHECK (path <> '')  -- where the programs the history names by file name are
);
CREATE TEMP TABLE v18_dir AS
  SELECT d FROM (
    SELECT rtrim(nc_file, replace(nc_file, '/', '')) AS d, 1 AS k, id FROM nc_pushes
    UNION ALL SELECT rtrim(nc_file, replace(nc_file, '/', '')), 2, id FROM nc_push_intents
    UNION ALL SELECT rtrim(nc_file, replace(nc_file, '/', '')), 3, id FROM nc_pending
    UNION ALL SELECT rtrim(nc_file, replace(nc_file, '/', '')), 4, id FROM gear_runs
    UNION ALL SELECT rtrim(nc_file, replace(nc_file, '/', '')), 5, id FROM runs WHERE nc_file IS NOT NULL)
  WHERE length(d) > 1
    AND NOT EXISTS (SELECT 1 FROM nc_pushes WHERE instr(nc_file, '/') = 0
                    UNION ALL SELECT 1 FROM nc_push_intents WHERE instr(nc_file, '/') = 0
                    UNION ALL SELECT 1 FROM nc_pending WHERE instr(nc_file, '/') = 0
                    UNION ALL SELECT 1 FROM gear_runs WHERE instr(nc_file, '/') = 0
                    UNION ALL SELECT 1 FROM runs WHERE instr(nc_file, '/') = 0)
  ORDER BY k, id DESC LIMIT 1;
INSERT INTO nc_directory (id, path) SELECT 1, substr(d, 1, length(d) - 1) FROM v18_dir;
UPDATE nc_pushes SET nc_file = substr(nc_file, length((SELECT d FROM v18_dir)) + 1)
  WHERE rtrim(nc_file, replace(nc_file, '/', '')) = (SELECT d FROM v18_dir);
UPDATE nc_push_intents SET nc_file = substr(nc_file, length((SELECT d FROM v18_dir)) + 1)
  WHERE rtrim(nc_file, replace(nc_file, '/', '')) = (SELECT d FROM v18_dir);
UPDATE nc_pending SET nc_file = substr(nc_file, length((SELECT d FROM v18_dir)) + 1)
  WHERE rtrim(nc_file, replace(nc_file, '/', '')) = (SELECT d FROM v18_dir);
UPDATE gear_runs SET nc_file = substr(nc_file, length((SELECT d FROM v18_dir)) + 1)
  WHERE rtrim(nc_file, replace(nc_file, '/', '')) = (SELECT d FROM v18_dir);
UPDATE runs SET nc_file = substr(nc_file, length((SELECT d FROM v18_dir)) + 1)
  WHERE nc_file IS NOT NULL AND rtrim(nc_file, replace(nc_file, '/', '')) = (SELECT d FROM v18_dir);
DROP TABLE v18_dir;
)sql";

// After an in-place edit of CREATE texts (versions 10, 13 and 14): `edited` tables must hold
// `marker` (else the edit found the text changed by hand and the migration rolls back); then the
// schema cookie changes with the CREATE text, so every connection reads it again.
Status bump_schema_cookie_after(Connection& conn, int version, const std::vector<std::string>& edited,
                                const std::string& marker) {
  const std::string operation = "migrate the schema to version " + std::to_string(version);
  std::string names;
  for (const std::string& t : edited) names += (names.empty() ? "'" : ", '") + t + "'";
  Result<Statement> count = Statement::prepare(conn,
                                               "SELECT count(*) FROM sqlite_schema WHERE type = 'table' AND name IN (" +
                                                   names + ") AND sql LIKE '%" + marker + "%'",
                                               operation);
  if (!count.ok()) return count.error();
  Result<bool> row = count->step();
  if (!row.ok()) return row.error();
  if (!*row || count->column<int>(0) != static_cast<int>(edited.size())) {
    std::string list;
    for (const std::string& t : edited) list += (list.empty() ? "" : " or ") + t;
    return make_error(ErrorCode::kStorage, operation + ": " + list + " in " + conn.path.string() +
                                               " is not as gaugeloop created it (a column of it was changed by "
                                               "hand); restore a backup or ask for help, nothing was changed");
  }
  std::int64_t next = 0;
  {
    Result<Statement> cookie = Statement::prepare(conn, "PRAGMA schema_version", "read the schema cookie");
    if (!cookie.ok()) return cookie.error();
    Result<bool> c = cookie->step();
    if (!c.ok()) return c.error();
    next = cookie->column<std::int64_t>(0) + 1;
  }
  return exec(conn, ("PRAGMA schema_version = " + std::to_string(next)).c_str(), "bump the schema cookie");
}

Status bump_schema_cookie(Connection& conn) {
  return bump_schema_cookie_after(conn, 10, {"nc_pushes", "nc_push_intents"}, "written by nc new");
}

Status bump_schema_cookie_v13(Connection& conn) {
  return bump_schema_cookie_after(conn, 13, {"nc_pending"}, "NULL: a gear''s stroke");
}

Status bump_schema_cookie_v14(Connection& conn) {
  return bump_schema_cookie_after(conn, 14, {"runs"}, "''assumed'', ''main_program''");
}

// A checksum over each run's per-degree BLOBs as stored (degree_blob.h): a page changed outside
// SQLite's notice (its own checks read structure, not the numbers in a BLOB) is found when the
// run is read and by `db check`. NULL for the rows stored before: not checked.
constexpr std::string_view kSchemaV19 = R"sql(
ALTER TABLE run_tables ADD COLUMN checksum INTEGER;
ALTER TABLE run_raw ADD COLUMN checksum INTEGER;
)sql";

// Every file of a push, with the hash of what was written: the table, its main program, its speed
// subprogram, a crankpin's Y table. The texts of the files beside the table are kept (the table's
// is in nc_pushes.program_text), so that reconciliation can put back one left from another push.
// Pushes recorded before: no rows, compared by their table alone.
constexpr std::string_view kSchemaV20 = R"sql(
CREATE TABLE nc_push_files (
  intent_id INTEGER NOT NULL REFERENCES nc_push_intents (id),
  role      TEXT    NOT NULL CHECK (role IN ('table', 'main', 'speed', 'y')),
  file      TEXT    NOT NULL,  -- as nc_pushes.nc_file: the name inside the NC directory
  hash      TEXT    NOT NULL,
  text      TEXT,              -- NULL for the table
  PRIMARY KEY (intent_id, role)
) WITHOUT ROWID;
CREATE INDEX nc_push_files_by_file ON nc_push_files (file, hash);
)sql";

// A gear's profiles at the face's middle beside its leads, each with its ISO 1328-1 figures, and
// the F_alpha tolerance of the class the gear was judged against. Gears stored before: no rows.
constexpr std::string_view kSchemaV21 = R"sql(
ALTER TABLE gear_runs ADD COLUMN profile_tolerance_um REAL CHECK (profile_tolerance_um > 0);
CREATE TABLE gear_run_profiles (
  run_id          INTEGER NOT NULL REFERENCES gear_runs (id) ON DELETE CASCADE,
  gap             INTEGER NOT NULL CHECK (gap >= 1),
  flank           TEXT    NOT NULL CHECK (flank IN ('left', 'right')),
  total_um        REAL    NOT NULL,  -- F_alpha
  form_um         REAL    NOT NULL,  -- f_f_alpha
  slope_um        REAL    NOT NULL,  -- f_H_alpha
  tolerance_class INTEGER NOT NULL CHECK (tolerance_class BETWEEN 1 AND 12),
  from_roll_mm    REAL    NOT NULL,  -- the evaluation range along the roll length
  to_roll_mm      REAL    NOT NULL,
  roll_mm         TEXT    NOT NULL CHECK (json_valid(roll_mm) AND json_array_length(roll_mm) >= 3),
  deviation_um    TEXT    NOT NULL
                  CHECK (json_valid(deviation_um) AND json_array_length(deviation_um) = json_array_length(roll_mm)),
  PRIMARY KEY (run_id, gap, flank)
) WITHOUT ROWID;
)sql";

// The runs whose raw samples were pruned, in the order the central sync follows the prunes in
// (RunStore::runs_pruned_after); only those, so the index is empty until the first prune.
constexpr std::string_view kSchemaV22 = R"sql(
CREATE INDEX runs_by_raw_pruned ON runs (raw_pruned_utc, id) WHERE raw_pruned_utc IS NOT NULL;
)sql";

// The slides' compensation tables pushed as one version: the CEC file beside the LEC file
// (role 'cec'). SQLite cannot change a CHECK constraint in place: the table is made anew.
constexpr std::string_view kSchemaV23 = R"sql(
CREATE TABLE nc_push_files_v23 (
  intent_id INTEGER NOT NULL REFERENCES nc_push_intents (id),
  role      TEXT    NOT NULL CHECK (role IN ('table', 'main', 'speed', 'y', 'cec')),
  file      TEXT    NOT NULL,  -- as nc_pushes.nc_file: the name inside the NC directory
  hash      TEXT    NOT NULL,
  text      TEXT,              -- NULL for the table
  PRIMARY KEY (intent_id, role)
) WITHOUT ROWID;
INSERT INTO nc_push_files_v23 (intent_id, role, file, hash, text)
  SELECT intent_id, role, file, hash, text FROM nc_push_files;
DROP TABLE nc_push_files;
ALTER TABLE nc_push_files_v23 RENAME TO nc_push_files;
CREATE INDEX nc_push_files_by_file ON nc_push_files (file, hash);
)sql";

const std::array<Migration, 23>& all_migrations() {
  static const std::array<Migration, 23> kMigrations{{
      {1, "runs, run_revolutions, run_profile, run_samples view", std::string(kSchemaV1), nullptr, {}},
      {2,
       "compact per-degree BLOBs (run_raw, run_tables) behind views; parts, lobes, settings, inspection "
       "figures, nc_pushes, events",
       std::string(kSchemaV2Before), convert_v1_rows, schema_v2_after()},
      {3,
       "nc_pushes: table versions, reason, interpolation, blocks, command position error, program text; "
       "nc_pending: tables awaiting approval",
       std::string(kSchemaV3),
       nullptr,
       {}},
      {4,
       "events: kind 'info' for the service's steps (PLC requests, cycle outcomes, config reloads)",
       std::string(kSchemaV4),
       nullptr,
       {}},
      {5,
       "nc_push_intents: the push journal; runs: the table version that ground the part, inspection runs",
       std::string(kSchemaV5),
       nullptr,
       {}},
      {6,
       "runs_by_lobe_started and row_counts (kept by triggers): what /metrics reads without reading the history",
       std::string(kSchemaV6),
       nullptr,
       {}},
      {7, "runs: the part's serial number and the operator who measured it", std::string(kSchemaV7), nullptr, {}},
      {8,
       "runs judged against their tolerances: run_characteristics, verdicts, the best-fit profile error, dial "
       "runout and roundness",
       std::string(kSchemaV8),
       nullptr,
       {}},
      {9,
       "one plant, many grinders: UUIDs on runs, pushes and events; the outbox of plant messages",
       kSchemaV9,
       nullptr,
       {}},
      {10,
       "a program written from a drawing (nc new): a push and its intent with no run behind them",
       std::string(kSchemaV10),
       bump_schema_cookie,
       {}},
      {11,
       "runs stored before version 8 say `not_judged`, so the verdict filter is served by its index",
       std::string(kSchemaV11),
       nullptr,
       {}},
      {12,
       "gear runs: a gear checker's lead traces, their ISO 1328-1 figures and the gear's verdict",
       std::string(kSchemaV12),
       nullptr,
       {}},
      {13,
       "a gear's stroke waits for approval as a table does: nc_pending.gear_run_id, nc_pending.run_id may be NULL",
       std::string(kSchemaV13),
       bump_schema_cookie_v13,
       {}},
      {14,
       "runs: the part was ground with the table the main program on the control coupled (ground_with_source "
       "main_program)",
       std::string(kSchemaV14),
       bump_schema_cookie_v14,
       {}},
      {15, "runs: an index by part and time, for the newest runs of a part", std::string(kSchemaV15), nullptr, {}},
      {16,
       "nc_pending: the speed subprogram of a lobe ground at a work speed program, written when its table is "
       "approved",
       std::string(kSchemaV16),
       nullptr,
       {}},
      {17,
       "runs: the band of harmonics the correction fed back and the threshold that chose it",
       std::string(kSchemaV17),
       nullptr,
       {}},
      {18,
       "the NC directory the pushes go to (nc_directory); programs in it named by their file name",
       std::string(kSchemaV18),
       nullptr,
       {}},
      {19,
       "a checksum over each run's stored per-degree numbers (run_tables, run_raw), checked as they are read",
       std::string(kSchemaV19),
       nullptr,
       {}},
      {20,
       "nc_push_files: every file of a push (table, main program, speed subprogram, Y table) with the hash of "
       "what was written",
       std::string(kSchemaV20),
       nullptr,
       {}},
      {21,
       "gear runs: the profiles at the face's middle with their ISO 1328-1 figures, and the F_alpha tolerance "
       "judged against",
       std::string(kSchemaV21),
       nullptr,
       {}},
      {22,
       "runs: an index of the runs whose raw samples were pruned (runs_by_raw_pruned)",
       std::string(kSchemaV22),
       nullptr,
       {}},
      {23,
       "nc_push_files: the slides' CEC file pushed beside their LEC file (role cec)",
       std::string(kSchemaV23),
       nullptr,
       {}},
  }};
  return kMigrations;
}

Result<int> read_user_version(Connection& conn) {
  Result<Statement> stmt = Statement::prepare(conn, "PRAGMA user_version", "read the schema version");
  if (!stmt.ok()) return stmt.error();
  Result<bool> row = stmt->step();
  if (!row.ok()) return row.error();
  return *row ? stmt->column<int>(0) : 0;
}

Error too_new(const Connection& conn, int version) {
  return make_error(ErrorCode::kStorage, "run database " + conn.path.string() + " has schema version " +
                                             std::to_string(version) + ", newer than this gaugeloop understands (" +
                                             std::to_string(latest_schema_version()) +
                                             "); run a newer gaugeloop or point --data-dir elsewhere");
}

}  // namespace

std::span<const Migration> migrations() { return all_migrations(); }

int latest_schema_version() { return all_migrations().back().version; }

std::string_view schema_v1_sql() { return kSchemaV1; }

Status apply_migrations(Connection& conn) { return apply_migrations_up_to(conn, latest_schema_version()); }

Status apply_migrations_up_to(Connection& conn, int target) {
  Result<int> version = read_user_version(conn);
  if (!version.ok()) return version.error();
  if (*version > latest_schema_version()) return too_new(conn, *version);

  for (const Migration& m : all_migrations()) {
    if (m.version <= *version || m.version > target) continue;
    const std::string operation = "migrate the schema to version " + std::to_string(m.version);
    Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
    if (!tx.ok()) return tx.error();
    // Read again under the write lock: another process may have migrated meanwhile.
    version = read_user_version(conn);
    if (!version.ok()) return version.error();
    if (*version > latest_schema_version()) return too_new(conn, *version);
    if (m.version <= *version) continue;  // the transaction rolls back, nothing was written

    Status applied = exec(conn, m.sql.c_str(), operation);
    if (!applied.ok()) return applied;
    if (m.convert != nullptr) {
      applied = m.convert(conn);
      if (!applied.ok()) return applied;
    }
    const std::string after = m.sql_after + "\nPRAGMA user_version = " + std::to_string(m.version) + ";";
    applied = exec(conn, after.c_str(), operation);
    if (!applied.ok()) return applied;
    Status committed = tx->commit();
    if (!committed.ok()) return committed;
    *version = m.version;
  }
  return {};
}

Result<int> schema_version_not_newer(Connection& conn) {
  Result<int> version = read_user_version(conn);
  if (version.ok() && *version > latest_schema_version()) return too_new(conn, *version);
  return version;
}

Status refuse_foreign_database(Connection& conn) {
  if (conn.path == ":memory:") return {};
  // A file that cannot be read as a database at all is the caller's to report (damaged).
  Result<int> version = read_user_version(conn);
  if (!version.ok() || *version != 0) return {};
  Result<Statement> tables = Statement::prepare(
      conn,
      "SELECT count(*), coalesce(group_concat(name, ', '), '') FROM (SELECT name FROM sqlite_schema WHERE type = "
      "'table' AND name NOT LIKE 'sqlite\\_%' ESCAPE '\\' ORDER BY name LIMIT 6)",
      "read the database's tables");
  if (!tables.ok()) return {};
  Result<bool> row = tables->step();
  if (!row.ok() || !*row || tables->column<int>(0) == 0) return {};
  return make_error(ErrorCode::kStorage,
                    "database " + conn.path.string() +
                        " is a SQLite file gaugeloop did not write (no gaugeloop schema version, tables " +
                        tables->column<std::string>(1) +
                        "); gaugeloop keeps its runs in a database of its own: point --data-dir, --db or the "
                        "config at one (a new directory starts an empty one). Nothing was changed");
}

}  // namespace gaugeloop::storage_internal
