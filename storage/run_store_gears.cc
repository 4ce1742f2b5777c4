// RunStore's gear runs (schema 12; profiles from schema 21): a gear checker's lead and profile
// traces and what ISO 1328-1 makes of them, with ids of their own.
#include <cmath>
#include <cstdint>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "storage/degree_json.h"
#include "storage/record_checks.h"
#include "storage/run_store.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::Connection;
using storage_internal::Statement;
using storage_internal::text_or_null;
using storage_internal::Transaction;

namespace {

Error gear_run_refused(const std::string& why) {
  return make_error(ErrorCode::kInvalidInput, "gear run not stored: " + why);
}

Status check_finite(double value, const std::string& what) {
  if (std::isfinite(value)) return {};
  return gear_run_refused(what + " is " + storage_internal::describe_non_finite(value));
}

// What a flank line is called in a refusal: a lead trace's words or a profile's.
struct FlankLineWords {
  const char* what;       // "trace", "profile"
  const char* positions;  // "positions", "roll lengths"
  const char* position;
  const char* total;  // F_beta, F_alpha
  const char* form;
  const char* slope;
};
constexpr FlankLineWords kLeadWords{"trace", "positions", "position", "F_beta", "f_f_beta", "f_H_beta"};
constexpr FlankLineWords kProfileWords{"profile", "roll lengths", "roll length", "F_alpha", "f_f_alpha", "f_H_alpha"};

// A lead trace's or a profile's record: its gap, flank and class, as many positions as
// deviations (3 or more), every number finite.
template <typename Line>
Status check_flank_line(const Line& t, double from, double to, const std::vector<double>& at, const FlankLineWords& w) {
  const std::string what = w.what;
  const std::string where = "the " + what + " of gap " + std::to_string(t.gap) + ", " + t.flank + " flank";
  if (t.gap < 1) return gear_run_refused("a " + what + "'s gap is " + std::to_string(t.gap) + "; gaps count from 1");
  if (t.flank != "left" && t.flank != "right") {
    return gear_run_refused("a " + what + "'s flank is '" + t.flank + "', not left or right");
  }
  if (t.tolerance_class < 1 || t.tolerance_class > 12) {
    return gear_run_refused(where + " has tolerance class " + std::to_string(t.tolerance_class) + ", not 1 to 12");
  }
  if (at.size() < 3 || at.size() != t.deviation_um.size()) {
    return gear_run_refused(where + " has " + std::to_string(at.size()) + " " + w.positions + " and " +
                            std::to_string(t.deviation_um.size()) + " deviations; it needs 3 or more of each, as many");
  }
  for (const auto& [value, name] :
       {std::pair{t.total_um, w.total}, std::pair{t.form_um, w.form}, std::pair{t.slope_um, w.slope},
        std::pair{from, "its range's start"}, std::pair{to, "its range's end"}}) {
    if (Status s = check_finite(value, where + "'s " + name); !s.ok()) return s;
  }
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (Status s = check_finite(at[i], where + "'s " + w.position + " " + std::to_string(i + 1)); !s.ok()) return s;
    if (Status s = check_finite(t.deviation_um[i], where + "'s deviation " + std::to_string(i + 1)); !s.ok()) return s;
  }
  return {};
}

