// RunStore's runs: storing a measurement run whole, reading it back, listing and pruning runs.
#include <algorithm>
#include <array>
#include <cstdio>
#include <initializer_list>
#include <map>
#include <utility>

#include "core/utc_time.h"
#include "storage/characteristic_summaries.h"
#include "storage/degree_blob.h"
#include "storage/degree_json.h"
#include "storage/record_checks.h"
#include "storage/run_store.h"

#include "core/uuid.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::Blob;
using storage_internal::Connection;
using storage_internal::damaged_run;
using storage_internal::kCountsPerMm;
using storage_internal::kCountsPerUm;
using storage_internal::Statement;
using storage_internal::text_or_null;
using storage_internal::Transaction;

namespace {

// ---- SQL ----

constexpr std::string_view kInsertRun = R"sql(
INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, note, status,
                  revolutions, degrees_captured, polls, reconnects, discarded_revolutions,
                  zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um,
                  repeatability_um, nc_file, correction_in_force_run, settings_hash,
                  phase_error_deg, base_circle_runout_um, harmonic_amplitude_um,
                  rotation_sense, c_offset_deg, probe_offset_deg, ground_with_version,
                  ground_with_source, inspection, serial, operator, verdict, lift_error_reference,
                  max_abs_residual_um, rms_residual_um, peak_to_valley_residual_um, dial_runout_um,
                  roundness_um, uuid, harmonics_fed_back, harmonic_threshold_um)
VALUES (:started_utc, :finished_utc, :machine, :part, :lobe, :gauge, :note, 'measured',
        :revolutions, :degrees_captured, :polls, :reconnects, :discarded_revolutions,
        :zero_offset_mm, :max_abs_error_um, :rms_error_um, :peak_to_valley_um,
        :repeatability_um, NULL, :correction_in_force_run, :settings_hash,
        :phase_error_deg, :base_circle_runout_um, :harmonic_amplitude_um,
        :rotation_sense, :c_offset_deg, :probe_offset_deg, :ground_with_version,
        :ground_with_source, :inspection, :serial, :operator, :verdict, :lift_error_reference,
        :max_abs_residual_um, :rms_residual_um, :peak_to_valley_residual_um, :dial_runout_um,
        :roundness_um, :uuid, :harmonics_fed_back, :harmonic_threshold_um))sql";

constexpr std::string_view kInsertRaw = R"sql(
INSERT INTO run_raw (run_id, amplifier_revolutions, lift, checksum) VALUES (?1, ?2, ?3, ?4))sql";

constexpr std::string_view kInsertTables = R"sql(
INSERT INTO run_tables (run_id, design_lift, mean_lift, spread, error, correction, residual_error, checksum)
VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8))sql";

constexpr std::string_view kInsertCharacteristic = R"sql(
INSERT INTO run_characteristics (run_id, position, key, unit, value, min_value, max_value,
                                 lower_limit, upper_limit, verdict, from_deg, to_deg)
VALUES (:run_id, :position, :key, :unit, :value, :min_value, :max_value,
        :lower_limit, :upper_limit, :verdict, :from_deg, :to_deg))sql";

constexpr std::string_view kCharacteristicColumns =
    "key, unit, value, min_value, max_value, lower_limit, upper_limit, verdict, from_deg, to_deg";

// The catalogue row exists (the runs trigger made it); a run that knows the geometry updates it.
constexpr std::string_view kUpdatePart = R"sql(
UPDATE parts SET follower = :follower, follower_radius_mm = :follower_radius_mm,
                 base_circle_radius_mm = :base_circle_radius_mm, wheel_radius_mm = :wheel_radius_mm
WHERE name = :part)sql";

constexpr std::string_view kUpdateLobe = R"sql(
UPDATE lobes SET rotation_sense = :rotation_sense, c_offset_deg = :c_offset_deg,
                 probe_offset_deg = :probe_offset_deg
WHERE part = :part AND lobe = :lobe)sql";

// Columns 0..23, read by read_summary() and (zero_offset_mm) read_summary_of_run().
constexpr std::string_view kSummaryColumns =
    "r.id, r.started_utc, r.machine, r.part, r.lobe, r.status, r.revolutions, r.degrees_captured, "
    "r.max_abs_error_um, r.rms_error_um, r.repeatability_um, r.nc_file, r.phase_error_deg, "
    "r.base_circle_runout_um, r.peak_to_valley_um, r.settings_hash, r.note, r.raw_pruned_utc, r.serial, "
    "r.operator, r.zero_offset_mm, r.verdict, r.uuid, r.lift_error_reference";
constexpr int kZeroOffsetColumn = 20;
constexpr int kVerdictColumn = 21;
constexpr int kUuidColumn = 22;
constexpr int kReferenceColumn = 23;

std::string select_summaries(std::string_view rest) {
  return "SELECT " + std::string(kSummaryColumns) + " FROM runs AS r" + std::string(rest);
}

constexpr std::string_view kLoadDetails = R"sql(
SELECT r.finished_utc, r.gauge, r.polls, r.reconnects, r.discarded_revolutions,
       r.correction_in_force_run, s.text, r.harmonic_amplitude_um, r.rotation_sense, r.c_offset_deg,
       r.probe_offset_deg, p.follower, p.follower_radius_mm, p.base_circle_radius_mm, p.wheel_radius_mm,
       r.ground_with_version, r.ground_with_source, r.inspection, r.lift_error_reference,
       r.max_abs_residual_um, r.rms_residual_um, r.peak_to_valley_residual_um, r.dial_runout_um,
       r.roundness_um, r.harmonics_fed_back, r.harmonic_threshold_um
