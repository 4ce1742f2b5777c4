// The run database: every measurement run, its analysis and its correction, kept in SQLite.
#include "storage/run_store.h"

#include <array>
#include <cctype>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <ctime>
#include <string_view>
#include <system_error>
#include <utility>

#include "core/utc_time.h"
#include "storage/degree_blob.h"
#include "storage/degree_json.h"
#include "storage/maintenance_internal.h"
#include "storage/migrations.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::Connection;
using storage_internal::Statement;
using storage_internal::Transaction;

namespace {

constexpr std::string_view kInMemory = ":memory:";

// ---- Validation: everything a record must satisfy before a single row is written ----

Error refused(const std::string& why) { return make_error(ErrorCode::kInvalidInput, "run not stored: " + why); }

std::string describe_non_finite(double value) {
  if (std::isnan(value)) return "NaN";
  return value > 0 ? "+infinity" : "-infinity";
}

Status check_table(const DegreeTable& table, std::string_view column, std::string_view frame) {
  for (std::size_t deg = 0; deg < table.size(); ++deg) {
    if (!std::isfinite(table[deg])) {
      return refused(std::string(column) + " at " + std::string(frame) + " degree " + std::to_string(deg) + " is " +
                     describe_non_finite(table[deg]) +
                     "; the computation that produced it failed, nothing was written");
    }
  }
  return {};
}

Status check_figure(double value, std::string_view column) {
  if (std::isfinite(value)) return {};
  return refused(std::string(column) + " is " + describe_non_finite(value) +
                 "; the computation that produced it failed, nothing was written");
}

// The non-finite checks matter beyond tidiness: SQLite binds a NaN double as NULL, and a
// per-degree BLOB holds integers only.
Status validate(const RunRecord& run) {
  if (!is_utc_timestamp(run.started_utc)) {
    return refused("started_utc '" + run.started_utc + "' is not an ISO 8601 UTC time like 2026-11-22T02:34:44Z");
  }
  if (!is_utc_timestamp(run.finished_utc)) {
    return refused("finished_utc '" + run.finished_utc + "' is not an ISO 8601 UTC time like 2026-11-22T02:34:44Z");
  }
  if (run.finished_utc < run.started_utc) {
    return refused("finished_utc " + run.finished_utc + " is before started_utc " + run.started_utc);
  }
  if (run.machine.empty()) return refused("the machine name is empty");
  if (run.part.empty()) return refused("the part name is empty");
  if (run.lobe < 1) return refused("lobe " + std::to_string(run.lobe) + " is not 1 or more");

  const MeasuredRun& m = run.measured;
  if (m.revolutions.size() < 3) {
    return refused("a run needs at least 3 complete revolutions, this one has " + std::to_string(m.revolutions.size()));
  }
  if (m.revolutions.size() > static_cast<std::size_t>(INT_MAX / kDegreesPerRevolution)) {
    return refused(std::to_string(m.revolutions.size()) + " revolutions are too many");
  }
  if (m.polls < 0 || m.reconnects < 0 || m.discarded_revolutions < 0) {
    return refused("a negative count of polls, reconnects or discarded revolutions");
  }
  for (std::size_t i = 0; i < m.revolutions.size(); ++i) {
    const RevolutionSamples& rev = m.revolutions[i];
    // Acquisition keeps complete revolutions in the order the amplifier counted them; a
    // repeat or a step back means samples were mixed up.
    if (i > 0 && rev.revolution <= m.revolutions[i - 1].revolution) {
      return refused("revolution " + std::to_string(i) + " has amplifier revolution count " +
                     std::to_string(rev.revolution) + ", not after the previous one (" +
                     std::to_string(m.revolutions[i - 1].revolution) +
                     "); the revolutions are out of order or repeated");
    }
    Status ok = check_table(rev.lift_mm, "run_samples.lift_mm of revolution " + std::to_string(i), "machine");
    if (!ok.ok()) return ok;
  }

  const LobeAnalysis& a = run.analysis;
  const std::pair<const DegreeTable*, std::string_view> tables[] = {
      {&a.design_lift_mm, "run_profile.design_lift_mm"}, {&a.mean_lift_mm, "run_profile.mean_lift_mm"},
      {&a.spread_um, "run_profile.spread_um"},           {&a.error_um, "run_profile.error_um"},
      {&run.correction_um, "run_profile.correction_um"},
  };
  for (const auto& [table, column] : tables) {
    Status ok = check_table(*table, column, "cam");
    if (!ok.ok()) return ok;
  }
  const std::pair<double, std::string_view> figures[] = {
      {a.zero_offset_mm, "runs.zero_offset_mm"},     {a.max_abs_error_um, "runs.max_abs_error_um"},
      {a.rms_error_um, "runs.rms_error_um"},         {a.peak_to_valley_um, "runs.peak_to_valley_um"},
      {a.repeatability_um, "runs.repeatability_um"},
  };
  for (const auto& [value, column] : figures) {
    Status ok = check_figure(value, column);
    if (!ok.ok()) return ok;
  }
  for (std::size_t h = 0; h < a.harmonic_amplitude_um.size(); ++h) {
    Status ok = check_figure(a.harmonic_amplitude_um[h], "runs.harmonic_amplitude_um harmonic " + std::to_string(h));
    if (!ok.ok()) return ok;
  }
  if (run.ground_with_version && *run.ground_with_version < 1) {
    return refused("ground_with_version " + std::to_string(*run.ground_with_version) + " is not 1 or more");
  }
  if (!run.ground_with_source.empty() && run.ground_with_source != "plc" && run.ground_with_source != "option" &&
      run.ground_with_source != "assumed") {
    return refused("ground_with_source '" + run.ground_with_source + "' is not plc, option or assumed");
  }
  if (run.ground_with_version && run.ground_with_source.empty()) {
    return refused("ground_with_version is set but not who said so (ground_with_source)");
  }
  if (run.geometry) {
    const Part& g = *run.geometry;
    if (g.rotation_sense != 1 && g.rotation_sense != -1) {
      return refused("the rotation sense is " + std::to_string(g.rotation_sense) + ", not +1 or -1");
    }
    const std::pair<double, std::string_view> geometry[] = {
        {g.follower_radius_mm, "parts.follower_radius_mm"}, {g.base_circle_radius_mm, "parts.base_circle_radius_mm"},
        {g.wheel_radius_mm, "parts.wheel_radius_mm"},       {g.c_offset_deg, "runs.c_offset_deg"},
        {g.probe_offset_deg, "runs.probe_offset_deg"},
    };
    for (const auto& [value, column] : geometry) {
      Status ok = check_figure(value, column);
      if (!ok.ok()) return ok;
    }
  }
  return {};
}

bool is_time_bound(std::string_view s) { return s.empty() || is_utc_timestamp(s); }

std::string_view follower_db_name(FollowerKind kind) {
  switch (kind) {
    case FollowerKind::kFlat:
      return "flat";
    case FollowerKind::kRoller:
      return "roller";
    case FollowerKind::kKnifeEdge:
      return "knife_edge";
  }
  return "flat";
}

std::optional<FollowerKind> follower_from_db(std::string_view name) {
  if (name == "flat") return FollowerKind::kFlat;
  if (name == "roller") return FollowerKind::kRoller;
  if (name == "knife_edge") return FollowerKind::kKnifeEdge;
  return std::nullopt;
}

// Shortest text that reads back as the same double, for the harmonics JSON.
std::string exact_number(double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

// ---- SQL ----

constexpr std::string_view kInsertRun = R"sql(
INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, note, status,
                  revolutions, degrees_captured, polls, reconnects, discarded_revolutions,
                  zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um,
                  repeatability_um, nc_file, correction_in_force_run, settings_hash,
                  phase_error_deg, base_circle_runout_um, harmonic_amplitude_um,
                  rotation_sense, c_offset_deg, probe_offset_deg, ground_with_version,
                  ground_with_source, inspection)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 'measured', ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17,
        NULL, ?18, ?19, ?20, ?21, ?22, ?23, ?24, ?25, ?26, ?27, ?28))sql";

constexpr std::string_view kInsertRaw = R"sql(
INSERT INTO run_raw (run_id, amplifier_revolutions, lift) VALUES (?1, ?2, ?3))sql";

constexpr std::string_view kInsertTables = R"sql(
INSERT INTO run_tables (run_id, design_lift, mean_lift, spread, error, correction)
VALUES (?1, ?2, ?3, ?4, ?5, ?6))sql";

constexpr std::string_view kInsertSettings = "INSERT OR IGNORE INTO settings (hash, text) VALUES (?1, ?2)";

// The catalogue row exists (the runs trigger made it); a run that knows the geometry updates it.
constexpr std::string_view kUpdatePart = R"sql(
UPDATE parts SET follower = ?2, follower_radius_mm = ?3, base_circle_radius_mm = ?4,
                 wheel_radius_mm = ?5
WHERE name = ?1)sql";