Status check_gear_run(const GearRunRecord& r) {
  if (!storage_internal::is_time_bound(r.started_utc) || r.started_utc.empty()) {
    return storage_internal::bad_bound("gear run not stored: started", r.started_utc);
  }
  if (r.machine.empty() || r.part.empty() || r.source.empty() || r.nc_file.empty()) {
    return gear_run_refused("the machine, the part, the source and the stroke program's file must be named");
  }
  if (r.serial.size() > 64 || r.operator_name.size() > 64) {
    return gear_run_refused("the serial and the operator are at most 64 characters");
  }
  if (r.traces.empty()) return gear_run_refused("no lead trace");
  if (r.required_class && (*r.required_class < 1 || *r.required_class > 11)) {
    return gear_run_refused("the required class is " + std::to_string(*r.required_class) + ", not 1 to 11");
  }
  if (r.required_class.has_value() != r.total_tolerance_um.has_value() ||
      (r.total_tolerance_um && !(*r.total_tolerance_um > 0.0 && std::isfinite(*r.total_tolerance_um)))) {
    return gear_run_refused("a required class comes with its F_beta tolerance, finite and above 0");
  }
  if (r.required_class.has_value() == (r.verdict == Verdict::kNotJudged)) {
    return gear_run_refused("a gear is judged (in or out) exactly when the part names its tolerance class");
  }
  if (r.tolerance_class < 1 || r.tolerance_class > 12) {
    return gear_run_refused("the tolerance class is " + std::to_string(r.tolerance_class) + ", not 1 to 12");
  }
  for (const auto& [value, name] :
       {std::pair{r.total_max_um, "F_beta's maximum"}, std::pair{r.total_mean_um, "F_beta's mean"},
        std::pair{r.form_mean_um, "f_f_beta's mean"}, std::pair{r.slope_mean_abs_um, "|f_H_beta|'s mean"}}) {
    if (Status s = check_finite(value, name); !s.ok()) return s;
  }
  std::set<std::pair<int, std::string>> seen;
  for (const GearTraceRecord& t : r.traces) {
    if (Status s = check_flank_line(t, t.from_mm, t.to_mm, t.z_mm, kLeadWords); !s.ok()) return s;
    if (!seen.insert({t.gap, t.flank}).second) {
      return gear_run_refused("two traces of gap " + std::to_string(t.gap) + ", " + t.flank + " flank");
    }
  }
  if (r.profile_tolerance_um.has_value() != (r.required_class.has_value() && !r.profiles.empty()) ||
      (r.profile_tolerance_um && !(*r.profile_tolerance_um > 0.0 && std::isfinite(*r.profile_tolerance_um)))) {
    return gear_run_refused(
        "a gear judged with profiles comes with its F_alpha tolerance, finite and above 0, and only then");
  }
  seen.clear();
  for (const GearProfileRecord& p : r.profiles) {
    if (Status s = check_flank_line(p, p.from_roll_mm, p.to_roll_mm, p.roll_mm, kProfileWords); !s.ok()) return s;
    if (!seen.insert({p.gap, p.flank}).second) {
      return gear_run_refused("two profiles of gap " + std::to_string(p.gap) + ", " + p.flank + " flank");
    }
  }
  return {};
}

constexpr std::string_view kInsertGearRun = R"sql(
INSERT INTO gear_runs (started_utc, machine, part, source, serial, operator, note, nc_file, ground_with_version,
                       required_class, total_tolerance_um, verdict, tolerance_class, total_max_um, total_mean_um,
                       form_mean_um, slope_mean_abs_um, profile_tolerance_um)
VALUES (:started_utc, :machine, :part, :source, :serial, :operator, :note, :nc_file, :ground_with_version,
        :required_class, :total_tolerance_um, :verdict, :tolerance_class, :total_max_um, :total_mean_um, :form_mean_um,
        :slope_mean_abs_um, :profile_tolerance_um)
)sql";

constexpr std::string_view kInsertGearProfile = R"sql(
INSERT INTO gear_run_profiles (run_id, gap, flank, total_um, form_um, slope_um, tolerance_class, from_roll_mm,
                               to_roll_mm, roll_mm, deviation_um)
VALUES (:run_id, :gap, :flank, :total_um, :form_um, :slope_um, :tolerance_class, :from_roll_mm, :to_roll_mm,
        :roll_mm, :deviation_um)
)sql";

constexpr std::string_view kInsertGearTrace = R"sql(
INSERT INTO gear_run_traces (run_id, gap, flank, total_um, form_um, slope_um, tolerance_class, from_mm, to_mm,
                             z_mm, deviation_um)
VALUES (:run_id, :gap, :flank, :total_um, :form_um, :slope_um, :tolerance_class, :from_mm, :to_mm, :z_mm,
        :deviation_um)
)sql";

// Columns 0..20 of gear_runs AS g, read by read_gear_run.
constexpr std::string_view kGearRunColumns =
    "g.id, g.started_utc, g.machine, g.part, g.source, g.serial, g.operator, g.note, g.nc_file, "
    "g.ground_with_version, g.required_class, g.verdict, g.tolerance_class, g.total_max_um, g.total_mean_um, "
    "g.form_mean_um, g.slope_mean_abs_um, g.pushed_version, g.mesh_residual_rms_um, g.total_tolerance_um, "
    "g.profile_tolerance_um";

