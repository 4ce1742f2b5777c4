// The run database: every measurement run, its analysis and its correction, kept in SQLite.
#include "storage/run_store.h"

#include <cctype>
#include <climits>
#include <cmath>
#include <cstddef>
#include <string_view>
#include <system_error>
#include <utility>

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

// The non-finite checks matter beyond tidiness: SQLite binds a NaN double as NULL, and a JSON
// array cannot hold one at all.
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
    Status ok = check_table(rev.lift_mm, "run_revolutions.lift_mm of revolution " + std::to_string(i), "machine");
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
  return {};
}

// ---- SQL ----

constexpr std::string_view kInsertRun = R"sql(
INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, note, status,
                  revolutions, degrees_captured, polls, reconnects, discarded_revolutions,
                  zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um,
                  repeatability_um, nc_file, correction_in_force_run)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, 'measured', ?8, ?9, ?10, ?11, ?12, ?13, ?14, ?15, ?16, ?17,
        NULL, ?18))sql";

constexpr std::string_view kInsertRevolution = R"sql(
INSERT INTO run_revolutions (run_id, revolution_index, amplifier_revolution, lift_mm)
VALUES (?1, ?2, ?3, ?4))sql";

constexpr std::string_view kInsertProfile = R"sql(
INSERT INTO run_profile (run_id, angle_deg, design_lift_mm, mean_lift_mm, spread_um, error_um,
                         correction_um)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7))sql";

// Columns 0..11, read by read_summary().
constexpr std::string_view kSummaryColumns =
    "id, started_utc, machine, part, lobe, status, revolutions, degrees_captured, "
    "max_abs_error_um, rms_error_um, repeatability_um, nc_file";

std::string select_summaries(std::string_view rest) {
  return "SELECT " + std::string(kSummaryColumns) + std::string(rest);
}

constexpr std::string_view kLoadRevolutions = R"sql(
SELECT revolution_index, amplifier_revolution, lift_mm FROM run_revolutions
WHERE run_id = ?1 ORDER BY revolution_index)sql";

constexpr std::string_view kLoadProfile = R"sql(
SELECT angle_deg, design_lift_mm, mean_lift_mm, spread_um, error_um, correction_um
FROM run_profile WHERE run_id = ?1 ORDER BY angle_deg)sql";

constexpr std::string_view kRecordNcFile = "UPDATE runs SET status = 'pushed', nc_file = ?2 WHERE id = ?1";

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
  return r;
}

Error damaged(const Connection& conn, std::int64_t run_id, const std::string& what) {
  return make_error(ErrorCode::kStorage, "run database " + conn.path.string() + ": run " + std::to_string(run_id) +
                                             " is damaged: " + what +
                                             "; the rows were changed outside gaugeloop, restore a backup");
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

  std::vector<std::string> lift_json;
  lift_json.reserve(run.measured.revolutions.size());
  for (const RevolutionSamples& rev : run.measured.revolutions) {
    lift_json.push_back(storage_internal::degree_table_to_json(rev.lift_mm));
  }

  Connection& conn = *conn_;
  const std::string operation =
      "store the run of part " + run.part + " lobe " + std::to_string(run.lobe) + " started " + run.started_utc;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();

  const int revolutions = static_cast<int>(run.measured.revolutions.size());
  const LobeAnalysis& a = run.analysis;
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
  Status s = ins->run();
  if (!s.ok()) return s.error();
  const std::int64_t run_id = sqlite3_last_insert_rowid(conn.db);

  Result<Statement> rev = Statement::prepare(conn, kInsertRevolution, operation);
  if (!rev.ok()) return rev.error();
  for (int i = 0; i < revolutions; ++i) {
    rev->reset();
    rev->bind(1, run_id);
    rev->bind(2, i);
    rev->bind(3, run.measured.revolutions[static_cast<std::size_t>(i)].revolution);
    rev->bind(4, std::string_view(lift_json[static_cast<std::size_t>(i)]));
    s = rev->run();
    if (!s.ok()) return s.error();
  }

  Result<Statement> prof = Statement::prepare(conn, kInsertProfile, operation);
  if (!prof.ok()) return prof.error();
  for (int deg = 0; deg < kDegreesPerRevolution; ++deg) {
    const auto d = static_cast<std::size_t>(deg);
    prof->reset();
    prof->bind(1, run_id);
    prof->bind(2, deg);
    prof->bind(3, a.design_lift_mm[d]);
    prof->bind(4, a.mean_lift_mm[d]);
    prof->bind(5, a.spread_um[d]);
    prof->bind(6, a.error_um[d]);
    prof->bind(7, run.correction_um[d]);
    s = prof->run();
    if (!s.ok()) return s.error();
  }

  s = tx->commit();
  if (!s.ok()) return s.error();
  return run_id;
}