constexpr std::string_view kUpdateLobe = R"sql(
UPDATE lobes SET rotation_sense = ?3, c_offset_deg = ?4, probe_offset_deg = ?5
WHERE part = ?1 AND lobe = ?2)sql";

// Columns 0..18, read by read_summary().
constexpr std::string_view kSummaryColumns =
    "r.id, r.started_utc, r.machine, r.part, r.lobe, r.status, r.revolutions, r.degrees_captured, "
    "r.max_abs_error_um, r.rms_error_um, r.repeatability_um, r.nc_file, r.phase_error_deg, "
    "r.base_circle_runout_um, r.peak_to_valley_um, r.settings_hash, r.note, r.raw_pruned_utc, r.zero_offset_mm";
constexpr int kSummaryColumnCount = 19;

std::string select_summaries(std::string_view rest) {
  return "SELECT " + std::string(kSummaryColumns) + " FROM runs AS r" + std::string(rest);
}

constexpr std::string_view kLoadDetails = R"sql(
SELECT r.finished_utc, r.gauge, r.polls, r.reconnects, r.discarded_revolutions,
       r.correction_in_force_run, s.text, r.harmonic_amplitude_um, r.rotation_sense, r.c_offset_deg,
       r.probe_offset_deg, p.follower, p.follower_radius_mm, p.base_circle_radius_mm, p.wheel_radius_mm,
       r.ground_with_version, r.ground_with_source, r.inspection
FROM runs AS r
LEFT JOIN settings AS s ON s.hash = r.settings_hash
LEFT JOIN parts AS p ON p.name = r.part
WHERE r.id = ?1)sql";

constexpr std::string_view kLoadRaw = "SELECT amplifier_revolutions, lift FROM run_raw WHERE run_id = ?1";

constexpr std::string_view kLoadTables =
    "SELECT design_lift, mean_lift, spread, error, correction FROM run_tables WHERE run_id = ?1";

// Columns 0..11, read by read_push(); program_text, when selected, is column 12.
constexpr std::string_view kPushColumns =
    "p.id, p.run_id, p.pushed_utc, p.nc_file, p.table_version, p.reason, p.interpolation, p.block_count, "
    "p.command_error_um, p.point_count, p.correction_max_um, p.program_hash";
constexpr int kPushTextColumn = 12;

constexpr std::string_view kRecordNcFile = "UPDATE runs SET status = 'pushed', nc_file = ?2 WHERE id = ?1";

constexpr std::string_view kNextTableVersion =
    "SELECT coalesce(max(table_version), 0) + 1 FROM nc_pushes WHERE nc_file = ?1";

constexpr std::string_view kInsertPush = R"sql(
INSERT INTO nc_pushes (run_id, pushed_utc, nc_file, table_version, reason, interpolation, block_count,
                       command_error_um, point_count, correction_max_um, program_hash, program_text)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12))sql";

// Columns 0..17, read by read_pending(); program_text is column 4 ('' in lists).
constexpr std::string_view kPendingColumns =
    "id, run_id, created_utc, nc_file, {text}, verdict, reason, interpolation, block_count, command_error_um, "
    "correction_max_um, point_count, status, decided_utc, decided_by, note, push_id, superseded_by";

std::string select_pending(bool with_text, std::string_view rest) {
  std::string columns(kPendingColumns);
  columns.replace(columns.find("{text}"), 6, with_text ? "program_text" : "''");
  return "SELECT " + columns + " FROM nc_pending" + std::string(rest);
}

RunSummary read_summary(const Statement& s) {
  RunSummary r;
  r.id = s.column_int64(0);
  r.started_utc = s.column_text(1);
  r.machine = s.column_text(2);
  r.part = s.column_text(3);
  r.lobe = s.column_int(4);
  r.status = s.column_text(5);
  r.revolutions = s.column_int(6);
  r.degrees_captured = s.column_int(7);
  r.max_abs_error_um = s.column_double(8);
  r.rms_error_um = s.column_double(9);
  r.repeatability_um = s.column_double(10);
  r.nc_file = s.column_text(11);  // NULL reads as ""
  if (!s.column_is_null(12)) r.phase_error_deg = s.column_double(12);
  if (!s.column_is_null(13)) r.base_circle_runout_um = s.column_double(13);
  r.peak_to_valley_um = s.column_double(14);
  r.settings_hash = s.column_text(15);
  r.note = s.column_text(16);
  r.raw_pruned_utc = s.column_text(17);
  return r;
}

NcPush read_push(const Statement& s, bool with_text) {
  NcPush p;
  p.id = s.column_int64(0);
  p.run_id = s.column_int64(1);
  p.pushed_utc = s.column_text(2);
  p.nc_file = s.column_text(3);
  p.table_version = s.column_int(4);
  p.reason = s.column_text(5);
  p.interpolation = s.column_text(6);
  if (!s.column_is_null(7)) p.block_count = s.column_int(7);
  if (!s.column_is_null(8)) p.command_error_um = s.column_double(8);
  if (!s.column_is_null(9)) p.point_count = s.column_int(9);
  if (!s.column_is_null(10)) p.correction_max_um = s.column_double(10);
  p.program_hash = s.column_text(11);
  if (with_text && !s.column_is_null(kPushTextColumn)) p.program_text = s.column_text(kPushTextColumn);
  return p;
}

std::optional<PendingStatus> pending_status_from_db(std::string_view name) {
  for (PendingStatus st :
       {PendingStatus::kPending, PendingStatus::kApproved, PendingStatus::kRejected, PendingStatus::kSuperseded}) {
    if (pending_status_name(st) == name) return st;
  }
  return std::nullopt;
}

PendingTable read_pending(const Statement& s) {
  PendingTable t;
  t.id = s.column_int64(0);
  t.run_id = s.column_int64(1);
  t.created_utc = s.column_text(2);
  t.nc_file = s.column_text(3);
  t.program_text = s.column_text(4);
  t.verdict = s.column_text(5) == "hold" ? PendingVerdict::kHold : PendingVerdict::kApply;
  t.reason = s.column_text(6);
  t.interpolation = s.column_text(7);
  if (!s.column_is_null(8)) t.block_count = s.column_int(8);
  if (!s.column_is_null(9)) t.command_error_um = s.column_double(9);
  if (!s.column_is_null(10)) t.correction_max_um = s.column_double(10);
  if (!s.column_is_null(11)) t.point_count = s.column_int(11);
  // The schema's CHECK admits only the four names.
  t.status = pending_status_from_db(s.column_text(12)).value_or(PendingStatus::kPending);
  t.decided_utc = s.column_text(13);
  t.decided_by = s.column_text(14);
  t.note = s.column_text(15);
  if (!s.column_is_null(16)) t.push_id = s.column_int64(16);
  if (!s.column_is_null(17)) t.superseded_by = s.column_int64(17);
  return t;
}

void bind_optional(Statement& st, int index, const std::optional<int>& v) {
  if (v) {
    st.bind(index, *v);
  } else {
    st.bind_null(index);
  }
}

void bind_optional(Statement& st, int index, const std::optional<double>& v) {
  if (v) {
    st.bind(index, *v);
  } else {
    st.bind_null(index);
  }
}

// NULL for empty text: the columns that say "not recorded" with NULL.
void bind_text_or_null(Statement& st, int index, std::string_view v) {
  if (v.empty()) {
    st.bind_null(index);
  } else {
    st.bind(index, v);
  }
}

// What a push or a pending table says about its table, checked before anything is written.
// `what` opens the message: "cannot record NC file /nc/A.SPF for run 3".
Status check_table_figures(const std::string& what, const std::optional<int>& block_count,
                           const std::optional<double>& command_error_um, const std::optional<int>& point_count,
                           const std::optional<double>& correction_max_um) {
  if (block_count && *block_count < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      what + ": block_count " + std::to_string(*block_count) + " is negative");
  }
  if (point_count && *point_count < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      what + ": point_count " + std::to_string(*point_count) + " is negative");
  }
  if (command_error_um && !(std::isfinite(*command_error_um) && *command_error_um >= 0.0)) {
    return make_error(ErrorCode::kInvalidInput,
                      what + ": command_error_um is " +
                          (std::isfinite(*command_error_um) ? std::to_string(*command_error_um) + ", below 0"
                                                            : describe_non_finite(*command_error_um)));
  }
  if (correction_max_um && !std::isfinite(*correction_max_um)) {
    return make_error(ErrorCode::kInvalidInput, what + ": correction_max_um is not finite");
  }
  return {};
}

Error damaged(const Connection& conn, std::int64_t run_id, const std::string& what) {
  return make_error(ErrorCode::kStorage, "run database " + conn.path.string() + ": run " + std::to_string(run_id) +
                                             " is damaged: " + what +
                                             "; the rows were changed outside gaugeloop, restore a backup");
}

Error bad_bound(std::string_view what, const std::string& value) {
  return make_error(ErrorCode::kInvalidInput,
                    std::string(what) + " '" + value + "' is not an ISO 8601 UTC time like 2026-11-22T02:34:44Z");
}