FROM runs AS r
LEFT JOIN settings AS s ON s.hash = r.settings_hash
LEFT JOIN parts AS p ON p.name = r.part
WHERE r.id = :run_id)sql";

// The follower as the schema stores it (its CHECK names these three). Apart from
// follower_kind_name on purpose: the words shown to people may change, the stored ones not.
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

// ---- storing a run ----

// A run's per-degree tables and lists as they are stored, made before the transaction
// begins: a value out of range is refused with nothing written.
struct EncodedRun {
  std::string lift;                   // every revolution's lift_mm, one BLOB
  std::string amplifier;              // JSON array of the amplifier's revolution counts
  std::array<std::string, 6> tables;  // design, mean, spread, error, correction, residual BLOBs
  std::string harmonics;              // JSON array
  std::string settings_hash;          // empty: no settings recorded
};

Result<EncodedRun> encode(const RunRecord& run) {
  EncodedRun e;
  e.amplifier = "[";
  e.lift.reserve(run.measured.revolutions.size() * storage_internal::kDegreeBlobBytes);
  for (std::size_t i = 0; i < run.measured.revolutions.size(); ++i) {
    const RevolutionSamples& rev = run.measured.revolutions[i];
    Status s = storage_internal::append_degree_blob(
        rev.lift_mm, kCountsPerMm, "lift_mm of revolution " + std::to_string(i) + " (machine frame)", e.lift);
    if (!s.ok()) return storage_internal::run_refused(s.error().message);
    e.amplifier += (i == 0 ? "" : ",") + std::to_string(rev.revolution);
  }
  e.amplifier += "]";
  const LobeAnalysis& a = run.analysis;
  const std::array<std::pair<const DegreeTable*, double>, 6> tables = {{
      {&a.design_lift_mm, kCountsPerMm},
      {&a.mean_lift_mm, kCountsPerMm},
      {&a.spread_um, kCountsPerUm},
      {&a.error_um, kCountsPerUm},
      {&run.correction_um, kCountsPerUm},
      {&a.residual_error_um, kCountsPerUm},
  }};
  static constexpr std::array<std::string_view, 6> kTableNames = {
      "design_lift_mm (cam frame)", "mean_lift_mm (cam frame)",  "spread_um (cam frame)",
      "error_um (cam frame)",       "correction_um (cam frame)", "residual_error_um (cam frame)"};
  for (std::size_t i = 0; i < tables.size(); ++i) {
    Status s = storage_internal::append_degree_blob(*tables[i].first, tables[i].second, kTableNames[i], e.tables[i]);
    if (!s.ok()) return storage_internal::run_refused(s.error().message);
  }
  e.harmonics = "[";
  for (std::size_t h = 0; h < a.harmonic_amplitude_um.size(); ++h) {
    e.harmonics += (h == 0 ? "" : ",") + exact_number(a.harmonic_amplitude_um[h]);
  }
  e.harmonics += "]";
  if (!run.settings.empty()) e.settings_hash = settings_hash(run.settings);
  return e;
}

Status insert_settings(Connection& conn, const RunRecord& run, const EncodedRun& e, const std::string& operation) {
  if (e.settings_hash.empty()) return {};
  Result<Statement> st =
      Statement::prepare(conn, "INSERT OR IGNORE INTO settings (hash, text) VALUES (?1, ?2)", operation);
  if (!st.ok()) return st.error();
  st->bind_all(std::string_view(e.settings_hash), std::string_view(run.settings));
  return st->run();
}

Result<std::int64_t> insert_run_row(Connection& conn, const RunRecord& run, const EncodedRun& e,
                                    const std::string& operation) {
  Result<Statement> ins = Statement::prepare(conn, kInsertRun, operation);
  if (!ins.ok()) return ins.error();
  // check_run_record bounds the count, so both fit an int.
  const int revolutions = static_cast<int>(run.measured.revolutions.size());
  const LobeAnalysis& a = run.analysis;
  const std::optional<Part>& g = run.geometry;
  ins->bind(":started_utc", run.started_utc);
  ins->bind(":uuid", run.uuid.empty() ? new_uuid() : run.uuid);
  ins->bind(":finished_utc", run.finished_utc);
  ins->bind(":machine", run.machine);
  ins->bind(":part", run.part);
  ins->bind(":lobe", run.lobe);
  ins->bind(":gauge", run.gauge);
  ins->bind(":note", run.note);
  ins->bind(":revolutions", revolutions);
  ins->bind(":degrees_captured", revolutions * kDegreesPerRevolution);
  ins->bind(":polls", run.measured.polls);
  ins->bind(":reconnects", run.measured.reconnects);
  ins->bind(":discarded_revolutions", run.measured.discarded_revolutions);
  ins->bind(":zero_offset_mm", a.zero_offset_mm);
  ins->bind(":max_abs_error_um", a.max_abs_error_um);
  ins->bind(":rms_error_um", a.rms_error_um);
  ins->bind(":peak_to_valley_um", a.peak_to_valley_um);
  ins->bind(":repeatability_um", a.repeatability_um);
  ins->bind(":correction_in_force_run", run.correction_in_force_run);
  ins->bind(":settings_hash", text_or_null(e.settings_hash));
  ins->bind(":phase_error_deg", a.phase_error_deg);
  ins->bind(":base_circle_runout_um", a.base_circle_runout_um);
  ins->bind(":harmonic_amplitude_um", e.harmonics);
  ins->bind(":rotation_sense", g ? std::optional<int>(g->rotation_sense) : std::nullopt);
  ins->bind(":c_offset_deg", g ? std::optional<double>(g->c_offset_deg) : std::nullopt);
  ins->bind(":probe_offset_deg", g ? std::optional<double>(g->probe_offset_deg) : std::nullopt);
  ins->bind(":ground_with_version", run.ground_with_version);
  ins->bind(":ground_with_source", text_or_null(run.ground_with_source));
  ins->bind(":inspection", run.inspection ? 1 : 0);
  ins->bind(":harmonics_fed_back", run.harmonics_fed_back);
  ins->bind(":harmonic_threshold_um", run.harmonic_threshold_um);
  ins->bind(":serial", text_or_null(run.serial));
  ins->bind(":operator", text_or_null(run.operator_name));
  ins->bind(":verdict", verdict_name(run.verdict));
  ins->bind(":lift_error_reference", lift_error_reference_name(run.lift_error_reference));
  ins->bind(":max_abs_residual_um", a.max_abs_residual_um);
  ins->bind(":rms_residual_um", a.rms_residual_um);
  ins->bind(":peak_to_valley_residual_um", a.peak_to_valley_residual_um);
  ins->bind(":dial_runout_um", a.dial_runout_um);
  ins->bind(":roundness_um", a.roundness_um);
  if (Status s = ins->run(); !s.ok()) return s.error();
  return conn.last_insert_rowid();
}

