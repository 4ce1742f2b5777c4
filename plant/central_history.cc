// The central history's queries: RunStore's list_runs, trend and characteristics
// (storage/run_store_runs.cc) over every grinder's runs, with the same filters, rows, order and
// messages.
#include "plant/central_history.h"

#include <cmath>
#include <map>
#include <utility>

#include "plant/central_internal.h"
#include "plant/central_schema.h"

namespace gaugeloop {

using central_internal::CentralConnection;
using central_internal::Params;

namespace {

// Columns 0..21, read by read_summary().
constexpr std::string_view kSummaryColumns =
    "r.local_id, r.uuid, r.started_utc, r.machine, r.part, r.lobe, r.status, r.revolutions, r.degrees_captured, "
    "r.max_abs_error_um, r.rms_error_um, r.repeatability_um, r.nc_file, r.phase_error_deg, "
    "r.base_circle_runout_um, r.peak_to_valley_um, r.settings_hash, r.note, r.raw_pruned_utc, r.serial, "
    "r.operator, r.verdict";

// RunStore's order (started_utc, then the id), and for two grinders' runs that tie on both, the
// grinder synced from and the UUID, so the order never depends on the plan.
constexpr std::string_view kNewestFirst =
    " ORDER BY r.started_utc DESC, r.local_id DESC, r.source_machine DESC, r.uuid DESC";
constexpr std::string_view kOldestFirst = " ORDER BY r.started_utc, r.local_id, r.source_machine, r.uuid";

// CharacteristicSummaries' statement as RunStore's (storage/run_store_runs.cc), over the central
// runs chosen and their characteristics by run UUID, read once (`c`: only the arrays it sums,
// not the whole run_characteristics view); ties in time broken as kOldestFirst. One statement,
// one round trip: the window's count and times (columns 0..2) on every row, and a row per key
// after them (columns 3..15; none when the window has no characteristics).
constexpr std::string_view kSummariesSql = R"sql(
w AS MATERIALIZED (SELECT uuid, local_id,
                          ROW_NUMBER() OVER (ORDER BY started_utc, local_id, source_machine, uuid) AS rank
                   FROM chosen),
c AS MATERIALIZED (SELECT w.rank, w.local_id, (c.ordinality - 1)::integer AS position, c.key, c.unit, c.value,
                          c.lower_limit, c.upper_limit, c.verdict
                   FROM w JOIN run_characteristic_sets AS s ON s.run_uuid = w.uuid,
                        unnest(s.key_list, s.unit_list, s.value_list, s.lower_limit_list, s.upper_limit_list,
                               s.verdict_list) WITH ORDINALITY
                          AS c (key, unit, value, lower_limit, upper_limit, verdict, ordinality)),
k AS MATERIALIZED (
  SELECT c.key, count(*) AS n, avg(c.value) AS mean, min(c.value) AS lo, max(c.value) AS hi,
         min(c.rank * 100000 + c.position) AS first_seen, max(c.rank) AS newest,
         count(*) FILTER (WHERE c.verdict = 'out') AS out_count,
         count(*) FILTER (WHERE c.verdict <> 'not_judged') AS judged_count,
         coalesce(count(c.lower_limit) NOT IN (0, count(*)) OR count(c.upper_limit) NOT IN (0, count(*))
                  OR min(c.lower_limit) <> max(c.lower_limit) OR min(c.upper_limit) <> max(c.upper_limit), false)
           AS changed
  FROM c GROUP BY c.key),
sums AS (
  SELECT k.key, max(CASE WHEN c.rank = k.newest THEN c.unit END), k.n, k.mean,
         sum((c.value - k.mean) * (c.value - k.mean)), k.lo = k.hi, k.lo,
         max(CASE WHEN c.rank = k.newest THEN c.lower_limit END),
         max(CASE WHEN c.rank = k.newest THEN c.upper_limit END),
         max(CASE WHEN c.rank = k.newest THEN c.local_id END), k.changed, k.out_count, k.judged_count, k.first_seen
  FROM c JOIN k ON k.key = c.key
  GROUP BY k.key, k.n, k.mean, k.lo, k.hi, k.first_seen, k.changed, k.out_count, k.judged_count),
span AS (SELECT count(*), min(started_utc), max(started_utc) FROM chosen)
SELECT * FROM span LEFT JOIN sums ON true ORDER BY sums.first_seen)sql";

RunSummary read_summary(const pqxx::row& row) {
  using central_internal::number_of;
  using central_internal::optional_number_of;
  using central_internal::text_of;
  RunSummary r;
  r.id = row[0].as<std::int64_t>();
  r.uuid = text_of(row[1]);
  r.started_utc = text_of(row[2]);
  r.machine = text_of(row[3]);
  r.part = text_of(row[4]);
  r.lobe = row[5].as<int>();
  r.status = text_of(row[6]);
  r.revolutions = row[7].as<int>();
  r.degrees_captured = row[8].as<int>();
  r.max_abs_error_um = number_of(row[9]);
  r.rms_error_um = number_of(row[10]);
  r.repeatability_um = number_of(row[11]);
  r.nc_file = text_of(row[12]);
  r.phase_error_deg = optional_number_of(row[13]);
  r.base_circle_runout_um = optional_number_of(row[14]);
  r.peak_to_valley_um = number_of(row[15]);
  r.settings_hash = text_of(row[16]);
  r.note = text_of(row[17]);
  r.raw_pruned_utc = text_of(row[18]);
  r.serial = text_of(row[19]);
  r.operator_name = text_of(row[20]);
  r.verdict = verdict_from_name(text_of(row[21])).value_or(Verdict::kNotJudged);
  return r;
}

Characteristic read_characteristic(const pqxx::row& row, int first) {
  using central_internal::number_of;
  using central_internal::optional_number_of;
  using central_internal::text_of;
  Characteristic c;
  c.key = text_of(row[first]);
  c.unit = text_of(row[first + 1]);
  c.value = number_of(row[first + 2]);
  c.min = number_of(row[first + 3]);
  c.max = number_of(row[first + 4]);
  c.limits.lower = optional_number_of(row[first + 5]);
  c.limits.upper = optional_number_of(row[first + 6]);
  c.verdict = verdict_from_name(text_of(row[first + 7])).value_or(Verdict::kNotJudged);
  if (!row[first + 8].is_null()) c.from_deg = row[first + 8].as<int>();
  if (!row[first + 9].is_null()) c.to_deg = row[first + 9].as<int>();
  return c;
}

// The query's WHERE clause and its parameters (check_run_query checks it, as for RunStore).
struct Filter {
  std::string where;
  Params params;
  int next = 1;
  void add(std::string_view column_op, const std::string& value) {
    where += (where.empty() ? " WHERE " : " AND ") + std::string(column_op) + " $" + std::to_string(next++);
    params.text(value);
  }
};

Result<Filter> run_filter(const RunQuery& q) {
  if (Status valid = check_run_query(q); !valid.ok()) return valid.error();
  Filter f;
  if (!q.part.empty()) f.add("r.part =", q.part);
  if (q.lobe > 0) f.add("r.lobe =", std::to_string(q.lobe));
  if (!q.machine.empty()) f.add("r.machine =", q.machine);
  if (!q.serial.empty()) f.add("r.serial =", q.serial);
  if (q.verdict) f.add("r.verdict =", std::string(verdict_name(*q.verdict)));
  if (!q.status.empty()) f.add("r.status =", q.status);
  if (q.ground_with_from > 0) f.add("r.ground_with_version >=", std::to_string(q.ground_with_from));
  if (!q.since_utc.empty()) f.add("r.started_utc >=", q.since_utc);
  if (!q.until_utc.empty()) f.add("r.started_utc <", q.until_utc);
  return f;
}

// The newest `limit` runs the filter selects, as a subquery "chosen" of full runs rows.
std::string chosen_runs(Filter& f, int limit) {
  f.params.integer(std::int64_t{limit});
  return "SELECT * FROM runs AS r" + f.where + std::string(kNewestFirst) + " LIMIT $" + std::to_string(f.next++);
}

Result<std::vector<RunSummary>> query_runs(pqxx::transaction_base& tx, const RunQuery& q, bool oldest_first) {
  Result<Filter> f = run_filter(q);
  if (!f.ok()) return f.error();
  const std::string chosen = chosen_runs(*f, q.limit);
  const std::string sql = "SELECT " + std::string(kSummaryColumns) + " FROM (" + chosen + ") AS r" +
                          std::string(oldest_first ? kOldestFirst : kNewestFirst);
  pqxx::result rows = central_internal::exec(tx, sql, f->params);
  std::vector<RunSummary> out;
  out.reserve(rows.size());
  for (const pqxx::row& row : rows) out.push_back(read_summary(row));
  return out;
}

}  // namespace