// WHERE clause and its text parameters (numbered from ?2; ?1 is the limit) for a RunQuery.
struct Filter {
  std::string where;
  std::vector<std::string> text;
  std::optional<int> lobe;
};

Result<Filter> run_filter(const RunQuery& q) {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list runs: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  if (q.lobe < 0) {
    return make_error(ErrorCode::kInvalidInput, "cannot list runs: lobe " + std::to_string(q.lobe) + " is negative");
  }
  if (!q.status.empty() && q.status != "measured" && q.status != "pushed") {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list runs: status '" + q.status + "' is not one of measured, pushed");
  }
  if (!is_time_bound(q.since_utc)) return bad_bound("cannot list runs: since", q.since_utc);
  if (!is_time_bound(q.until_utc)) return bad_bound("cannot list runs: until", q.until_utc);
  Filter f;
  auto add = [&f](const std::string& column_op, const std::string& value) {
    f.text.push_back(value);
    f.where += (f.where.empty() ? " WHERE " : " AND ") + column_op + " ?" + std::to_string(f.text.size() + 1);
  };
  if (!q.part.empty()) add("r.part =", q.part);
  if (q.lobe > 0) {
    f.lobe = q.lobe;
    f.where += std::string(f.where.empty() ? " WHERE " : " AND ") + "r.lobe = " + std::to_string(q.lobe);
  }
  if (!q.machine.empty()) add("r.machine =", q.machine);
  if (!q.status.empty()) add("r.status =", q.status);
  if (!q.since_utc.empty()) add("r.started_utc >=", q.since_utc);
  if (!q.until_utc.empty()) add("r.started_utc <", q.until_utc);
  return f;
}

// Opens the connection and sets it up; the schema is not touched.
Result<std::unique_ptr<Connection>> connect(const std::filesystem::path& db_path) {
  const std::string shown = db_path.string();
  const bool in_memory = db_path == kInMemory;
  if (!in_memory && db_path.has_parent_path()) {
    std::error_code ec;
    std::filesystem::create_directories(db_path.parent_path(), ec);
    if (ec) {
      return make_error(ErrorCode::kIo, "cannot create directory " + db_path.parent_path().string() +
                                            " for run database " + shown + ": " + ec.message() +
                                            "; check the --data-dir is writable");
    }
  }

  auto conn = std::make_unique<Connection>();
  conn->path = db_path;
  // NOMUTEX: a connection is used by one thread only (see RunStore).
  const int flags = SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE | SQLITE_OPEN_NOMUTEX | SQLITE_OPEN_EXRESCODE;
  const int rc = sqlite3_open_v2(shown.c_str(), &conn->db, flags, nullptr);
  if (rc != SQLITE_OK) {
    const std::string reason = conn->db != nullptr ? sqlite3_errmsg(conn->db) : sqlite3_errstr(rc);
    return make_error(ErrorCode::kStorage,
                      "cannot open run database " + shown + ": " + reason + "; check the --data-dir is writable");
  }
  // SQLite silently falls back to read-only when the file exists but is not writable; we
  // would only find out at the first insert, after a whole measurement. A file without write
  // bits is refused for root too: readers open it immutable (RunStore::open_read_only).
  if (sqlite3_db_readonly(conn->db, "main") == 1 || storage_internal::has_no_write_bits(db_path)) {
    return make_error(ErrorCode::kStorage, "cannot open run database " + shown +
                                               " for writing: the file is read-only; check the file and the "
                                               "--data-dir are writable by this user");
  }
  sqlite3_busy_timeout(conn->db, storage_internal::kBusyTimeoutMs);

  Status s = storage_internal::exec(*conn, "PRAGMA foreign_keys = ON", "enable foreign keys");
  if (!s.ok()) return s.error();
  // synchronous stays at its default, FULL: a committed run survives a power cut.
  Result<Statement> wal = Statement::prepare(*conn, "PRAGMA journal_mode = WAL", "switch to WAL journal mode");
  if (!wal.ok()) return wal.error();
  Result<bool> row = wal->step();
  if (!row.ok()) return row.error();
  const std::string mode = *row ? wal->column_text(0) : std::string();
  if (!in_memory && mode != "wal") {
    return make_error(ErrorCode::kStorage, "run database " + shown + ": cannot switch to WAL journal mode (it stays '" +
                                               mode +
                                               "'), so readers would block the writer; keep the --data-dir on a "
                                               "local file system");
  }
  return conn;
}

}  // namespace

// ---- RunStore ----

RunStore::RunStore(std::unique_ptr<Connection> conn) : conn_(std::move(conn)) {}
RunStore::RunStore(RunStore&& other) noexcept = default;
RunStore& RunStore::operator=(RunStore&& other) noexcept = default;
RunStore::~RunStore() = default;