// The parts and lobes catalogue learns the geometry the run was measured with.
Status update_catalogue(Connection& conn, const RunRecord& run, const Part& g, const std::string& operation) {
  Result<Statement> part = Statement::prepare(conn, kUpdatePart, operation);
  if (!part.ok()) return part.error();
  part->bind(":part", run.part);
  part->bind(":follower", follower_db_name(g.follower));
  part->bind(":follower_radius_mm", g.follower_radius_mm);
  part->bind(":base_circle_radius_mm", g.base_circle_radius_mm);
  part->bind(":wheel_radius_mm", g.wheel_radius_mm);
  if (Status s = part->run(); !s.ok()) return s;
  Result<Statement> lobe = Statement::prepare(conn, kUpdateLobe, operation);
  if (!lobe.ok()) return lobe.error();
  lobe->bind(":part", run.part);
  lobe->bind(":lobe", run.lobe);
  lobe->bind(":rotation_sense", g.rotation_sense);
  lobe->bind(":c_offset_deg", g.c_offset_deg);
  lobe->bind(":probe_offset_deg", g.probe_offset_deg);
  return lobe->run();
}

Status insert_degree_rows(Connection& conn, std::int64_t run_id, const EncodedRun& e, const std::string& operation) {
  Result<Statement> raw = Statement::prepare(conn, kInsertRaw, operation);
  if (!raw.ok()) return raw.error();
  raw->bind_all(run_id, std::string_view(e.amplifier), Blob{e.lift},
                storage_internal::raw_checksum(e.amplifier, e.lift));
  if (Status s = raw->run(); !s.ok()) return s;
  Result<Statement> tab = Statement::prepare(conn, kInsertTables, operation);
  if (!tab.ok()) return tab.error();
  const std::int64_t checksum = storage_internal::tables_checksum(
      {e.tables[0], e.tables[1], e.tables[2], e.tables[3], e.tables[4]}, std::string_view(e.tables[5]));
  tab->bind_all(run_id, Blob{e.tables[0]}, Blob{e.tables[1]}, Blob{e.tables[2]}, Blob{e.tables[3]}, Blob{e.tables[4]},
                Blob{e.tables[5]}, checksum);
  return tab->run();
}

Status insert_characteristics(Connection& conn, std::int64_t run_id, const RunRecord& run,
                              const std::string& operation) {
  if (run.characteristics.empty()) return {};
  Result<Statement> ins = Statement::prepare(conn, kInsertCharacteristic, operation);
  if (!ins.ok()) return ins.error();
  for (std::size_t i = 0; i < run.characteristics.size(); ++i) {
    const Characteristic& c = run.characteristics[i];
    ins->reset();
    ins->bind(":run_id", run_id);
    ins->bind(":position", static_cast<std::int64_t>(i));
    ins->bind(":key", c.key);
    ins->bind(":unit", c.unit);
    ins->bind(":value", c.value);
    ins->bind(":min_value", c.min);
    ins->bind(":max_value", c.max);
    ins->bind(":lower_limit", c.limits.lower);
    ins->bind(":upper_limit", c.limits.upper);
    ins->bind(":verdict", verdict_name(c.verdict));
    ins->bind(":from_deg", c.from_deg);
    ins->bind(":to_deg", c.to_deg);
    if (Status s = ins->run(); !s.ok()) return s;
  }
  return {};
}

}  // namespace

Result<std::int64_t> RunStore::insert_run(const RunRecord& run) {
  if (Status valid = storage_internal::check_run_record(run); !valid.ok()) return valid.error();
  Result<EncodedRun> encoded = encode(run);
  if (!encoded.ok()) return encoded.error();

  Connection& conn = *conn_;
  const std::string operation =
      "store the run of part " + run.part + " lobe " + std::to_string(run.lobe) + " started " + run.started_utc;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  if (Status s = insert_settings(conn, run, *encoded, operation); !s.ok()) return s.error();
  Result<std::int64_t> run_id = insert_run_row(conn, run, *encoded, operation);
  if (!run_id.ok()) return run_id.error();
  if (run.geometry) {
    if (Status s = update_catalogue(conn, run, *run.geometry, operation); !s.ok()) return s.error();
  }
  if (Status s = insert_degree_rows(conn, *run_id, *encoded, operation); !s.ok()) return s.error();
  if (Status s = insert_characteristics(conn, *run_id, run, operation); !s.ok()) return s.error();
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return run_id;
}