StoredGearRun read_gear_run(const Statement& s) {
  StoredGearRun g;
  g.id = s.column<std::int64_t>(0);
  GearRunRecord& r = g.record;
  r.started_utc = s.column<std::string>(1);
  r.machine = s.column<std::string>(2);
  r.part = s.column<std::string>(3);
  r.source = s.column<std::string>(4);
  r.serial = s.column<std::optional<std::string>>(5).value_or("");
  r.operator_name = s.column<std::optional<std::string>>(6).value_or("");
  r.note = s.column<std::string>(7);
  r.nc_file = storage_internal::nc_path_column(s, 8);
  r.ground_with_version = s.column<std::optional<int>>(9);
  r.required_class = s.column<std::optional<int>>(10);
  r.verdict = verdict_from_name(s.column<std::string>(11)).value_or(Verdict::kNotJudged);
  r.tolerance_class = s.column<int>(12);
  r.total_max_um = s.column<double>(13);
  r.total_mean_um = s.column<double>(14);
  r.form_mean_um = s.column<double>(15);
  r.slope_mean_abs_um = s.column<double>(16);
  g.pushed_version = s.column<std::optional<int>>(17);
  g.mesh_residual_rms_um = s.column<std::optional<double>>(18);
  r.total_tolerance_um = s.column<std::optional<double>>(19);
  r.profile_tolerance_um = s.column<std::optional<double>>(20);
  return g;
}

// A stored trace's positions (column `first`, named `positions_name`) and deviations (the
// column after it), read back from their JSON arrays; kStorage naming `what` if they do not.
struct TraceNumbers {
  std::vector<double> positions;
  std::vector<double> deviation_um;
};

Result<TraceNumbers> trace_numbers(const Statement& s, int first, const std::string& positions_name,
                                   const std::string& what, const Connection& conn, const std::string& operation) {
  Result<std::vector<double>> at = storage_internal::numbers_from_json(s.column<std::string>(first));
  Result<std::vector<double>> d = storage_internal::numbers_from_json(s.column<std::string>(first + 1));
  if (!at.ok() || !d.ok() || at->size() != d->size()) {
    return make_error(ErrorCode::kStorage, "cannot " + operation + ": " + what + " in " + conn.path.string() +
                                               " does not read back (" +
                                               (!at.ok()  ? positions_name + ": " + at.error().message
                                                : !d.ok() ? "deviation_um: " + d.error().message
                                                          : std::string("positions and deviations differ in number")) +
                                               "); restore a backup");
  }
  return TraceNumbers{std::move(*at), std::move(*d)};
}

Error gear_run_not_found(const Connection& conn, std::int64_t id, const std::string& operation) {
  return make_error(ErrorCode::kNotFound, "cannot " + operation + ": gear run " + std::to_string(id) +
                                              " is not in run database " + conn.path.string() +
                                              " (`gaugeloop gear runs list` lists them)");
}

}  // namespace