Result<CentralHistory> CentralHistory::open(const std::string& url) {
  Result<CentralUrl> parsed = parse_central_url(url);
  if (!parsed.ok()) return parsed.error();
  Result<CentralConnection> c = central_internal::connect(*parsed);
  if (!c.ok()) return c.error();
  auto conn = std::make_unique<CentralConnection>(std::move(*c));
  if (Status s = central_internal::require_latest(*conn); !s.ok()) return s.error();
  return CentralHistory(std::move(conn));
}

CentralHistory::CentralHistory(std::unique_ptr<CentralConnection> conn) : conn_(std::move(conn)) {}
CentralHistory::CentralHistory(CentralHistory&&) noexcept = default;
CentralHistory& CentralHistory::operator=(CentralHistory&&) noexcept = default;
CentralHistory::~CentralHistory() = default;

const CentralUrl& CentralHistory::url() const { return conn_->url; }

// One statement: outside a transaction (no BEGIN and COMMIT round trips), it sees one snapshot.
Result<std::vector<RunSummary>> CentralHistory::list_runs(const RunQuery& q) const {
  try {
    pqxx::nontransaction tx(*conn_->conn);
    return query_runs(tx, q, false);
  } catch (const std::exception& e) {
    return central_internal::database_error(conn_->url, "list runs", e);
  }
}