Result<RunStore> RunStore::open(const std::filesystem::path& db_path) {
  if (db_path.empty()) {
    return make_error(ErrorCode::kInvalidInput, "no run database path given; set --data-dir");
  }
  Result<std::unique_ptr<Connection>> conn = connect(db_path);
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

Result<std::int64_t> RunStore::insert_run(const RunRecord& run) {
  Status valid = validate(run);
  if (!valid.ok()) return valid.error();

  // Encode before the transaction: a value out of range is refused with nothing written.
  std::string lift;
  std::string amplifier = "[";
  lift.reserve(run.measured.revolutions.size() * storage_internal::kDegreeBlobBytes);
  for (std::size_t i = 0; i < run.measured.revolutions.size(); ++i) {
    const RevolutionSamples& rev = run.measured.revolutions[i];
    Status s =
        storage_internal::append_degree_blob(rev.lift_mm, storage_internal::kCountsPerMm,
                                             "lift_mm of revolution " + std::to_string(i) + " (machine frame)", lift);
    if (!s.ok()) return refused(s.error().message);
    amplifier += (i == 0 ? "" : ",") + std::to_string(rev.revolution);
  }
  amplifier += "]";
  const LobeAnalysis& a = run.analysis;
  const std::array<std::pair<const DegreeTable*, double>, 5> tables = {{
      {&a.design_lift_mm, storage_internal::kCountsPerMm},
      {&a.mean_lift_mm, storage_internal::kCountsPerMm},
      {&a.spread_um, storage_internal::kCountsPerUm},
      {&a.error_um, storage_internal::kCountsPerUm},
      {&run.correction_um, storage_internal::kCountsPerUm},
  }};
  static constexpr std::array<std::string_view, 5> kTableNames = {"design_lift_mm (cam frame)",
                                                                  "mean_lift_mm (cam frame)", "spread_um (cam frame)",
                                                                  "error_um (cam frame)", "correction_um (cam frame)"};
  std::array<std::string, 5> table_blobs;
  for (std::size_t i = 0; i < tables.size(); ++i) {
    Status s = storage_internal::append_degree_blob(*tables[i].first, tables[i].second, kTableNames[i], table_blobs[i]);
    if (!s.ok()) return refused(s.error().message);
  }
  std::string harmonics = "[";
  for (std::size_t h = 0; h < a.harmonic_amplitude_um.size(); ++h) {
    harmonics += (h == 0 ? "" : ",") + exact_number(a.harmonic_amplitude_um[h]);
  }
  harmonics += "]";
  const std::string hash = run.settings.empty() ? std::string() : settings_hash(run.settings);

  Connection& conn = *conn_;
  const std::string operation =
      "store the run of part " + run.part + " lobe " + std::to_string(run.lobe) + " started " + run.started_utc;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();

  if (!hash.empty()) {
    Result<Statement> st = Statement::prepare(conn, kInsertSettings, operation);
    if (!st.ok()) return st.error();
    st->bind(1, std::string_view(hash));
    st->bind(2, std::string_view(run.settings));
    if (Status s = st->run(); !s.ok()) return s.error();
  }

  const int revolutions = static_cast<int>(run.measured.revolutions.size());
  Result<Statement> ins = Statement::prepare(conn, kInsertRun, operation);
  if (!ins.ok()) return ins.error();
  ins->bind(1, std::string_view(run.started_utc));
  ins->bind(2, std::string_view(run.finished_utc));
  ins->bind(3, std::string_view(run.machine));
  ins->bind(4, std::string_view(run.part));
  ins->bind(5, run.lobe);
  ins->bind(6, std::string_view(run.gauge));
  ins->bind(7, std::string_view(run.note));
  ins->bind(8, revolutions);
  ins->bind(9, revolutions * kDegreesPerRevolution);
  ins->bind(10, run.measured.polls);
  ins->bind(11, run.measured.reconnects);
  ins->bind(12, run.measured.discarded_revolutions);
  ins->bind(13, a.zero_offset_mm);
  ins->bind(14, a.max_abs_error_um);
  ins->bind(15, a.rms_error_um);
  ins->bind(16, a.peak_to_valley_um);
  ins->bind(17, a.repeatability_um);
  if (run.correction_in_force_run) {
    ins->bind(18, *run.correction_in_force_run);
  } else {
    ins->bind_null(18);
  }
  if (hash.empty()) {
    ins->bind_null(19);
  } else {
    ins->bind(19, std::string_view(hash));
  }
  ins->bind(20, a.phase_error_deg);
  ins->bind(21, a.base_circle_runout_um);
  ins->bind(22, std::string_view(harmonics));
  if (run.geometry) {
    ins->bind(23, run.geometry->rotation_sense);
    ins->bind(24, run.geometry->c_offset_deg);
    ins->bind(25, run.geometry->probe_offset_deg);
  } else {
    ins->bind_null(23);
    ins->bind_null(24);
    ins->bind_null(25);
  }
  bind_optional(*ins, 26, run.ground_with_version);
  bind_text_or_null(*ins, 27, run.ground_with_source);
  ins->bind(28, run.inspection ? 1 : 0);
  Status s = ins->run();
  if (!s.ok()) return s.error();
  const std::int64_t run_id = sqlite3_last_insert_rowid(conn.db);

  if (run.geometry) {
    const Part& g = *run.geometry;
    Result<Statement> part = Statement::prepare(conn, kUpdatePart, operation);
    if (!part.ok()) return part.error();
    part->bind(1, std::string_view(run.part));
    part->bind(2, follower_db_name(g.follower));
    part->bind(3, g.follower_radius_mm);
    part->bind(4, g.base_circle_radius_mm);
    part->bind(5, g.wheel_radius_mm);
    if (s = part->run(); !s.ok()) return s.error();
    Result<Statement> lobe = Statement::prepare(conn, kUpdateLobe, operation);
    if (!lobe.ok()) return lobe.error();
    lobe->bind(1, std::string_view(run.part));
    lobe->bind(2, run.lobe);
    lobe->bind(3, g.rotation_sense);
    lobe->bind(4, g.c_offset_deg);
    lobe->bind(5, g.probe_offset_deg);
    if (s = lobe->run(); !s.ok()) return s.error();
  }

  Result<Statement> raw = Statement::prepare(conn, kInsertRaw, operation);
  if (!raw.ok()) return raw.error();
  raw->bind(1, run_id);
  raw->bind(2, std::string_view(amplifier));
  raw->bind_blob(3, lift);
  if (s = raw->run(); !s.ok()) return s.error();

  Result<Statement> tab = Statement::prepare(conn, kInsertTables, operation);
  if (!tab.ok()) return tab.error();
  tab->bind(1, run_id);
  for (std::size_t i = 0; i < table_blobs.size(); ++i) tab->bind_blob(static_cast<int>(i) + 2, table_blobs[i]);
  if (s = tab->run(); !s.ok()) return s.error();

  s = tx->commit();
  if (!s.ok()) return s.error();
  return run_id;
}

namespace {

std::string push_what(std::int64_t run_id, const NcPush& push) {
  return "cannot record NC file " + push.nc_file + " for run " + std::to_string(run_id);
}

Status check_push(std::int64_t run_id, const NcPush& push) {
  if (push.nc_file.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot record an NC file for run " + std::to_string(run_id) + ": the NC file path is empty");
  }
  const std::string what = push_what(run_id, push);
  if (!push.pushed_utc.empty() && !is_utc_timestamp(push.pushed_utc)) {
    return bad_bound(what + ": pushed_utc", push.pushed_utc);
  }
  if (push.table_version < 0) {
    return make_error(ErrorCode::kInvalidInput, what + ": table version " + std::to_string(push.table_version) +
                                                    " is negative (0: the next one)");
  }
  return check_table_figures(what, push.block_count, push.command_error_um, push.point_count, push.correction_max_um);
}

// The next table version of `nc_file`: 1 + the highest recorded (1 if none).
Result<int> next_version_of(Connection& conn, std::string_view nc_file, const std::string& operation) {
  Result<Statement> next = Statement::prepare(conn, kNextTableVersion, operation);
  if (!next.ok()) return next.error();
  next->bind(1, nc_file);
  Result<bool> row = next->step();
  if (!row.ok()) return row.error();
  return next->column_int(0);
}

// Records one push inside the caller's write transaction, which makes the version check and
// the insert one step for other writers: marks the run pushed, takes (or checks) the file's
// next table version and inserts the nc_pushes row. Returns its id. `push` was checked.
Result<std::int64_t> insert_push(Connection& conn, std::int64_t run_id, const NcPush& push, std::string_view text,
                                 const std::string& operation) {
  Result<Statement> upd = Statement::prepare(conn, kRecordNcFile, operation);
  if (!upd.ok()) return upd.error();
  upd->bind(1, run_id);
  upd->bind(2, std::string_view(push.nc_file));
  if (Status s = upd->run(); !s.ok()) return s.error();
  if (sqlite3_changes(conn.db) == 0) {
    return make_error(ErrorCode::kNotFound, "cannot " + operation + ": run " + std::to_string(run_id) +
                                                " is not in run database " + conn.path.string());
  }
  Result<int> next = next_version_of(conn, push.nc_file, operation);
  if (!next.ok()) return next.error();
  const int version = *next;
  if (push.table_version != 0 && push.table_version != version) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot " + operation + ": table version " + std::to_string(push.table_version) +
                          " is not the next for " + push.nc_file + " (the next is " + std::to_string(version) +
                          "): another push was recorded since the version was asked; nothing was recorded, "
                          "render the program again with the next version");
  }
  Result<Statement> ins = Statement::prepare(conn, kInsertPush, operation);
  if (!ins.ok()) return ins.error();
  ins->bind(1, run_id);
  ins->bind(2, std::string_view(push.pushed_utc.empty() ? utc_now() : push.pushed_utc));
  ins->bind(3, std::string_view(push.nc_file));
  ins->bind(4, version);
  ins->bind(5, std::string_view(push.reason.empty() ? "run " + std::to_string(run_id) : push.reason));
  bind_text_or_null(*ins, 6, push.interpolation);
  bind_optional(*ins, 7, push.block_count);
  bind_optional(*ins, 8, push.command_error_um);
  bind_optional(*ins, 9, push.point_count);
  bind_optional(*ins, 10, push.correction_max_um);
  const std::string hash = text.empty() ? push.program_hash : settings_hash(text);
  bind_text_or_null(*ins, 11, hash);
  bind_text_or_null(*ins, 12, text);
  if (Status s = ins->run(); !s.ok()) return s.error();
  return static_cast<std::int64_t>(sqlite3_last_insert_rowid(conn.db));
}

}  // namespace

Status RunStore::record_nc_file(std::int64_t run_id, const std::string& nc_path) {
  NcPush push;
  push.nc_file = nc_path;
  return record_push(run_id, push);
}

Status RunStore::record_push(std::int64_t run_id, const NcPush& push, std::string_view program_text) {
  if (Status s = check_push(run_id, push); !s.ok()) return s;
  if (program_text.empty() && push.program_text) program_text = *push.program_text;
  Connection& conn = *conn_;
  const std::string operation = "record NC file " + push.nc_file + " for run " + std::to_string(run_id);
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<std::int64_t> id = insert_push(conn, run_id, push, program_text, operation);
  if (!id.ok()) return id.error();
  return tx->commit();
}

Result<int> RunStore::next_table_version(const std::string& nc_file) const {
  if (nc_file.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot find the next table version: the NC file path is empty");
  }
  return next_version_of(*conn_, nc_file, "find the next table version of " + nc_file);
}

Result<std::vector<NcPush>> RunStore::list_pushes(const PushQuery& q) const {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list NC pushes: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  if (q.lobe < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list NC pushes: lobe " + std::to_string(q.lobe) + " is negative");
  }
  std::string where;
  std::vector<std::string> text;
  auto add = [&](const std::string& column_op, const std::string& value) {
    text.push_back(value);
    where += (where.empty() ? " WHERE " : " AND ") + column_op + " ?" + std::to_string(text.size() + 1);
  };
  if (!q.nc_file.empty()) add("p.nc_file =", q.nc_file);
  if (!q.machine.empty()) add("r.machine =", q.machine);
  if (!q.part.empty()) add("r.part =", q.part);
  if (q.lobe > 0) where += std::string(where.empty() ? " WHERE " : " AND ") + "r.lobe = " + std::to_string(q.lobe);
  Connection& conn = *conn_;
  Result<Statement> st = Statement::prepare(conn,
                                            "SELECT " + std::string(kPushColumns) +
                                                " FROM nc_pushes AS p JOIN runs AS r ON r.id = p.run_id" + where +
                                                " ORDER BY p.id DESC LIMIT ?1",
                                            "list NC pushes");
  if (!st.ok()) return st.error();
  st->bind(1, q.limit);
  for (std::size_t i = 0; i < text.size(); ++i) st->bind(static_cast<int>(i) + 2, std::string_view(text[i]));
  std::vector<NcPush> out;
  for (;;) {
    Result<bool> row = st->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    out.push_back(read_push(*st, false));
  }
  return out;
}