// ---- reading runs ----

namespace {

RunSummary read_summary(const Statement& s) {
  RunSummary r;
  r.id = s.column<std::int64_t>(0);
  r.started_utc = s.column<std::string>(1);
  r.machine = s.column<std::string>(2);
  r.part = s.column<std::string>(3);
  r.lobe = s.column<int>(4);
  r.status = s.column<std::string>(5);
  r.revolutions = s.column<int>(6);
  r.degrees_captured = s.column<int>(7);
  r.max_abs_error_um = s.column<double>(8);
  r.rms_error_um = s.column<double>(9);
  r.repeatability_um = s.column<double>(10);
  r.nc_file = storage_internal::nc_path_column(s, 11);  // NULL reads as ""
  r.phase_error_deg = s.column<std::optional<double>>(12);
  r.base_circle_runout_um = s.column<std::optional<double>>(13);
  r.peak_to_valley_um = s.column<double>(14);
  r.settings_hash = s.column<std::string>(15);
  r.note = s.column<std::string>(16);
  r.raw_pruned_utc = s.column<std::string>(17);
  r.serial = s.column<std::string>(18);  // NULL reads as ""
  r.operator_name = s.column<std::string>(19);
  // NULL (before schema 8) reads as not judged.
  r.verdict = verdict_from_name(s.column<std::string>(kVerdictColumn)).value_or(Verdict::kNotJudged);
  r.uuid = s.column<std::string>(kUuidColumn);
  if (const std::optional<std::string> ref = s.column<std::optional<std::string>>(kReferenceColumn)) {
    r.lift_error_reference = *ref == "nominal" ? LiftErrorReference::kNominal : LiftErrorReference::kBestFit;
  }
  return r;
}

Characteristic read_characteristic(const Statement& s) {
  Characteristic c;
  c.key = s.column<std::string>(0);
  c.unit = s.column<std::string>(1);
  c.value = s.column<double>(2);
  c.min = s.column<double>(3);
  c.max = s.column<double>(4);
  c.limits.lower = s.column<std::optional<double>>(5);
  c.limits.upper = s.column<std::optional<double>>(6);
  c.verdict = verdict_from_name(s.column<std::string>(7)).value_or(Verdict::kNotJudged);
  c.from_deg = s.column<std::optional<int>>(8);
  c.to_deg = s.column<std::optional<int>>(9);
  return c;
}

Result<std::vector<Characteristic>> characteristics_of(Statement& q, std::int64_t run_id) {
  q.reset();
  q.bind(":run_id", run_id);
  return q.collect(read_characteristic);
}

std::string characteristics_sql() {
  return "SELECT " + std::string(kCharacteristicColumns) +
         " FROM run_characteristics WHERE run_id = :run_id ORDER BY position";
}

// The statements the readers of a run's parts use, each prepared once however many runs are
// read: reading runs one after another pays SQLite's parsing once, not per run.
class PartStatements {
 public:
  PartStatements(Connection& conn, std::string operation) : conn_(conn), operation_(std::move(operation)) {}

  Connection& conn() const { return conn_; }

  // `sql`, prepared on first use and reset since; its bindings are rebound by the caller.
  Result<Statement*> get(const std::string& sql) {
    auto it = prepared_.find(sql);
    if (it == prepared_.end()) {
      Result<Statement> st = Statement::prepare(conn_, sql, operation_);
      if (!st.ok()) return st.error();
      it = prepared_.emplace(sql, std::move(*st)).first;
    } else {
      it->second.reset();
    }
    return &it->second;
  }