Result<std::vector<RunSummary>> CentralHistory::trend(const RunQuery& q) const {
  try {
    pqxx::nontransaction tx(*conn_->conn);
    return query_runs(tx, q, true);
  } catch (const std::exception& e) {
    return central_internal::database_error(conn_->url, "list runs", e);
  }
}

Result<std::vector<RunCharacteristics>> CentralHistory::characteristics(const RunQuery& q,
                                                                        const std::string& key) const {
  try {
    // One snapshot for both statements, as RunStore reads them in one transaction.
    pqxx::transaction<pqxx::repeatable_read, pqxx::readwrite_policy::read_only> tx(*conn_->conn);
    Result<std::vector<RunSummary>> runs = query_runs(tx, q, true);
    if (!runs.ok()) return runs.error();
    Result<Filter> f = run_filter(q);
    if (!f.ok()) return f.error();
    const std::string chosen = chosen_runs(*f, q.limit);
    std::string only_key;
    if (!key.empty()) {
      only_key = " WHERE c.key = $" + std::to_string(f->next++);
      f->params.text(key);
    }
    pqxx::result rows = central_internal::exec(
        tx,
        "SELECT c.run_uuid, c.key, c.unit, c.value, c.min_value, c.max_value, c.lower_limit, c.upper_limit, "
        "c.verdict, c.from_deg, c.to_deg FROM run_characteristics AS c JOIN (" +
            chosen + ") AS r ON r.uuid = c.run_uuid" + only_key + " ORDER BY c.run_uuid, c.position",
        f->params);
    std::map<std::string, std::vector<Characteristic>> by_run;
    for (const pqxx::row& row : rows) {
      by_run[central_internal::text_of(row[0])].push_back(read_characteristic(row, 1));
    }
    tx.commit();
    std::vector<RunCharacteristics> out;
    out.reserve(runs->size());
    for (RunSummary& r : *runs) {
      auto found = by_run.find(r.uuid);
      std::vector<Characteristic> c = found == by_run.end() ? std::vector<Characteristic>() : std::move(found->second);
      out.push_back({std::move(r), std::move(c)});
    }
    return out;
  } catch (const std::exception& e) {
    return central_internal::database_error(conn_->url, "read the characteristics of the runs", e);
  }
}

Result<CharacteristicSummaries> CentralHistory::characteristic_summaries(const RunQuery& q) const {
  using central_internal::optional_number_of;
  using central_internal::text_of;
  try {
    pqxx::nontransaction tx(*conn_->conn);
    Result<Filter> f = run_filter(q);
    if (!f.ok()) return f.error();
    const std::string chosen = "WITH chosen AS (" + chosen_runs(*f, q.limit) + ")";
    CharacteristicSummaries out;
    const pqxx::result rows = central_internal::exec(tx, chosen + "," + std::string(kSummariesSql), f->params);
    out.runs = rows[0][0].as<int>();
    out.first_started_utc = text_of(rows[0][1]);
    out.last_started_utc = text_of(rows[0][2]);
    for (const pqxx::row& row : rows) {
      if (row[3].is_null()) continue;  // no characteristics: the window's row alone
      CharacteristicSummary k;
      k.key = text_of(row[3]);
      k.unit = text_of(row[4]);
      k.n = row[5].as<int>();
      k.all_equal = row[8].as<bool>();
      k.mean = k.all_equal ? central_internal::number_of(row[9]) : central_internal::number_of(row[6]);
      k.squares = k.all_equal ? 0.0 : optional_number_of(row[7]).value_or(INFINITY);
      k.limits.lower = optional_number_of(row[10]);
      k.limits.upper = optional_number_of(row[11]);
      k.limits_from_run = row[12].as<std::int64_t>();
      k.limits_changed = row[13].as<bool>();
      k.out_count = row[14].as<int>();
      k.judged_count = row[15].as<int>();
      out.by_key.push_back(std::move(k));
    }
    return out;
  } catch (const std::exception& e) {
    return central_internal::database_error(conn_->url, "sum up the characteristics of the runs", e);
  }
}

}  // namespace gaugeloop