Result<NcPush> RunStore::load_push(const std::string& nc_file, int table_version) const {
  Connection& conn = *conn_;
  const std::string operation = "load table version " + std::to_string(table_version) + " of " + nc_file;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> q = Statement::prepare(conn,
                                           "SELECT " + std::string(kPushColumns) +
                                               ", p.program_text FROM nc_pushes AS p"
                                               " WHERE p.nc_file = ?1 AND p.table_version = ?2",
                                           operation);
  if (!q.ok()) return q.error();
  q->bind(1, std::string_view(nc_file));
  q->bind(2, table_version);
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  if (*row) return read_push(*q, true);

  Result<Statement> have = Statement::prepare(
      conn, "SELECT count(*), min(table_version), max(table_version) FROM nc_pushes WHERE nc_file = ?1", operation);
  if (!have.ok()) return have.error();
  have->bind(1, std::string_view(nc_file));
  row = have->step();
  if (!row.ok()) return row.error();
  const int count = have->column_int(0);
  std::string versions;
  if (count == 0) {
    versions = "nothing was ever pushed to it";
  } else if (count == 1) {
    versions = "its only version is " + std::to_string(have->column_int(1));
  } else {
    versions = "its versions are " + std::to_string(have->column_int(1)) + " to " + std::to_string(have->column_int(2));
    if (have->column_int(2) - have->column_int(1) + 1 != count) versions += " (" + std::to_string(count) + " of them)";
  }
  return make_error(ErrorCode::kNotFound, "NC file " + nc_file + " has no table version " +
                                              std::to_string(table_version) + " in run database " + conn.path.string() +
                                              ": " + versions);
}

Result<std::optional<NcPush>> RunStore::last_push(const std::string& nc_file) const {
  Connection& conn = *conn_;
  Result<Statement> q = Statement::prepare(conn,
                                           "SELECT " + std::string(kPushColumns) +
                                               ", p.program_text FROM nc_pushes AS p WHERE p.nc_file = ?1"
                                               " ORDER BY p.table_version DESC LIMIT 1",
                                           "load the last push of " + nc_file);
  if (!q.ok()) return q.error();
  q->bind(1, std::string_view(nc_file));
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  if (!*row) return std::optional<NcPush>();
  return std::optional<NcPush>(read_push(*q, true));
}

// ---- Tables awaiting approval ----

namespace {

std::string pending_what(std::int64_t id) { return "pending table " + std::to_string(id); }

// Reads one pending table inside the caller's transaction; kNotFound if absent.
Result<PendingTable> read_one_pending(Connection& conn, std::int64_t id, bool with_text, const std::string& operation) {
  Result<Statement> q = Statement::prepare(conn, select_pending(with_text, " WHERE id = ?1"), operation);
  if (!q.ok()) return q.error();
  q->bind(1, id);
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  if (!*row) {
    return make_error(ErrorCode::kNotFound, "cannot " + operation + ": " + pending_what(id) +
                                                " is not in run database " + conn.path.string());
  }
  return read_pending(*q);
}

// kRefused for a table that left kPending, saying how and when.
Status require_pending(const PendingTable& t, const std::string& operation) {
  if (t.status == PendingStatus::kPending) return {};
  std::string how = "it is already " + std::string(pending_status_name(t.status));
  switch (t.status) {
    case PendingStatus::kApproved:
    case PendingStatus::kRejected:
      how += " (by " + t.decided_by + " at " + t.decided_utc + ")";
      break;
    case PendingStatus::kSuperseded:
      how += " by the newer " + (t.superseded_by ? pending_what(*t.superseded_by) : std::string("pending table")) +
             " at " + t.decided_utc + "; only the newest measurement can be approved";
      break;
    case PendingStatus::kPending:
      break;
  }
  return make_error(ErrorCode::kRefused, "cannot " + operation + ": " + how + "; nothing was changed");
}

}  // namespace

Result<std::int64_t> RunStore::add_pending(const PendingTable& table) {
  const std::string what = "cannot keep a pending table for run " + std::to_string(table.run_id);
  if (table.nc_file.empty()) return make_error(ErrorCode::kInvalidInput, what + ": the NC file path is empty");
  if (table.program_text.empty()) {
    return make_error(ErrorCode::kInvalidInput, what + " (" + table.nc_file + "): the program text is empty");
  }
  if (!table.created_utc.empty() && !is_utc_timestamp(table.created_utc)) {
    return bad_bound(what + ": created_utc", table.created_utc);
  }
  if (Status s = check_table_figures(what + " (" + table.nc_file + ")", table.block_count, table.command_error_um,
                                     table.point_count, table.correction_max_um);
      !s.ok()) {
    return s.error();
  }
  const std::string created = table.created_utc.empty() ? utc_now() : table.created_utc;
  Connection& conn = *conn_;
  const std::string operation =
      "keep the table of run " + std::to_string(table.run_id) + " for " + table.nc_file + " pending";
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();

  Result<Statement> run = Statement::prepare(conn, "SELECT 1 FROM runs WHERE id = ?1", operation);
  if (!run.ok()) return run.error();
  run->bind(1, table.run_id);
  Result<bool> row = run->step();
  if (!row.ok()) return row.error();
  if (!*row) {
    return make_error(ErrorCode::kNotFound, "cannot " + operation + ": run " + std::to_string(table.run_id) +
                                                " is not in run database " + conn.path.string());
  }
  // The older pending table (at most one: nc_pending_one_per_file) steps aside before the new
  // row goes in, and learns the new id after.
  std::optional<std::int64_t> older;
  {
    Result<Statement> q =
        Statement::prepare(conn, "SELECT id FROM nc_pending WHERE nc_file = ?1 AND status = 'pending'", operation);
    if (!q.ok()) return q.error();
    q->bind(1, std::string_view(table.nc_file));
    row = q->step();
    if (!row.ok()) return row.error();
    if (*row) older = q->column_int64(0);
  }
  if (older) {
    Result<Statement> sup = Statement::prepare(
        conn, "UPDATE nc_pending SET status = 'superseded', decided_utc = ?2 WHERE id = ?1", operation);
    if (!sup.ok()) return sup.error();
    sup->bind(1, *older);
    sup->bind(2, std::string_view(created));
    if (Status s = sup->run(); !s.ok()) return s.error();
  }
  Result<Statement> ins = Statement::prepare(conn,
                                             "INSERT INTO nc_pending (run_id, created_utc, nc_file, program_text,"
                                             " verdict, reason, interpolation, block_count, command_error_um,"
                                             " correction_max_um, point_count)"
                                             " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11)",
                                             operation);
  if (!ins.ok()) return ins.error();
  ins->bind(1, table.run_id);
  ins->bind(2, std::string_view(created));
  ins->bind(3, std::string_view(table.nc_file));
  ins->bind(4, std::string_view(table.program_text));
  ins->bind(5, pending_verdict_name(table.verdict));
  ins->bind(6, std::string_view(table.reason));
  bind_text_or_null(*ins, 7, table.interpolation);
  bind_optional(*ins, 8, table.block_count);
  bind_optional(*ins, 9, table.command_error_um);
  bind_optional(*ins, 10, table.correction_max_um);
  bind_optional(*ins, 11, table.point_count);
  if (Status s = ins->run(); !s.ok()) return s.error();
  const std::int64_t id = sqlite3_last_insert_rowid(conn.db);
  if (older) {
    Result<Statement> link =
        Statement::prepare(conn, "UPDATE nc_pending SET superseded_by = ?2 WHERE id = ?1", operation);
    if (!link.ok()) return link.error();
    link->bind(1, *older);
    link->bind(2, id);
    if (Status s = link->run(); !s.ok()) return s.error();
  }
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return id;
}

Result<std::vector<PendingTable>> RunStore::list_pending(const PendingQuery& q) const {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list pending tables: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  std::string where;
  std::vector<std::string> text;
  auto add = [&](const std::string& column_op, const std::string& value) {
    text.push_back(value);
    where += (where.empty() ? " WHERE " : " AND ") + column_op + " ?" + std::to_string(text.size() + 1);
  };
  if (q.status) add("status =", std::string(pending_status_name(*q.status)));
  if (!q.nc_file.empty()) add("nc_file =", q.nc_file);
  Connection& conn = *conn_;
  Result<Statement> st =
      Statement::prepare(conn, select_pending(false, where + " ORDER BY id DESC LIMIT ?1"), "list pending tables");
  if (!st.ok()) return st.error();
  st->bind(1, q.limit);
  for (std::size_t i = 0; i < text.size(); ++i) st->bind(static_cast<int>(i) + 2, std::string_view(text[i]));
  std::vector<PendingTable> out;
  for (;;) {
    Result<bool> row = st->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    out.push_back(read_pending(*st));
  }
  return out;
}

Result<PendingTable> RunStore::load_pending(std::int64_t id) const {
  return read_one_pending(*conn_, id, true, "load " + pending_what(id));
}