 private:
  Connection& conn_;
  std::string operation_;
  std::map<std::string, Statement> prepared_;
};

// The runs row: the summary and the analysis's figures.
Status read_summary_of_run(PartStatements& st, std::int64_t run_id, StoredRun& out) {
  Result<Statement*> prepared = st.get(select_summaries(" WHERE r.id = :run_id"));
  if (!prepared.ok()) return prepared.error();
  Statement& q = **prepared;
  q.bind(":run_id", run_id);
  Result<bool> row = q.step();
  if (!row.ok()) return row.error();
  if (!*row) {
    return make_error(ErrorCode::kNotFound,
                      "run " + std::to_string(run_id) + " is not in run database " + st.conn().path.string());
  }
  out.summary = read_summary(q);
  out.note = out.summary.note;
  LobeAnalysis& a = out.analysis;
  a.zero_offset_mm = q.column<double>(kZeroOffsetColumn);
  a.max_abs_error_um = out.summary.max_abs_error_um;
  a.rms_error_um = out.summary.rms_error_um;
  a.peak_to_valley_um = out.summary.peak_to_valley_um;
  a.repeatability_um = out.summary.repeatability_um;
  a.phase_error_deg = out.summary.phase_error_deg.value_or(0.0);
  a.base_circle_runout_um = out.summary.base_circle_runout_um.value_or(0.0);
  return {};
}

// Columns 8..14 of kLoadDetails, when the run recorded its frame mapping.
Part read_geometry(const Statement& q, const RunSummary& summary) {
  Part g;
  g.name = summary.part;
  g.lobe = summary.lobe;
  g.rotation_sense = q.column<int>(8);
  g.c_offset_deg = q.column<double>(9);
  g.probe_offset_deg = q.column<double>(10);
  if (std::optional<FollowerKind> kind = follower_from_db(q.column<std::string>(11))) g.follower = *kind;
  g.follower_radius_mm = q.column<double>(12);
  g.base_circle_radius_mm = q.column<double>(13);
  g.wheel_radius_mm = q.column<double>(14);
  return g;
}

// The rest of the runs row, its settings text and its part's geometry.
Status read_details(PartStatements& st, std::int64_t run_id, StoredRun& out) {
  Result<Statement*> prepared = st.get(std::string(kLoadDetails));
  if (!prepared.ok()) return prepared.error();
  Statement& q = **prepared;
  q.bind(":run_id", run_id);
  Result<bool> row = q.step();
  if (!row.ok()) return row.error();
  if (!*row) return damaged_run(st.conn(), run_id, "its row vanished while it was read");
  out.finished_utc = q.column<std::string>(0);
  out.gauge = q.column<std::string>(1);
  out.polls = q.column<std::int64_t>(2);
  out.reconnects = q.column<std::int64_t>(3);
  out.discarded_revolutions = q.column<std::int64_t>(4);
  out.correction_in_force_run = q.column<std::optional<std::int64_t>>(5);
  out.settings = q.column<std::string>(6);
  // The text is stored under its hash: one changed outside SQLite no longer matches it.
  if (!out.settings.empty() && !out.summary.settings_hash.empty() &&
      settings_hash(out.settings) != out.summary.settings_hash) {
    return damaged_run(st.conn(), run_id,
                       "its settings text does not match the hash " + out.summary.settings_hash +
                           " it is stored under (a page changed outside SQLite)");
  }
  if (std::optional<std::string> json = q.column<std::optional<std::string>>(7)) {
    Result<std::vector<double>> h = storage_internal::numbers_from_json(*json);
    if (!h.ok() || h->size() != out.analysis.harmonic_amplitude_um.size()) {
      return damaged_run(st.conn(), run_id, "harmonic_amplitude_um is not a JSON array of 31 numbers");
    }
    for (std::size_t i = 0; i < h->size(); ++i) out.analysis.harmonic_amplitude_um[i] = (*h)[i];
  }
  if (!q.column_is_null(8)) out.geometry = read_geometry(q, out.summary);
  out.ground_with_version = q.column<std::optional<int>>(15);
  out.ground_with_source = q.column<std::string>(16);
  out.inspection = q.column<bool>(17);
  out.lift_error_reference =
      q.column<std::string>(18) == "nominal" ? LiftErrorReference::kNominal : LiftErrorReference::kBestFit;
  LobeAnalysis& a = out.analysis;
  a.max_abs_residual_um = q.column<std::optional<double>>(19).value_or(0.0);
  a.rms_residual_um = q.column<std::optional<double>>(20).value_or(0.0);
  a.peak_to_valley_residual_um = q.column<std::optional<double>>(21).value_or(0.0);
  a.dial_runout_um = q.column<std::optional<double>>(22).value_or(0.0);
  a.roundness_um = q.column<std::optional<double>>(23).value_or(0.0);
  out.harmonics_fed_back = q.column<std::optional<int>>(24);
  out.harmonic_threshold_um = q.column<std::optional<double>>(25);
  return {};
}

Status read_characteristics(PartStatements& st, std::int64_t run_id, StoredRun& out) {
  Result<Statement*> q = st.get(characteristics_sql());
  if (!q.ok()) return q.error();
  Result<std::vector<Characteristic>> c = characteristics_of(**q, run_id);
  if (!c.ok()) return c.error();
  out.characteristics = std::move(*c);
  return {};
}

}  // namespace

std::int64_t storage_internal::tables_checksum_of_row(const Statement& st, int first) {
  std::array<std::string, 5> blobs;
  for (int i = 0; i < 5; ++i) blobs[static_cast<std::size_t>(i)] = st.column_blob(first + i);
  const std::string residual = st.column_is_null(first + 5) ? std::string() : st.column_blob(first + 5);
  return tables_checksum({blobs[0], blobs[1], blobs[2], blobs[3], blobs[4]},
                         st.column_is_null(first + 5) ? std::nullopt : std::optional<std::string_view>(residual));
}