Result<std::int64_t> RunStore::insert_gear_run(const GearRunRecord& run) {
  if (Status valid = check_gear_run(run); !valid.ok()) return valid.error();
  Connection& conn = *conn_;
  const std::string operation = "store the gear run of part " + run.part + " started " + run.started_utc;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  if (Status s = storage_internal::note_nc_directory(conn, run.nc_file, operation); !s.ok()) return s.error();
  Result<Statement> ins = Statement::prepare(conn, kInsertGearRun, operation);
  if (!ins.ok()) return ins.error();
  ins->bind(":started_utc", run.started_utc);
  ins->bind(":machine", run.machine);
  ins->bind(":part", run.part);
  ins->bind(":source", run.source);
  ins->bind(":serial", text_or_null(run.serial));
  ins->bind(":operator", text_or_null(run.operator_name));
  ins->bind(":note", run.note);
  ins->bind(":nc_file", storage_internal::nc_key(conn, run.nc_file));
  ins->bind(":ground_with_version", run.ground_with_version);
  ins->bind(":required_class", run.required_class);
  ins->bind(":total_tolerance_um", run.total_tolerance_um);
  ins->bind(":verdict", verdict_name(run.verdict));
  ins->bind(":tolerance_class", run.tolerance_class);
  ins->bind(":total_max_um", run.total_max_um);
  ins->bind(":total_mean_um", run.total_mean_um);
  ins->bind(":form_mean_um", run.form_mean_um);
  ins->bind(":slope_mean_abs_um", run.slope_mean_abs_um);
  ins->bind(":profile_tolerance_um", run.profile_tolerance_um);
  if (Status s = ins->run(); !s.ok()) return s.error();
  const std::int64_t id = conn.last_insert_rowid();
  Result<Statement> trace = Statement::prepare(conn, kInsertGearTrace, operation);
  if (!trace.ok()) return trace.error();
  for (const GearTraceRecord& t : run.traces) {
    trace->reset();
    trace->bind(":run_id", id);
    trace->bind(":gap", t.gap);
    trace->bind(":flank", t.flank);
    trace->bind(":total_um", t.total_um);
    trace->bind(":form_um", t.form_um);
    trace->bind(":slope_um", t.slope_um);
    trace->bind(":tolerance_class", t.tolerance_class);
    trace->bind(":from_mm", t.from_mm);
    trace->bind(":to_mm", t.to_mm);
    trace->bind(":z_mm", storage_internal::numbers_to_json(t.z_mm));
    trace->bind(":deviation_um", storage_internal::numbers_to_json(t.deviation_um));
    if (Status s = trace->run(); !s.ok()) return s.error();
  }
  if (!run.profiles.empty()) {
    Result<Statement> profile = Statement::prepare(conn, kInsertGearProfile, operation);
    if (!profile.ok()) return profile.error();
    for (const GearProfileRecord& p : run.profiles) {
      profile->reset();
      profile->bind(":run_id", id);
      profile->bind(":gap", p.gap);
      profile->bind(":flank", p.flank);
      profile->bind(":total_um", p.total_um);
      profile->bind(":form_um", p.form_um);
      profile->bind(":slope_um", p.slope_um);
      profile->bind(":tolerance_class", p.tolerance_class);
      profile->bind(":from_roll_mm", p.from_roll_mm);
      profile->bind(":to_roll_mm", p.to_roll_mm);
      profile->bind(":roll_mm", storage_internal::numbers_to_json(p.roll_mm));
      profile->bind(":deviation_um", storage_internal::numbers_to_json(p.deviation_um));
      if (Status s = profile->run(); !s.ok()) return s.error();
    }
  }
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return id;
}

Status RunStore::record_gear_correction(std::int64_t id, double mesh_residual_rms_um,
                                        std::optional<int> stroke_version) {
  Connection& conn = *conn_;
  const std::string operation = "record the correction made from gear run " + std::to_string(id);
  if ((stroke_version && *stroke_version < 1) || !std::isfinite(mesh_residual_rms_um)) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot " + operation + ": the version must be 1 or more and the residual finite");
  }
  Result<Statement> up = Statement::prepare(
      conn,
      "UPDATE gear_runs SET mesh_residual_rms_um = :residual, pushed_version = coalesce(:version, pushed_version) "
      "WHERE id = :id",
      operation);
  if (!up.ok()) return up.error();
  up->bind(":version", stroke_version);
  up->bind(":residual", mesh_residual_rms_um);
  up->bind(":id", id);
  if (Status s = up->run(); !s.ok()) return s;
  if (conn.changes() == 0) return gear_run_not_found(conn, id, operation);
  return {};
}

Result<std::vector<StoredGearRun>> RunStore::list_gear_runs(const GearRunQuery& q) const {
  RunQuery as_runs;
  as_runs.limit = q.limit;
  as_runs.since_utc = q.since_utc;
  as_runs.until_utc = q.until_utc;
  if (Status valid = check_run_query(as_runs); !valid.ok()) return valid.error();
  storage_internal::WhereClause where;
  if (!q.part.empty()) where.add("g.part =", q.part);
  if (!q.machine.empty()) where.add("g.machine =", q.machine);
  if (!q.serial.empty()) where.add("g.serial =", q.serial);
  if (q.verdict) where.add("g.verdict =", std::string(verdict_name(*q.verdict)));
  if (!q.since_utc.empty()) where.add("g.started_utc >=", q.since_utc);
  if (!q.until_utc.empty()) where.add("g.started_utc <", q.until_utc);
  Connection& conn = *conn_;
  Result<Statement> list = Statement::prepare(conn,
                                              "SELECT " + std::string(kGearRunColumns) + " FROM gear_runs AS g" +
                                                  where.sql() + " ORDER BY g.started_utc DESC, g.id DESC LIMIT :limit",
                                              "list gear runs");
  if (!list.ok()) return list.error();
  where.bind(*list);
  list->bind(":limit", q.limit);
  std::vector<StoredGearRun> out;
  for (;;) {
    Result<bool> row = list->step();
    if (!row.ok()) return row.error();
    if (!*row) return out;
    out.push_back(read_gear_run(*list));
  }
}