Status RunStore::reject_pending(std::int64_t id, const std::string& by, const std::string& note) {
  const std::string operation = "reject " + pending_what(id);
  if (by.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": say who rejects it (the name is empty)");
  }
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<PendingTable> t = read_one_pending(conn, id, false, operation);
  if (!t.ok()) return t.error();
  if (Status s = require_pending(*t, operation + " for " + t->nc_file); !s.ok()) return s;
  Result<Statement> upd = Statement::prepare(conn,
                                             "UPDATE nc_pending SET status = 'rejected', decided_utc = ?2,"
                                             " decided_by = ?3, note = ?4 WHERE id = ?1",
                                             operation);
  if (!upd.ok()) return upd.error();
  upd->bind(1, id);
  upd->bind(2, std::string_view(utc_now()));
  upd->bind(3, std::string_view(by));
  upd->bind(4, std::string_view(note));
  if (Status s = upd->run(); !s.ok()) return s;
  return tx->commit();
}

namespace {

// Inside the caller's write transaction: records `push` as the approved push of pending table
// `pending_id` and marks the table approved, as record_approved_push describes. Returns the
// push's id.
Result<std::int64_t> approve_in_transaction(Connection& conn, std::int64_t pending_id, const NcPush& push,
                                            const std::string& by, const std::string& note,
                                            const std::string& operation) {
  if (by.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": say who approves it (the name is empty)");
  }
  Result<PendingTable> t = read_one_pending(conn, pending_id, true, operation);
  if (!t.ok()) return t.error();
  if (!push.nc_file.empty() && push.nc_file != t->nc_file) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": it was rendered for " + t->nc_file +
                                                    ", not for " + push.nc_file + "; nothing was recorded");
  }
  if (Status s = require_pending(*t, operation + " for " + t->nc_file); !s.ok()) return s.error();

  NcPush full = push;
  full.nc_file = t->nc_file;
  if (full.reason.empty()) full.reason = "approved by " + by;
  if (full.interpolation.empty()) full.interpolation = t->interpolation;
  if (!full.block_count) full.block_count = t->block_count;
  if (!full.command_error_um) full.command_error_um = t->command_error_um;
  if (!full.correction_max_um) full.correction_max_um = t->correction_max_um;
  if (!full.point_count) full.point_count = t->point_count;
  if (!full.program_text || full.program_text->empty()) full.program_text = t->program_text;
  if (Status s = check_push(t->run_id, full); !s.ok()) return s.error();

  Result<std::int64_t> push_id = insert_push(conn, t->run_id, full, *full.program_text, operation);
  if (!push_id.ok()) return push_id.error();
  Result<Statement> upd = Statement::prepare(conn,
                                             "UPDATE nc_pending SET status = 'approved', decided_utc = ?2,"
                                             " decided_by = ?3, note = ?4, push_id = ?5 WHERE id = ?1",
                                             operation);
  if (!upd.ok()) return upd.error();
  upd->bind(1, pending_id);
  upd->bind(2, std::string_view(utc_now()));
  upd->bind(3, std::string_view(by));
  upd->bind(4, std::string_view(note));
  upd->bind(5, *push_id);
  if (Status s = upd->run(); !s.ok()) return s.error();
  return push_id;
}

}  // namespace

Status RunStore::record_approved_push(std::int64_t pending_id, const NcPush& push, const std::string& by,
                                      const std::string& note) {
  const std::string operation = "record the approved push of " + pending_what(pending_id);
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<std::int64_t> push_id = approve_in_transaction(conn, pending_id, push, by, note, operation);
  if (!push_id.ok()) return push_id.error();
  return tx->commit();
}

// ---- push journal ----

namespace {

constexpr std::string_view kIntentColumns =
    "id, created_utc, run_id, nc_file, table_version, reason, interpolation, block_count, command_error_um, "
    "point_count, correction_max_um, program_hash, program_text, pending_id, approved_by, note";

PushIntent read_intent(const Statement& s) {
  PushIntent i;
  i.id = s.column_int64(0);
  i.created_utc = s.column_text(1);
  i.run_id = s.column_int64(2);
  i.push.run_id = i.run_id;
  i.push.nc_file = s.column_text(3);
  i.push.table_version = s.column_int(4);
  i.push.reason = s.column_text(5);
  i.push.interpolation = s.column_text(6);
  if (!s.column_is_null(7)) i.push.block_count = s.column_int(7);
  if (!s.column_is_null(8)) i.push.command_error_um = s.column_double(8);
  if (!s.column_is_null(9)) i.push.point_count = s.column_int(9);
  if (!s.column_is_null(10)) i.push.correction_max_um = s.column_double(10);
  i.push.program_hash = s.column_text(11);
  i.push.program_text = s.column_text(12);
  if (!s.column_is_null(13)) i.pending_id = s.column_int64(13);
  i.approved_by = s.column_text(14);
  i.note = s.column_text(15);
  return i;
}

Result<std::optional<PushIntent>> read_open_intent(Connection& conn, std::int64_t id, const std::string& operation) {
  Result<Statement> q = Statement::prepare(
      conn, "SELECT " + std::string(kIntentColumns) + " FROM nc_push_intents WHERE id = ?1 AND state = 'open'",
      operation);
  if (!q.ok()) return q.error();
  q->bind(1, id);
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  if (!*row) return std::optional<PushIntent>();
  return std::optional<PushIntent>(read_intent(*q));
}

Status resolve_intent(Connection& conn, std::int64_t id, std::string_view state, const std::string& resolution,
                      std::optional<std::int64_t> push_id, const std::string& operation) {
  Result<Statement> upd =
      Statement::prepare(conn,
                         "UPDATE nc_push_intents SET state = ?2, resolved_utc = ?3, resolution = ?4,"
                         " push_id = ?5, program_text = '' WHERE id = ?1 AND state = 'open'",
                         operation);
  if (!upd.ok()) return upd.error();
  upd->bind(1, id);
  upd->bind(2, state);
  upd->bind(3, std::string_view(utc_now()));
  upd->bind(4, std::string_view(resolution));
  if (push_id) {
    upd->bind(5, *push_id);
  } else {
    upd->bind_null(5);
  }
  if (Status s = upd->run(); !s.ok()) return s;
  if (sqlite3_changes(conn.db) == 0) {
    return make_error(ErrorCode::kRefused, "cannot " + operation + ": push intent " + std::to_string(id) +
                                               " is not open (already resolved by another command)");
  }
  return {};
}

}  // namespace

Result<std::int64_t> RunStore::begin_push(const PushIntent& intent) {
  const NcPush& p = intent.push;
  if (Status s = check_push(intent.run_id, p); !s.ok()) return s.error();
  const std::string operation = "record the intent to push table version " + std::to_string(p.table_version) + " of " +
                                p.nc_file + " for run " + std::to_string(intent.run_id);
  if (!p.program_text || p.program_text->empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": the program text is empty");
  }
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  {
    Result<Statement> open = Statement::prepare(
        conn, "SELECT id, created_utc, run_id FROM nc_push_intents WHERE nc_file = ?1 AND state = 'open'", operation);
    if (!open.ok()) return open.error();
    open->bind(1, std::string_view(p.nc_file));
    Result<bool> row = open->step();
    if (!row.ok()) return row.error();
    if (*row) {
      return make_error(ErrorCode::kRefused,
                        "cannot " + operation + ": push intent " + std::to_string(open->column_int64(0)) + " (run " +
                            std::to_string(open->column_int64(2)) + ", " + open->column_text(1) +
                            ") is still open for this file: another push is under way, or one was interrupted and "
                            "must be reconciled first");
    }
  }
  {
    Result<Statement> run = Statement::prepare(conn, "SELECT 1 FROM runs WHERE id = ?1", operation);
    if (!run.ok()) return run.error();
    run->bind(1, intent.run_id);
    Result<bool> row = run->step();
    if (!row.ok()) return row.error();
    if (!*row) {
      return make_error(ErrorCode::kNotFound, "cannot " + operation + ": run " + std::to_string(intent.run_id) +
                                                  " is not in run database " + conn.path.string());
    }
  }
  Result<int> next = next_version_of(conn, p.nc_file, operation);
  if (!next.ok()) return next.error();
  if (*next != p.table_version) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": the next version of the file is " +
                                                    std::to_string(*next) + "; render the program again with it");
  }
  Result<Statement> ins = Statement::prepare(
      conn,
      "INSERT INTO nc_push_intents (created_utc, run_id, nc_file, table_version, reason, interpolation, block_count,"
      " command_error_um, point_count, correction_max_um, program_hash, program_text, pending_id, approved_by, note)"
      " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15)",
      operation);
  if (!ins.ok()) return ins.error();
  ins->bind(1, std::string_view(utc_now()));
  ins->bind(2, intent.run_id);
  ins->bind(3, std::string_view(p.nc_file));
  ins->bind(4, p.table_version);
  ins->bind(5, std::string_view(p.reason.empty() ? "run " + std::to_string(intent.run_id) : p.reason));
  bind_text_or_null(*ins, 6, p.interpolation);
  bind_optional(*ins, 7, p.block_count);
  bind_optional(*ins, 8, p.command_error_um);
  bind_optional(*ins, 9, p.point_count);
  bind_optional(*ins, 10, p.correction_max_um);
  ins->bind(11, std::string_view(settings_hash(*p.program_text)));
  ins->bind(12, std::string_view(*p.program_text));
  if (intent.pending_id) {
    ins->bind(13, *intent.pending_id);
  } else {
    ins->bind_null(13);
  }
  bind_text_or_null(*ins, 14, intent.approved_by);
  bind_text_or_null(*ins, 15, intent.note);
  if (Status s = ins->run(); !s.ok()) return s.error();
  const std::int64_t id = sqlite3_last_insert_rowid(conn.db);
  if (Status c = tx->commit(); !c.ok()) return c.error();
  return id;
}