namespace {

constexpr const char* kChecksumMismatch =
    "its stored per-degree numbers do not match the checksum kept with them: a page of the file was changed "
    "outside SQLite (a failing disk, a bad copy), so it is not used as the base of a correction";

// The raw revolutions, unless prune_raw_samples removed them.
Status read_raw(PartStatements& st, std::int64_t run_id, StoredRun& out) {
  Result<Statement*> prepared =
      st.get("SELECT amplifier_revolutions, lift, checksum FROM run_raw WHERE run_id = :run_id");
  if (!prepared.ok()) return prepared.error();
  Statement& q = **prepared;
  q.bind(":run_id", run_id);
  Result<bool> row = q.step();
  if (!row.ok()) return row.error();
  if (!*row) {
    if (out.summary.raw_pruned_utc.empty()) {
      return damaged_run(st.conn(), run_id, "its raw revolutions are missing but it was never pruned");
    }
    return {};
  }
  const std::string amplifier = q.column<std::string>(0);
  const std::string lift = q.column_blob(1);
  if (!q.column_is_null(2) && q.column<std::int64_t>(2) != storage_internal::raw_checksum(amplifier, lift)) {
    return damaged_run(st.conn(), run_id, kChecksumMismatch + std::string(" (its raw revolutions, run_raw)"));
  }
  Result<std::vector<double>> counts = storage_internal::numbers_from_json(amplifier);
  if (!counts.ok()) return damaged_run(st.conn(), run_id, "amplifier_revolutions: " + counts.error().message);
  if (lift.size() != counts->size() * storage_internal::kDegreeBlobBytes) {
    return damaged_run(st.conn(), run_id,
                       "the raw lift BLOB holds " + std::to_string(lift.size()) + " bytes for " +
                           std::to_string(counts->size()) + " revolutions");
  }
  for (std::size_t i = 0; i < counts->size(); ++i) {
    Result<DegreeTable> t =
        storage_internal::read_degree_blob(lift, i * storage_internal::kDegreeBlobBytes, kCountsPerMm);
    if (!t.ok()) return damaged_run(st.conn(), run_id, t.error().message);
    out.revolutions.push_back(RevolutionSamples{static_cast<std::int64_t>((*counts)[i]), *t});
  }
  if (out.revolutions.size() != static_cast<std::size_t>(out.summary.revolutions)) {
    return damaged_run(st.conn(), run_id,
                       "it lists " + std::to_string(out.summary.revolutions) + " revolutions but holds " +
                           std::to_string(out.revolutions.size()));
  }
  return {};
}

// The per-degree profile and correction (cam frame).
Status read_profile(PartStatements& st, std::int64_t run_id, StoredRun& out) {
  Result<Statement*> prepared = st.get(
      "SELECT design_lift, mean_lift, spread, error, correction, residual_error, checksum FROM run_tables WHERE "
      "run_id = :run_id");
  if (!prepared.ok()) return prepared.error();
  Statement& q = **prepared;
  q.bind(":run_id", run_id);
  Result<bool> row = q.step();
  if (!row.ok()) return row.error();
  if (!*row) return damaged_run(st.conn(), run_id, "its profile (run_tables) is missing");
  if (!q.column_is_null(6)) {
    if (q.column<std::int64_t>(6) != storage_internal::tables_checksum_of_row(q, 0)) {
      return damaged_run(st.conn(), run_id,
                         kChecksumMismatch + std::string(" (its profile and correction, run_tables)"));
    }
  }
  const std::array<std::pair<DegreeTable*, double>, 5> tables = {{
      {&out.analysis.design_lift_mm, kCountsPerMm},
      {&out.analysis.mean_lift_mm, kCountsPerMm},
      {&out.analysis.spread_um, kCountsPerUm},
      {&out.analysis.error_um, kCountsPerUm},
      {&out.correction_um, kCountsPerUm},
  }};
  for (std::size_t i = 0; i < tables.size(); ++i) {
    Result<DegreeTable> t = storage_internal::read_degree_blob(q.column_blob(static_cast<int>(i)), 0, tables[i].second);
    if (!t.ok())
      return damaged_run(st.conn(), run_id, "profile column " + std::to_string(i) + ": " + t.error().message);
    *tables[i].first = *t;
  }
  // Runs stored before schema 8 have no residual: it stays 0.
  if (!q.column_is_null(5)) {
    Result<DegreeTable> t = storage_internal::read_degree_blob(q.column_blob(5), 0, kCountsPerUm);
    if (!t.ok()) return damaged_run(st.conn(), run_id, "residual_error: " + t.error().message);
    out.analysis.residual_error_um = *t;
  }
  return {};
}

Status read_pushes_of(PartStatements& st, std::int64_t run_id, StoredRun& out) {
  Result<Statement*> prepared = st.get("SELECT " + std::string(storage_internal::kPushColumns) +
                                       " FROM nc_pushes AS p WHERE p.run_id = :run_id ORDER BY p.id");
  if (!prepared.ok()) return prepared.error();
  Statement& q = **prepared;
  q.bind(":run_id", run_id);
  Result<std::vector<NcPush>> pushes =
      q.collect([](const Statement& s) { return storage_internal::read_push(s, false); });
  if (!pushes.ok()) return pushes.error();
  out.pushes = std::move(*pushes);
  return {};
}

}  // namespace

namespace {

using RunPartReader = Status (*)(PartStatements&, std::int64_t, StoredRun&);

// The parts of the runs that `ids` names (read in the same snapshot) that `readers` read: one
// read transaction, so a concurrent writer cannot split a run.
template <typename ReadIds>
Result<std::vector<StoredRun>> load_parts(Connection& conn, const std::string& operation, ReadIds read_ids,
                                          std::initializer_list<RunPartReader> readers) {
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();
  Result<std::vector<std::int64_t>> ids = read_ids();
  if (!ids.ok()) return ids.error();
  PartStatements statements(conn, operation);
  std::vector<StoredRun> out(ids->size());
  for (std::size_t i = 0; i < ids->size(); ++i) {
    for (RunPartReader read : readers) {
      if (Status s = read(statements, (*ids)[i], out[i]); !s.ok()) return s.error();
    }
  }
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return out;
}

Result<StoredRun> load_one(Connection& conn, std::int64_t run_id, std::initializer_list<RunPartReader> readers) {
  Result<std::vector<StoredRun>> runs = load_parts(
      conn, "load run " + std::to_string(run_id),
      [run_id]() -> Result<std::vector<std::int64_t>> { return std::vector<std::int64_t>{run_id}; }, readers);
  if (!runs.ok()) return runs.error();
  return std::move(runs->front());
}

}  // namespace