Status RunStore::record_nc_file(std::int64_t run_id, const std::string& nc_path) {
  if (nc_path.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot record an NC file for run " + std::to_string(run_id) + ": the NC file path is empty");
  }
  Connection& conn = *conn_;
  const std::string operation = "record NC file " + nc_path + " for run " + std::to_string(run_id);
  Result<Statement> upd = Statement::prepare(conn, kRecordNcFile, operation);
  if (!upd.ok()) return upd.error();
  upd->bind(1, run_id);
  upd->bind(2, std::string_view(nc_path));
  Status s = upd->run();
  if (!s.ok()) return s;
  if (sqlite3_changes(conn.db) == 0) {
    return make_error(ErrorCode::kNotFound, "cannot " + operation + ": run " + std::to_string(run_id) +
                                                " is not in run database " + conn.path.string());
  }
  return {};
}

Result<std::vector<RunSummary>> RunStore::list_runs(const RunQuery& q) const {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list runs: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  Connection& conn = *conn_;
  Result<Statement> list =
      Statement::prepare(conn,
                         select_summaries(q.part.empty() ? " FROM runs"
                                                           " ORDER BY started_utc DESC, id DESC LIMIT ?1"
                                                         : " FROM runs WHERE part = ?2"
                                                           " ORDER BY started_utc DESC, id DESC LIMIT ?1"),
                         "list runs");
  if (!list.ok()) return list.error();
  list->bind(1, q.limit);
  if (!q.part.empty()) list->bind(2, std::string_view(q.part));

  std::vector<RunSummary> runs;
  for (;;) {
    Result<bool> row = list->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    runs.push_back(read_summary(*list));
  }
  return runs;
}

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
  // One snapshot for the three SELECTs, so a concurrent writer cannot split the run.
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();

  StoredRun out;
  {
    // Columns 12..20 follow the summary.
    Result<Statement> q = Statement::prepare(
        conn,
        select_summaries(", finished_utc, gauge, note, polls, reconnects, discarded_revolutions,"
                         " zero_offset_mm, peak_to_valley_um, correction_in_force_run FROM runs WHERE id = ?1"),
        operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    Result<bool> row = q->step();
    if (!row.ok()) return row.error();
    if (!*row) {
      return make_error(ErrorCode::kNotFound, "run " + std::to_string(run_id) + " is not in run database " +
                                                  conn.path.string() + "; list the runs to see which ids exist");
    }
    out.summary = read_summary(*q);
    out.finished_utc = q->column_text(12);
    out.gauge = q->column_text(13);
    out.note = q->column_text(14);
    out.polls = q->column_int64(15);
    out.reconnects = q->column_int64(16);
    out.discarded_revolutions = q->column_int64(17);
    out.analysis.zero_offset_mm = q->column_double(18);
    out.analysis.peak_to_valley_um = q->column_double(19);
    if (!q->column_is_null(20)) out.correction_in_force_run = q->column_int64(20);
    out.analysis.max_abs_error_um = out.summary.max_abs_error_um;
    out.analysis.rms_error_um = out.summary.rms_error_um;
    out.analysis.repeatability_um = out.summary.repeatability_um;
  }
  {
    Result<Statement> q = Statement::prepare(conn, kLoadRevolutions, operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    for (;;) {
      Result<bool> row = q->step();
      if (!row.ok()) return row.error();
      if (!*row) break;
      const std::int64_t index = q->column_int64(0);
      if (index != static_cast<std::int64_t>(out.revolutions.size())) {
        return damaged(conn, run_id, "revolution " + std::to_string(out.revolutions.size()) + " is missing");
      }
      Result<DegreeTable> lift = storage_internal::degree_table_from_json(q->column_text(2));
      if (!lift.ok()) {
        return damaged(conn, run_id, "lift_mm of revolution " + std::to_string(index) + ": " + lift.error().message);
      }
      out.revolutions.push_back(RevolutionSamples{q->column_int64(1), *lift});
    }
    if (out.revolutions.size() != static_cast<std::size_t>(out.summary.revolutions)) {
      return damaged(conn, run_id,
                     "it lists " + std::to_string(out.summary.revolutions) + " revolutions but holds " +
                         std::to_string(out.revolutions.size()));
    }
  }
  {
    Result<Statement> q = Statement::prepare(conn, kLoadProfile, operation);
    if (!q.ok()) return q.error();
    q->bind(1, run_id);
    int deg = 0;
    for (;; ++deg) {
      Result<bool> row = q->step();
      if (!row.ok()) return row.error();
      if (!*row) break;
      if (deg >= kDegreesPerRevolution || q->column_int(0) != deg) {
        return damaged(conn, run_id, "the profile row for cam degree " + std::to_string(deg) + " is missing");
      }
      const auto d = static_cast<std::size_t>(deg);
      out.analysis.design_lift_mm[d] = q->column_double(1);
      out.analysis.mean_lift_mm[d] = q->column_double(2);
      out.analysis.spread_um[d] = q->column_double(3);
      out.analysis.error_um[d] = q->column_double(4);
      out.correction_um[d] = q->column_double(5);
    }
    if (deg != kDegreesPerRevolution) {
      return damaged(
          conn, run_id,
          "the profile has " + std::to_string(deg) + " rows instead of " + std::to_string(kDegreesPerRevolution));
    }
  }
  Status s = tx->commit();
  if (!s.ok()) return s.error();
  return out;
}

}  // namespace gaugeloop
