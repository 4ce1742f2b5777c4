// RunStore's figures for /metrics: counts and the newest run of each lobe, without reading the history.
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "storage/run_store.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::Connection;
using storage_internal::Statement;
using storage_internal::Transaction;

namespace {

constexpr std::string_view kCounts = "SELECT table_name, value, row_count FROM row_counts";

// The partial index nc_pending_one_per_file holds exactly the pending tables.
constexpr std::string_view kPending = "SELECT count(*) FROM nc_pending WHERE status = 'pending'";

// The newest run of each machine, part and lobe, as a walk down runs_by_lobe_started
// (machine, part, lobe, started_utc; the rowid, which is runs.id, ends every index entry):
// from the last entry of the index, each step seeks the last entry below the current lobe,
// which is the newest run of the next lobe down. Each step is one index seek, so the cost
// grows with the number of lobes, not of runs. The three seeks of a step are the three ways a
// lobe can sort below another (same machine and part; same machine; another machine): SQLite
// would use only the first column of a row-value comparison (machine, part, lobe) < (...) as
// an index range and step over every run of that machine. `machine >= ''` holds for every
// row (machine is NOT NULL TEXT); it makes the first step a seek rather than a scan.
constexpr std::string_view kLastRuns = R"sql(
WITH RECURSIVE newest (id) AS (
  SELECT (SELECT id FROM runs WHERE machine >= ''
          ORDER BY machine DESC, part DESC, lobe DESC, started_utc DESC, id DESC LIMIT 1)
  UNION ALL
  SELECT coalesce(
    (SELECT r.id FROM runs AS r WHERE r.machine = p.machine AND r.part = p.part AND r.lobe < p.lobe
      ORDER BY r.lobe DESC, r.started_utc DESC, r.id DESC LIMIT 1),
    (SELECT r.id FROM runs AS r WHERE r.machine = p.machine AND r.part < p.part
      ORDER BY r.part DESC, r.lobe DESC, r.started_utc DESC, r.id DESC LIMIT 1),
    (SELECT r.id FROM runs AS r WHERE r.machine < p.machine AND r.machine >= ''
      ORDER BY r.machine DESC, r.part DESC, r.lobe DESC, r.started_utc DESC, r.id DESC LIMIT 1))
  FROM newest AS n JOIN runs AS p ON p.id = n.id
)
SELECT r.machine, r.part, r.lobe, r.id, r.started_utc, r.max_abs_error_um, r.verdict
FROM newest AS n JOIN runs AS r ON r.id = n.id
ORDER BY r.machine, r.part, r.lobe)sql";

}  // namespace

namespace storage_internal {
std::vector<std::string_view> metrics_snapshot_queries() { return {kCounts, kPending, kLastRuns}; }
}  // namespace storage_internal

Result<StoreMetrics> RunStore::metrics_snapshot() const {
  Connection& conn = *conn_;
  const std::string operation = "read the figures for /metrics";
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();
  StoreMetrics out;
  out.runs_by_status = {{"measured", 0}, {"pushed", 0}};
  for (EventKind kind : {EventKind::kFault, EventKind::kRefusal, EventKind::kInfo}) {
    out.events_by_kind[std::string(event_kind_name(kind))] = 0;
  }
  for (Verdict v : {Verdict::kIn, Verdict::kOut, Verdict::kNotJudged})
    out.runs_by_verdict[std::string(verdict_name(v))] = 0;

  Result<Statement> counts = Statement::prepare(conn, kCounts, operation);
  if (!counts.ok()) return counts.error();
  for (;;) {
    Result<bool> row = counts->step();
    if (!row.ok()) return row.error();
    if (!*row) break;
    const std::string table = counts->column<std::string>(0);
    const std::string value = counts->column<std::string>(1);
    if (table == "runs") {
      out.runs_by_status[value] = counts->column<std::int64_t>(2);
    } else if (table == "events") {
      out.events_by_kind[value] = counts->column<std::int64_t>(2);
    } else if (table == "verdicts") {
      out.runs_by_verdict[value] = counts->column<std::int64_t>(2);
    }
  }

  Result<Statement> pending = Statement::prepare(conn, kPending, operation);
  if (!pending.ok()) return pending.error();
  Result<std::optional<std::int64_t>> n = pending->first([](const Statement& s) { return s.column<std::int64_t>(0); });
  if (!n.ok()) return n.error();
  out.pending_tables = n->value_or(0);

  Result<Statement> last = Statement::prepare(conn, kLastRuns, operation);
  if (!last.ok()) return last.error();
  Result<std::vector<LobeLastRun>> last_runs = last->collect([](const Statement& s) {
    LobeLastRun r;
    r.machine = s.column<std::string>(0);
    r.part = s.column<std::string>(1);
    r.lobe = s.column<int>(2);
    r.run_id = s.column<std::int64_t>(3);
    r.started_utc = s.column<std::string>(4);
    r.max_abs_error_um = s.column<double>(5);
    r.verdict = verdict_from_name(s.column<std::string>(6)).value_or(Verdict::kNotJudged);
    return r;
  });
  if (!last_runs.ok()) return last_runs.error();
  out.last_runs = std::move(*last_runs);
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return out;
}

}  // namespace gaugeloop