Result<PushCompletion> RunStore::complete_push(std::int64_t intent_id, const std::string& resolution) {
  const std::string operation = "complete push intent " + std::to_string(intent_id);
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<std::optional<PushIntent>> intent = read_open_intent(conn, intent_id, operation);
  if (!intent.ok()) return intent.error();
  if (!*intent) {
    return make_error(ErrorCode::kRefused, "cannot " + operation + ": it is not open (resolved by another command)");
  }
  const PushIntent& i = **intent;
  PushCompletion out;
  out.table_version = i.push.table_version;
  Result<std::int64_t> push_id = make_error(ErrorCode::kInternal, "no push");
  if (i.pending_id) {
    push_id = approve_in_transaction(conn, *i.pending_id, i.push, i.approved_by, i.note, operation);
    // Rejected or superseded since it was checked: the file is written, so the history must
    // still say so, as a plain push.
    if (!push_id.ok() && push_id.error().code == ErrorCode::kRefused) {
      out.decision_recorded = false;
      push_id = insert_push(conn, i.run_id, i.push, *i.push.program_text, operation);
    }
  } else {
    push_id = insert_push(conn, i.run_id, i.push, *i.push.program_text, operation);
  }
  if (!push_id.ok()) return push_id.error();
  out.push_id = *push_id;
  if (Status s = resolve_intent(conn, intent_id, "completed", resolution, *push_id, operation); !s.ok()) {
    return s.error();
  }
  if (Status c = tx->commit(); !c.ok()) return c.error();
  return out;
}

Status RunStore::abandon_push(std::int64_t intent_id, const std::string& resolution) {
  const std::string operation = "abandon push intent " + std::to_string(intent_id);
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  if (Status s = resolve_intent(conn, intent_id, "abandoned", resolution, std::nullopt, operation); !s.ok()) return s;
  return tx->commit();
}

Result<std::vector<PushIntent>> RunStore::open_push_intents(const std::string& nc_file) const {
  Connection& conn = *conn_;
  Result<Statement> q =
      Statement::prepare(conn,
                         "SELECT " + std::string(kIntentColumns) +
                             " FROM nc_push_intents WHERE state = 'open' AND (?1 = '' OR nc_file = ?1) ORDER BY id",
                         "list the open push intents");
  if (!q.ok()) return q.error();
  q->bind(1, std::string_view(nc_file));
  std::vector<PushIntent> out;
  for (;;) {
    Result<bool> row = q->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    out.push_back(read_intent(*q));
  }
  return out;
}

Result<std::int64_t> RunStore::record_event(const EventRecord& event) {
  if (event.message.empty() || event.code.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot record an event without a code and a message");
  }
  if (!event.at_utc.empty() && !is_utc_timestamp(event.at_utc)) {
    return bad_bound("cannot record an event: at_utc", event.at_utc);
  }
  if (event.lobe < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot record an event: lobe " + std::to_string(event.lobe) + " is negative (0: no lobe)");
  }
  Connection& conn = *conn_;
  const std::string operation = "record a " + std::string(event_kind_name(event.kind)) + " event";
  Result<Statement> ins = Statement::prepare(conn,
                                             "INSERT INTO events (at_utc, kind, code, machine, part, lobe, run_id,"
                                             " message) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8)",
                                             operation);
  if (!ins.ok()) return ins.error();
  ins->bind(1, std::string_view(event.at_utc.empty() ? utc_now() : event.at_utc));
  ins->bind(2, event_kind_name(event.kind));
  ins->bind(3, std::string_view(event.code));
  ins->bind(4, std::string_view(event.machine));
  ins->bind(5, std::string_view(event.part));
  if (event.lobe > 0) {
    ins->bind(6, event.lobe);
  } else {
    ins->bind_null(6);
  }
  if (event.run_id) {
    ins->bind(7, *event.run_id);
  } else {
    ins->bind_null(7);
  }
  ins->bind(8, std::string_view(event.message));
  if (Status s = ins->run(); !s.ok()) return s.error();
  return static_cast<std::int64_t>(sqlite3_last_insert_rowid(conn.db));
}

Result<std::vector<StoredEvent>> RunStore::list_events(const EventQuery& q) const {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list events: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  if (!is_time_bound(q.since_utc)) return bad_bound("cannot list events: since", q.since_utc);
  if (!is_time_bound(q.until_utc)) return bad_bound("cannot list events: until", q.until_utc);
  std::string where;
  std::vector<std::string> text;
  auto add = [&](const std::string& column_op, const std::string& value) {
    text.push_back(value);
    where += (where.empty() ? " WHERE " : " AND ") + column_op + " ?" + std::to_string(text.size() + 1);
  };
  if (!q.machine.empty()) add("machine =", q.machine);
  if (!q.part.empty()) add("part =", q.part);
  if (q.kind) add("kind =", std::string(event_kind_name(*q.kind)));
  if (!q.since_utc.empty()) add("at_utc >=", q.since_utc);
  if (!q.until_utc.empty()) add("at_utc <", q.until_utc);
  Connection& conn = *conn_;
  Result<Statement> st =
      Statement::prepare(conn,
                         "SELECT id, at_utc, kind, code, machine, part, lobe, run_id, message FROM events" + where +
                             " ORDER BY at_utc DESC, id DESC LIMIT ?1",
                         "list events");
  if (!st.ok()) return st.error();
  st->bind(1, q.limit);
  for (std::size_t i = 0; i < text.size(); ++i) st->bind(static_cast<int>(i) + 2, std::string_view(text[i]));
  std::vector<StoredEvent> out;
  for (;;) {
    Result<bool> row = st->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    StoredEvent e;
    e.id = st->column_int64(0);
    e.event.at_utc = st->column_text(1);
    const std::string kind = st->column_text(2);
    e.event.kind = kind == "refusal" ? EventKind::kRefusal : kind == "info" ? EventKind::kInfo : EventKind::kFault;
    e.event.code = st->column_text(3);
    e.event.machine = st->column_text(4);
    e.event.part = st->column_text(5);
    e.event.lobe = st->column_is_null(6) ? 0 : st->column_int(6);
    if (!st->column_is_null(7)) e.event.run_id = st->column_int64(7);
    e.event.message = st->column_text(8);
    out.push_back(std::move(e));
  }
  return out;
}

namespace {

Result<std::vector<RunSummary>> query_runs(Connection& conn, const RunQuery& q, bool oldest_first) {
  Result<Filter> f = run_filter(q);
  if (!f.ok()) return f.error();
  // Newest `limit` runs first; the trend wants them back in time order.
  std::string sql = select_summaries(f->where + " ORDER BY r.started_utc DESC, r.id DESC LIMIT ?1");
  if (oldest_first) {
    sql = "SELECT * FROM (" + sql + ") ORDER BY started_utc, id";
  }
  Result<Statement> list = Statement::prepare(conn, sql, "list runs");
  if (!list.ok()) return list.error();
  list->bind(1, q.limit);
  for (std::size_t i = 0; i < f->text.size(); ++i) list->bind(static_cast<int>(i) + 2, std::string_view(f->text[i]));
  std::vector<RunSummary> runs;
  for (;;) {
    Result<bool> row = list->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    runs.push_back(read_summary(*list));
  }
  return runs;
}

}  // namespace

Result<std::vector<RunSummary>> RunStore::list_runs(const RunQuery& q) const { return query_runs(*conn_, q, false); }

Result<std::vector<RunSummary>> RunStore::trend(const RunQuery& q) const { return query_runs(*conn_, q, true); }

Result<std::optional<std::int64_t>> RunStore::last_pushed_run(const std::string& machine, const std::string& part,
                                                              int lobe) const {
  Connection& conn = *conn_;
  Result<Statement> q = Statement::prepare(conn,
                                           "SELECT p.run_id FROM nc_pushes AS p JOIN runs AS r ON r.id = p.run_id"
                                           " WHERE r.machine = ?1 AND r.part = ?2 AND r.lobe = ?3"
                                           " ORDER BY p.id DESC LIMIT 1",
                                           "find the table in force");
  if (!q.ok()) return q.error();
  q->bind(1, std::string_view(machine));
  q->bind(2, std::string_view(part));
  q->bind(3, static_cast<std::int64_t>(lobe));
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  if (!*row) return std::optional<std::int64_t>();
  return std::optional<std::int64_t>(q->column_int64(0));
}