Result<StoredRun> RunStore::load_run(std::int64_t run_id) const {
  return load_one(*conn_, run_id,
                  {read_summary_of_run, read_details, read_raw, read_profile, read_pushes_of, read_characteristics});
}

Result<StoredRun> RunStore::load_run_record(std::int64_t run_id) const {
  return load_one(*conn_, run_id, {read_summary_of_run, read_details, read_characteristics});
}

Result<std::vector<StoredRun>> RunStore::run_records_after(std::int64_t after_id, int limit, bool per_degree) const {
  auto ids = [&] { return run_ids_after(after_id, limit); };
  if (per_degree) {
    return load_parts(*conn_, "read runs to replicate", ids,
                      {read_summary_of_run, read_details, read_characteristics, read_raw, read_profile});
  }
  return load_parts(*conn_, "read runs to replicate", ids, {read_summary_of_run, read_details, read_characteristics});
}

Status check_run_query(const RunQuery& q) {
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
  if (q.ground_with_from < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list runs: table version " + std::to_string(q.ground_with_from) + " is negative");
  }
  if (!storage_internal::is_time_bound(q.since_utc)) {
    return storage_internal::bad_bound("cannot list runs: since", q.since_utc);
  }
  if (!storage_internal::is_time_bound(q.until_utc)) {
    return storage_internal::bad_bound("cannot list runs: until", q.until_utc);
  }
  return {};
}

namespace {

// Validates the query and makes its WHERE clause.
Result<storage_internal::WhereClause> run_filter(const RunQuery& q) {
  if (Status valid = check_run_query(q); !valid.ok()) return valid.error();
  storage_internal::WhereClause where;
  if (!q.part.empty()) where.add("r.part =", q.part);
  if (q.lobe > 0) where.add_literal("r.lobe = " + std::to_string(q.lobe));
  if (!q.machine.empty()) where.add("r.machine =", q.machine);
  if (!q.serial.empty()) where.add("r.serial =", q.serial);
  // Every run has a verdict from schema 11 (the older ones `not_judged`): one comparison, which
  // runs_by_verdict serves with the sort.
  if (q.verdict) where.add("r.verdict =", std::string(verdict_name(*q.verdict)));
  if (!q.status.empty()) where.add("r.status =", q.status);
  if (q.ground_with_from > 0) where.add_literal("r.ground_with_version >= " + std::to_string(q.ground_with_from));
  if (!q.since_utc.empty()) where.add("r.started_utc >=", q.since_utc);
  if (!q.until_utc.empty()) where.add("r.started_utc <", q.until_utc);
  return where;
}

Result<std::vector<RunSummary>> query_runs(Connection& conn, const RunQuery& q, bool oldest_first) {
  Result<storage_internal::WhereClause> where = run_filter(q);
  if (!where.ok()) return where.error();
  // Newest `limit` runs first; the trend wants them back in time order.
  std::string sql = select_summaries(where->sql() + " ORDER BY r.started_utc DESC, r.id DESC LIMIT :limit");
  if (oldest_first) {
    sql = "SELECT * FROM (" + sql + ") ORDER BY started_utc, id";
  }
  Result<Statement> list = Statement::prepare(conn, sql, "list runs");
  if (!list.ok()) return list.error();
  list->bind(":limit", q.limit);
  where->bind(*list);
  return list->collect(read_summary);
}

}  // namespace

Result<std::vector<RunSummary>> RunStore::list_runs(const RunQuery& q) const { return query_runs(*conn_, q, false); }

Result<std::vector<RunSummary>> RunStore::trend(const RunQuery& q) const { return query_runs(*conn_, q, true); }

namespace {

// The runs a query selects (`chosen`: id, started_utc), newest first, as a WITH clause.
std::string chosen_runs(const storage_internal::WhereClause& where) {
  return "WITH chosen AS (SELECT r.id, r.started_utc FROM runs AS r" + where.sql() +
         " ORDER BY r.started_utc DESC, r.id DESC LIMIT :limit)";
}

}  // namespace

Result<std::vector<RunCharacteristics>> RunStore::characteristics(const RunQuery& q, const std::string& key) const {
  Connection& conn = *conn_;
  const std::string operation = "read the characteristics of the runs";
  Result<storage_internal::WhereClause> where = run_filter(q);
  if (!where.ok()) return where.error();
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();
  Result<std::vector<RunSummary>> runs = query_runs(conn, q, true);
  if (!runs) return runs.error();
  // Every run's characteristics in one statement, its run's id last (read_characteristic reads
  // the first columns), in the runs' order: a statement per run cost 5 ms for 200 runs.
  Result<Statement> rows =
      Statement::prepare(conn,
                         chosen_runs(*where) + " SELECT " + std::string(kCharacteristicColumns) +
                             ", w.id FROM chosen AS w JOIN run_characteristics AS c ON c.run_id = w.id" +
                             (key.empty() ? "" : " AND c.key = :key") + " ORDER BY w.started_utc, w.id, c.position",
                         operation);
  if (!rows.ok()) return rows.error();
  rows->bind(":limit", q.limit);
  if (!key.empty()) rows->bind(":key", key);
  where->bind(*rows);
  std::vector<RunCharacteristics> out;
  out.reserve(runs->size());
  std::map<std::int64_t, std::size_t> index_of;
  for (RunSummary& r : *runs) {
    index_of.emplace(r.id, out.size());
    out.push_back({std::move(r), {}});
  }
  constexpr int kIdColumn = static_cast<int>(std::ranges::count(kCharacteristicColumns, ',')) + 1;
  for (;;) {
    Result<bool> row = rows->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    auto at = index_of.find(rows->column<std::int64_t>(kIdColumn));
    if (at != index_of.end()) out[at->second].characteristics.push_back(read_characteristic(*rows));
  }
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return out;
}