Result<StoredGearRun> RunStore::load_gear_run(std::int64_t id) const {
  Connection& conn = *conn_;
  const std::string operation = "read gear run " + std::to_string(id);
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> one = Statement::prepare(
      conn, "SELECT " + std::string(kGearRunColumns) + " FROM gear_runs AS g WHERE g.id = :id", operation);
  if (!one.ok()) return one.error();
  one->bind(":id", id);
  Result<bool> row = one->step();
  if (!row.ok()) return row.error();
  if (!*row) return gear_run_not_found(conn, id, operation);
  StoredGearRun g = read_gear_run(*one);
  Result<Statement> traces = Statement::prepare(conn,
                                                "SELECT gap, flank, total_um, form_um, slope_um, tolerance_class, "
                                                "from_mm, to_mm, z_mm, deviation_um FROM gear_run_traces "
                                                "WHERE run_id = :id ORDER BY gap, flank",
                                                operation);
  if (!traces.ok()) return traces.error();
  traces->bind(":id", id);
  for (;;) {
    Result<bool> t = traces->step();
    if (!t.ok()) return t.error();
    if (!*t) break;
    GearTraceRecord r;
    r.gap = traces->column<int>(0);
    r.flank = traces->column<std::string>(1);
    r.total_um = traces->column<double>(2);
    r.form_um = traces->column<double>(3);
    r.slope_um = traces->column<double>(4);
    r.tolerance_class = traces->column<int>(5);
    r.from_mm = traces->column<double>(6);
    r.to_mm = traces->column<double>(7);
    Result<TraceNumbers> numbers = trace_numbers(
        *traces, 8, "z_mm", "the trace of gap " + std::to_string(r.gap) + ", " + r.flank + " flank", conn, operation);
    if (!numbers.ok()) return numbers.error();
    r.z_mm = std::move(numbers->positions);
    r.deviation_um = std::move(numbers->deviation_um);
    g.record.traces.push_back(std::move(r));
  }
  if (g.record.traces.empty()) {
    return make_error(ErrorCode::kStorage,
                      "cannot " + operation + ": it has no lead trace in " + conn.path.string() + "; restore a backup");
  }
  Result<Statement> profiles = Statement::prepare(conn,
                                                  "SELECT gap, flank, total_um, form_um, slope_um, tolerance_class, "
                                                  "from_roll_mm, to_roll_mm, roll_mm, deviation_um "
                                                  "FROM gear_run_profiles WHERE run_id = :id ORDER BY gap, flank",
                                                  operation);
  if (!profiles.ok()) return profiles.error();
  profiles->bind(":id", id);
  for (;;) {
    Result<bool> t = profiles->step();
    if (!t.ok()) return t.error();
    if (!*t) break;
    GearProfileRecord p;
    p.gap = profiles->column<int>(0);
    p.flank = profiles->column<std::string>(1);
    p.total_um = profiles->column<double>(2);
    p.form_um = profiles->column<double>(3);
    p.slope_um = profiles->column<double>(4);
    p.tolerance_class = profiles->column<int>(5);
    p.from_roll_mm = profiles->column<double>(6);
    p.to_roll_mm = profiles->column<double>(7);
    Result<TraceNumbers> numbers =
        trace_numbers(*profiles, 8, "roll_mm",
                      "the profile of gap " + std::to_string(p.gap) + ", " + p.flank + " flank", conn, operation);
    if (!numbers.ok()) return numbers.error();
    p.roll_mm = std::move(numbers->positions);
    p.deviation_um = std::move(numbers->deviation_um);
    g.record.profiles.push_back(std::move(p));
  }
  return g;
}

}  // namespace gaugeloop