Result<StoredRun> RunStore::load_run(std::int64_t run_id) const {
  Connection& conn = *conn_;
  const std::string operation = "load run " + std::to_string(run_id);
  // One snapshot for every SELECT, so a concurrent writer cannot split the run.
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();

  StoredRun out;
  {
    Result<Statement> q = Statement::prepare(conn, select_summaries(" WHERE r.id = ?1"), operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    Result<bool> row = q->step();
    if (!row.ok()) return row.error();
    if (!*row) {
      return make_error(ErrorCode::kNotFound,
                        "run " + std::to_string(run_id) + " is not in run database " + conn.path.string());
    }
    out.summary = read_summary(*q);
    out.note = out.summary.note;
    LobeAnalysis& a = out.analysis;
    a.zero_offset_mm = q->column_double(kSummaryColumnCount - 1);
    a.max_abs_error_um = out.summary.max_abs_error_um;
    a.rms_error_um = out.summary.rms_error_um;
    a.peak_to_valley_um = out.summary.peak_to_valley_um;
    a.repeatability_um = out.summary.repeatability_um;
    a.phase_error_deg = out.summary.phase_error_deg.value_or(0.0);
    a.base_circle_runout_um = out.summary.base_circle_runout_um.value_or(0.0);
  }
  {
    Result<Statement> q = Statement::prepare(conn, kLoadDetails, operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    Result<bool> row = q->step();
    if (!row.ok()) return row.error();
    if (!*row) return damaged(conn, run_id, "its row vanished while it was read");
    out.finished_utc = q->column_text(0);
    out.gauge = q->column_text(1);
    out.polls = q->column_int64(2);
    out.reconnects = q->column_int64(3);
    out.discarded_revolutions = q->column_int64(4);
    if (!q->column_is_null(5)) out.correction_in_force_run = q->column_int64(5);
    out.settings = q->column_text(6);
    if (!q->column_is_null(7)) {
      Result<std::vector<double>> h = storage_internal::numbers_from_json(q->column_text(7));
      if (!h.ok() || h->size() != out.analysis.harmonic_amplitude_um.size()) {
        return damaged(conn, run_id, "harmonic_amplitude_um is not a JSON array of 31 numbers");
      }
      for (std::size_t i = 0; i < h->size(); ++i) out.analysis.harmonic_amplitude_um[i] = (*h)[i];
    }
    if (!q->column_is_null(8)) {
      Part g;
      g.name = out.summary.part;
      g.lobe = out.summary.lobe;
      g.rotation_sense = q->column_int(8);
      g.c_offset_deg = q->column_double(9);
      g.probe_offset_deg = q->column_double(10);
      if (std::optional<FollowerKind> kind = follower_from_db(q->column_text(11))) g.follower = *kind;
      g.follower_radius_mm = q->column_double(12);
      g.base_circle_radius_mm = q->column_double(13);
      g.wheel_radius_mm = q->column_double(14);
      out.geometry = g;
    }
    if (!q->column_is_null(15)) out.ground_with_version = q->column_int(15);
    out.ground_with_source = q->column_text(16);
    out.inspection = q->column_int(17) != 0;
  }
  {
    Result<Statement> q = Statement::prepare(conn, kLoadRaw, operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    Result<bool> row = q->step();
    if (!row.ok()) return row.error();
    if (*row) {
      Result<std::vector<double>> counts = storage_internal::numbers_from_json(q->column_text(0));
      if (!counts.ok()) return damaged(conn, run_id, "amplifier_revolutions: " + counts.error().message);
      const std::string lift = q->column_blob(1);
      if (lift.size() != counts->size() * storage_internal::kDegreeBlobBytes) {
        return damaged(conn, run_id,
                       "the raw lift BLOB holds " + std::to_string(lift.size()) + " bytes for " +
                           std::to_string(counts->size()) + " revolutions");
      }
      for (std::size_t i = 0; i < counts->size(); ++i) {
        Result<DegreeTable> t = storage_internal::read_degree_blob(lift, i * storage_internal::kDegreeBlobBytes,
                                                                   storage_internal::kCountsPerMm);
        if (!t.ok()) return damaged(conn, run_id, t.error().message);
        out.revolutions.push_back(RevolutionSamples{static_cast<std::int64_t>((*counts)[i]), *t});
      }
      if (out.revolutions.size() != static_cast<std::size_t>(out.summary.revolutions)) {
        return damaged(conn, run_id,
                       "it lists " + std::to_string(out.summary.revolutions) + " revolutions but holds " +
                           std::to_string(out.revolutions.size()));
      }
    } else if (out.summary.raw_pruned_utc.empty()) {
      return damaged(conn, run_id, "its raw revolutions are missing but it was never pruned");
    }
  }
  {
    Result<Statement> q = Statement::prepare(conn, kLoadTables, operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    Result<bool> row = q->step();
    if (!row.ok()) return row.error();
    if (!*row) return damaged(conn, run_id, "its profile (run_tables) is missing");
    const std::array<std::pair<DegreeTable*, double>, 5> tables = {{
        {&out.analysis.design_lift_mm, storage_internal::kCountsPerMm},
        {&out.analysis.mean_lift_mm, storage_internal::kCountsPerMm},
        {&out.analysis.spread_um, storage_internal::kCountsPerUm},
        {&out.analysis.error_um, storage_internal::kCountsPerUm},
        {&out.correction_um, storage_internal::kCountsPerUm},
    }};
    for (std::size_t i = 0; i < tables.size(); ++i) {
      Result<DegreeTable> t =
          storage_internal::read_degree_blob(q->column_blob(static_cast<int>(i)), 0, tables[i].second);
      if (!t.ok()) return damaged(conn, run_id, "profile column " + std::to_string(i) + ": " + t.error().message);
      *tables[i].first = *t;
    }
  }
  {
    Result<Statement> q = Statement::prepare(
        conn, "SELECT " + std::string(kPushColumns) + " FROM nc_pushes AS p WHERE p.run_id = ?1 ORDER BY p.id",
        operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    for (;;) {
      Result<bool> row = q->step();
      if (!row.ok()) return row.error();
      if (!*row) break;
      out.pushes.push_back(read_push(*q, false));
    }
  }
  Status s = tx->commit();
  if (!s.ok()) return s.error();
  return out;
}

Result<std::int64_t> RunStore::prune_raw_samples(const std::string& cutoff_utc, const std::string& now_utc) {
  if (!is_utc_timestamp(cutoff_utc)) return bad_bound("cannot prune raw samples: cutoff", cutoff_utc);
  if (!is_utc_timestamp(now_utc)) return bad_bound("cannot prune raw samples: now", now_utc);
  Connection& conn = *conn_;
  const std::string operation = "prune the raw samples of runs started before " + cutoff_utc;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> mark = Statement::prepare(conn,
                                              "UPDATE runs SET raw_pruned_utc = ?2 WHERE started_utc < ?1"
                                              " AND id IN (SELECT run_id FROM run_raw)",
                                              operation);
  if (!mark.ok()) return mark.error();
  mark->bind(1, std::string_view(cutoff_utc));
  mark->bind(2, std::string_view(now_utc));
  if (Status s = mark->run(); !s.ok()) return s.error();
  const std::int64_t pruned = sqlite3_changes(conn.db);
  Result<Statement> del = Statement::prepare(
      conn, "DELETE FROM run_raw WHERE run_id IN (SELECT id FROM runs WHERE started_utc < ?1)", operation);
  if (!del.ok()) return del.error();
  del->bind(1, std::string_view(cutoff_utc));
  if (Status s = del->run(); !s.ok()) return s.error();
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return pruned;
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

std::string_view pending_verdict_name(PendingVerdict verdict) {
  return verdict == PendingVerdict::kHold ? "hold" : "apply";
}

std::string_view pending_status_name(PendingStatus status) {
  switch (status) {
    case PendingStatus::kPending:
      return "pending";
    case PendingStatus::kApproved:
      return "approved";
    case PendingStatus::kRejected:
      return "rejected";
    case PendingStatus::kSuperseded:
      return "superseded";
  }
  return "pending";
}

std::string_view event_kind_name(EventKind kind) {
  switch (kind) {
    case EventKind::kFault:
      return "fault";
    case EventKind::kRefusal:
      return "refusal";
    case EventKind::kInfo:
      return "info";
  }
  return "fault";
}

EventKind event_kind_for(ErrorCode code) {
  return code == ErrorCode::kRefused ? EventKind::kRefusal : EventKind::kFault;
}

}  // namespace gaugeloop