namespace {

// The characteristics of the runs a query selects (chosen: id, started_utc, newest first),
// oldest run first, each run's by position: one statement, summed up in C++ as they come. SQL
// aggregates over the same rows (a GROUP BY key for the counts and the mean, a second pass for
// the squared deviations and the newest run's limits) measured three times slower in SQLite
// than this (docs/PERFORMANCE.md), so the file sums up here and the central history in
// PostgreSQL, where the rows would otherwise cross the network.
constexpr std::string_view kWindowCharacteristicsSql = R"sql(
SELECT w.id, c.key, c.unit, c.value, c.lower_limit, c.upper_limit, c.verdict
FROM chosen AS w JOIN run_characteristics AS c ON c.run_id = w.id
ORDER BY w.started_utc, w.id, c.position)sql";

}  // namespace

Result<CharacteristicSummaries> RunStore::characteristic_summaries(const RunQuery& q) const {
  Connection& conn = *conn_;
  const std::string operation = "sum up the characteristics of the runs";
  Result<storage_internal::WhereClause> where = run_filter(q);
  if (!where.ok()) return where.error();
  const std::string chosen = chosen_runs(*where);
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();
  CharacteristicSummaries out;
  {
    Result<Statement> runs = Statement::prepare(
        conn, chosen + " SELECT count(*), min(started_utc), max(started_utc) FROM chosen", operation);
    if (!runs.ok()) return runs.error();
    runs->bind(":limit", q.limit);
    where->bind(*runs);
    Result<std::optional<int>> n = runs->first([&out](const Statement& st) {
      out.first_started_utc = st.column<std::optional<std::string>>(1).value_or("");
      out.last_started_utc = st.column<std::optional<std::string>>(2).value_or("");
      return st.column<int>(0);
    });
    if (!n.ok()) return n.error();
    out.runs = n->value_or(0);
  }
  Result<Statement> rows = Statement::prepare(conn, chosen + std::string(kWindowCharacteristicsSql), operation);
  if (!rows.ok()) return rows.error();
  rows->bind(":limit", q.limit);
  where->bind(*rows);
  CharacteristicSummer summer;
  Characteristic c;
  for (;;) {
    Result<bool> row = rows->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    c.key = rows->column<std::string>(1);
    c.unit = rows->column<std::string>(2);
    c.value = rows->column<double>(3);
    c.limits.lower = rows->column<std::optional<double>>(4);
    c.limits.upper = rows->column<std::optional<double>>(5);
    c.verdict = verdict_from_name(rows->column<std::string>(6)).value_or(Verdict::kNotJudged);
    summer.add(rows->column<std::int64_t>(0), c);
  }
  CharacteristicSummaries summed = summer.finish(out.runs, out.first_started_utc, out.last_started_utc);
  out = std::move(summed);
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return out;
}

Result<std::optional<std::int64_t>> RunStore::last_pushed_run(const std::string& machine, const std::string& part,
                                                              int lobe) const {
  Result<Statement> q = Statement::prepare(*conn_,
                                           "SELECT p.run_id FROM nc_pushes AS p JOIN runs AS r ON r.id = p.run_id"
                                           " WHERE r.machine = :machine AND r.part = :part AND r.lobe = :lobe"
                                           " ORDER BY p.id DESC LIMIT 1",
                                           "find the table in force");
  if (!q.ok()) return q.error();
  q->bind(":machine", machine);
  q->bind(":part", part);
  q->bind(":lobe", static_cast<std::int64_t>(lobe));
  return q->first([](const Statement& s) { return s.column<std::int64_t>(0); });
}

Result<std::int64_t> RunStore::prune_raw_samples(const std::string& cutoff_utc, const std::string& now_utc) {
  if (!is_utc_timestamp(cutoff_utc)) return storage_internal::bad_bound("cannot prune raw samples: cutoff", cutoff_utc);
  if (!is_utc_timestamp(now_utc)) return storage_internal::bad_bound("cannot prune raw samples: now", now_utc);
  Connection& conn = *conn_;
  const std::string operation = "prune the raw samples of runs started before " + cutoff_utc;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> mark = Statement::prepare(conn,
                                              "UPDATE runs SET raw_pruned_utc = :now WHERE started_utc < :cutoff"
                                              " AND id IN (SELECT run_id FROM run_raw)",
                                              operation);
  if (!mark.ok()) return mark.error();
  mark->bind(":cutoff", cutoff_utc);
  mark->bind(":now", now_utc);
  if (Status s = mark->run(); !s.ok()) return s.error();
  const std::int64_t pruned = conn.changes();
  Result<Statement> del = Statement::prepare(
      conn, "DELETE FROM run_raw WHERE run_id IN (SELECT id FROM runs WHERE started_utc < :cutoff)", operation);
  if (!del.ok()) return del.error();
  del->bind(":cutoff", cutoff_utc);
  if (Status s = del->run(); !s.ok()) return s.error();
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return pruned;
}

}  // namespace gaugeloop
