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

#include "storage/degree_blob.h"
#include "storage/degree_json.h"
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

// Exactly "YYYY-MM-DDTHH:MM:SSZ" with plausible field ranges: fixed width keeps text order
// equal to time order, which list_runs relies on.
bool is_utc_timestamp(std::string_view s) {
  constexpr std::string_view kShape = "dddd-dd-ddTdd:dd:ddZ";
  if (s.size() != kShape.size()) return false;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const bool digit = std::isdigit(static_cast<unsigned char>(s[i])) != 0;
    if (kShape[i] == 'd' ? !digit : s[i] != kShape[i]) return false;
  }
  auto field = [s](std::size_t at) { return (s[at] - '0') * 10 + (s[at + 1] - '0'); };
  const int month = field(5), day = field(8), hour = field(11), minute = field(14), second = field(17);
  return month >= 1 && month <= 12 && day >= 1 && day <= 31 && hour <= 23 && minute <= 59 &&
         second <= 60;  // 60: a leap second
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

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

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
                  rotation_sense, c_offset_deg, probe_offset_deg)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 'measured', ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17,
        NULL, ?18, ?19, ?20, ?21, ?22, ?23, ?24, ?25))sql";

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
       r.probe_offset_deg, p.follower, p.follower_radius_mm, p.base_circle_radius_mm, p.wheel_radius_mm
FROM runs AS r
LEFT JOIN settings AS s ON s.hash = r.settings_hash
LEFT JOIN parts AS p ON p.name = r.part
WHERE r.id = ?1)sql";

constexpr std::string_view kLoadRaw = "SELECT amplifier_revolutions, lift FROM run_raw WHERE run_id = ?1";

constexpr std::string_view kLoadTables =
    "SELECT design_lift, mean_lift, spread, error, correction FROM run_tables WHERE run_id = ?1";

constexpr std::string_view kLoadPushes = R"sql(
SELECT pushed_utc, nc_file, point_count, correction_max_um, program_hash FROM nc_pushes
WHERE run_id = ?1 ORDER BY id)sql";

constexpr std::string_view kRecordNcFile = "UPDATE runs SET status = 'pushed', nc_file = ?2 WHERE id = ?1";

constexpr std::string_view kInsertPush = R"sql(
INSERT INTO nc_pushes (run_id, pushed_utc, nc_file, point_count, correction_max_um, program_hash)
VALUES (?1, ?2, ?3, ?4, ?5, ?6))sql";

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
  // would only find out at the first insert, after a whole measurement.
  if (sqlite3_db_readonly(conn->db, "main") == 1) {
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
  Status migrated = storage_internal::apply_migrations(**conn);
  if (!migrated.ok()) return migrated.error();
  return RunStore(std::move(*conn));
}

const std::filesystem::path& RunStore::path() const { return conn_->path; }

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

Status RunStore::record_nc_file(std::int64_t run_id, const std::string& nc_path) {
  NcPush push;
  push.nc_file = nc_path;
  return record_push(run_id, push);
}

Status RunStore::record_push(std::int64_t run_id, const NcPush& push, std::string_view program_text) {
  if (push.nc_file.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot record an NC file for run " + std::to_string(run_id) + ": the NC file path is empty");
  }
  if (!push.pushed_utc.empty() && !is_utc_timestamp(push.pushed_utc)) {
    return bad_bound("cannot record an NC file for run " + std::to_string(run_id) + ": pushed_utc", push.pushed_utc);
  }
  if (push.correction_max_um && !std::isfinite(*push.correction_max_um)) {
    return make_error(ErrorCode::kInvalidInput, "cannot record an NC file for run " + std::to_string(run_id) +
                                                    ": correction_max_um is not finite");
  }
  Connection& conn = *conn_;
  const std::string operation = "record NC file " + push.nc_file + " for run " + std::to_string(run_id);
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> upd = Statement::prepare(conn, kRecordNcFile, operation);
  if (!upd.ok()) return upd.error();
  upd->bind(1, run_id);
  upd->bind(2, std::string_view(push.nc_file));
  Status s = upd->run();
  if (!s.ok()) return s;
  if (sqlite3_changes(conn.db) == 0) {
    return make_error(ErrorCode::kNotFound, "cannot " + operation + ": run " + std::to_string(run_id) +
                                                " is not in run database " + conn.path.string());
  }
  Result<Statement> ins = Statement::prepare(conn, kInsertPush, operation);
  if (!ins.ok()) return ins.error();
  ins->bind(1, run_id);
  ins->bind(2, std::string_view(push.pushed_utc.empty() ? utc_now() : push.pushed_utc));
  ins->bind(3, std::string_view(push.nc_file));
  if (push.point_count) {
    ins->bind(4, *push.point_count);
  } else {
    ins->bind_null(4);
  }
  if (push.correction_max_um) {
    ins->bind(5, *push.correction_max_um);
  } else {
    ins->bind_null(5);
  }
  std::string program_hash = push.program_hash;
  if (!program_text.empty()) program_hash = settings_hash(program_text);
  if (program_hash.empty()) {
    ins->bind_null(6);
  } else {
    ins->bind(6, std::string_view(program_hash));
  }
  if (s = ins->run(); !s.ok()) return s;
  return tx->commit();
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
    e.event.kind = st->column_text(2) == "refusal" ? EventKind::kRefusal : EventKind::kFault;
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
                                           "SELECT id FROM runs WHERE machine = ?1 AND part = ?2 AND lobe = ?3"
                                           " AND status = 'pushed' ORDER BY started_utc DESC, id DESC LIMIT 1",
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
    Result<Statement> q = Statement::prepare(conn, kLoadPushes, operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    for (;;) {
      Result<bool> row = q->step();
      if (!row.ok()) return row.error();
      if (!*row) break;
      NcPush p;
      p.pushed_utc = q->column_text(0);
      p.nc_file = q->column_text(1);
      if (!q->column_is_null(2)) p.point_count = q->column_int(2);
      if (!q->column_is_null(3)) p.correction_max_um = q->column_double(3);
      p.program_hash = q->column_text(4);
      out.pushes.push_back(std::move(p));
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

std::string_view event_kind_name(EventKind kind) { return kind == EventKind::kRefusal ? "refusal" : "fault"; }

EventKind event_kind_for(ErrorCode code) {
  return code == ErrorCode::kRefused ? EventKind::kRefusal : EventKind::kFault;
}

}  // namespace gaugeloop
