// RunStore::metrics_snapshot: the same figures as reading the whole history, kept right by
// the triggers whatever changes the rows, read through indexes, and brought by the migration
// to databases written before it.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <climits>
#include <filesystem>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"
#include "storage_test_support.h"
#include "tests/support/damaged_database.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::make_record;
using testing::RawDb;
using testing::TempDir;

using Counts = std::map<std::string, std::int64_t>;
// machine, part, lobe, run id, started_utc, max_abs_error_um
using Last = std::tuple<std::string, std::string, int, std::int64_t, std::string, double>;

std::vector<Last> last_of(const StoreMetrics& m) {
  std::vector<Last> out;
  for (const LobeLastRun& r : m.last_runs) {
    out.emplace_back(r.machine, r.part, r.lobe, r.run_id, r.started_utc, r.max_abs_error_um);
  }
  return out;
}

// The figures as /metrics computed them before metrics_snapshot: every run, event and pending
// table read, the newest run of a lobe being the first of list_runs (newest first).
StoreMetrics read_in_full(const RunStore& store) {
  StoreMetrics m;
  m.runs_by_status = {{"measured", 0}, {"pushed", 0}};
  m.events_by_kind = {{"fault", 0}, {"refusal", 0}, {"info", 0}};
  RunQuery rq;
  rq.limit = INT_MAX;
  Result<std::vector<RunSummary>> runs = store.list_runs(rq);
  EXPECT_TRUE(runs.ok());
  std::map<std::tuple<std::string, std::string, int>, LobeLastRun> last;
  for (const RunSummary& r : runs.value()) {
    ++m.runs_by_status[r.status];
    last.emplace(std::make_tuple(r.machine, r.part, r.lobe),
                 LobeLastRun{r.machine, r.part, r.lobe, r.id, r.started_utc, r.max_abs_error_um});
  }
  for (const auto& [key, r] : last) m.last_runs.push_back(r);
  EventQuery eq;
  eq.limit = INT_MAX;
  Result<std::vector<StoredEvent>> events = store.list_events(eq);
  EXPECT_TRUE(events.ok());
  for (const StoredEvent& e : events.value()) ++m.events_by_kind[std::string(event_kind_name(e.event.kind))];
  PendingQuery pq;
  pq.limit = INT_MAX;
  pq.status = PendingStatus::kPending;
  Result<std::vector<PendingTable>> pending = store.list_pending(pq);
  EXPECT_TRUE(pending.ok());
  m.pending_tables = static_cast<std::int64_t>(pending.value().size());
  return m;
}

class MetricsSnapshotTest : public testing::StoreTest {
 protected:
  std::int64_t add(const std::string& machine, const std::string& part, int lobe, const std::string& started,
                   double max_um) {
    RunRecord r = make_record(part, started);
    r.machine = machine;
    r.lobe = lobe;
    r.analysis.max_abs_error_um = max_um;
    Result<std::int64_t> id = store().insert_run(r);
    EXPECT_TRUE(id.ok()) << id.error().message;
    return id.ok() ? *id : -1;
  }

  void event(EventKind kind, const std::string& code) {
    EventRecord e;
    e.kind = kind;
    e.code = code;
    e.message = code + " on grinder g1";
    e.at_utc = "2026-11-22T08:00:00Z";
    ASSERT_TRUE(store().record_event(e).ok());
  }

  std::int64_t pending(std::int64_t run_id, const std::string& nc_file) {
    PendingTable t;
    t.run_id = run_id;
    t.nc_file = nc_file;
    t.program_text = "N10 G1 C0 X0\n";
    t.reason = "approval required";
    Result<std::int64_t> id = store().add_pending(t);
    EXPECT_TRUE(id.ok()) << id.error().message;
    return id.ok() ? *id : -1;
  }

  StoreMetrics snapshot() {
    Result<StoreMetrics> m = store().metrics_snapshot();
    EXPECT_TRUE(m.ok()) << m.error().message;
    return m.ok() ? *m : StoreMetrics{};
  }

  // Two machines, two parts, three lobes; a run stored after a newer one of its lobe, two runs
  // of a lobe started in the same second; every event kind; pending, superseded and rejected tables.
  void fill() {
    ids_.push_back(add("g1", "a", 1, "2026-11-20T10:00:00Z", 4.0));
    ids_.push_back(add("g1", "a", 1, "2026-11-21T10:00:00Z", 5.0));  // the newest of g1/a/1
    ids_.push_back(add("g1", "a", 1, "2026-11-19T10:00:00Z", 9.0));  // stored last, measured first
    ids_.push_back(add("g1", "a", 2, "2026-11-21T10:00:00Z", 30.0));
    ids_.push_back(add("g1", "a", 2, "2026-11-21T10:00:00Z", 31.0));  // same second, higher id
    ids_.push_back(add("g1", "b", 1, "2026-11-22T10:00:00Z", 2.5));
    ids_.push_back(add("g2", "a", 1, "2026-11-20T12:00:00Z", 6.0));
    ids_.push_back(add("g2", "a", 3, "2026-11-18T12:00:00Z", 7.25));
    ASSERT_TRUE(store().record_nc_file(ids_[1], "/nc/A1.SPF").ok());
    ASSERT_TRUE(store().record_nc_file(ids_[5], "/nc/B1.SPF").ok());
    event(EventKind::kFault, "gauge timeout");
    for (int i = 0; i < 2; ++i) event(EventKind::kRefusal, "refused");
    for (int i = 0; i < 3; ++i) event(EventKind::kInfo, "plc request");
    pending(ids_[3], "/nc/A2.SPF");  // superseded by the next one
    pending(ids_[4], "/nc/A2.SPF");
    ASSERT_TRUE(store().reject_pending(pending(ids_[5], "/nc/B1.SPF"), "anna", "flank").ok());
    pending(ids_[6], "/nc/A1_G2.SPF");
  }

  std::vector<std::int64_t> ids_;
};

TEST_F(MetricsSnapshotTest, AnEmptyDatabaseCountsZeroOfEverything) {
  const StoreMetrics m = snapshot();
  EXPECT_EQ(m.runs_by_status, (Counts{{"measured", 0}, {"pushed", 0}}));
  EXPECT_EQ(m.events_by_kind, (Counts{{"fault", 0}, {"refusal", 0}, {"info", 0}}));
  EXPECT_EQ(m.pending_tables, 0);
  EXPECT_TRUE(m.last_runs.empty());
}

TEST_F(MetricsSnapshotTest, GivesTheFiguresOfTheWholeHistory) {
  fill();
  const StoreMetrics m = snapshot();
  EXPECT_EQ(m.runs_by_status, (Counts{{"measured", 6}, {"pushed", 2}}));
  EXPECT_EQ(m.events_by_kind, (Counts{{"fault", 1}, {"refusal", 2}, {"info", 3}}));
  EXPECT_EQ(m.pending_tables, 2);
  EXPECT_EQ(last_of(m), (std::vector<Last>{
                            {"g1", "a", 1, ids_[1], "2026-11-21T10:00:00Z", 5.0},
                            {"g1", "a", 2, ids_[4], "2026-11-21T10:00:00Z", 31.0},
                            {"g1", "b", 1, ids_[5], "2026-11-22T10:00:00Z", 2.5},
                            {"g2", "a", 1, ids_[6], "2026-11-20T12:00:00Z", 6.0},
                            {"g2", "a", 3, ids_[7], "2026-11-18T12:00:00Z", 7.25},
                        }));
  const StoreMetrics full = read_in_full(store());
  EXPECT_EQ(m.runs_by_status, full.runs_by_status);
  EXPECT_EQ(m.events_by_kind, full.events_by_kind);
  EXPECT_EQ(m.pending_tables, full.pending_tables);
  EXPECT_EQ(last_of(m), last_of(full));
}

// The counts are kept by triggers, so rows changed with sqlite3 by hand count too.
TEST_F(MetricsSnapshotTest, CountsFollowRowsDeletedAndChangedByHand) {
  fill();
  {
    RawDb raw(db());
    raw.exec("DELETE FROM runs WHERE id = " + std::to_string(ids_[7]));
    raw.exec("UPDATE runs SET status = 'measured', nc_file = NULL WHERE id = " + std::to_string(ids_[5]));
    raw.exec("UPDATE events SET kind = 'fault' WHERE kind = 'info'");
    raw.exec("DELETE FROM events WHERE kind = 'refusal'");
    raw.exec("UPDATE events SET message = 'edited'");  // no kind changes: no count changes
  }
  const StoreMetrics m = snapshot();
  EXPECT_EQ(m.runs_by_status, (Counts{{"measured", 6}, {"pushed", 1}}));
  EXPECT_EQ(m.events_by_kind, (Counts{{"fault", 4}, {"refusal", 0}, {"info", 0}}));
  ASSERT_EQ(m.last_runs.size(), 4u) << "g2/a/3 had one run, deleted";
  const StoreMetrics full = read_in_full(store());
  EXPECT_EQ(m.runs_by_status, full.runs_by_status);
  EXPECT_EQ(m.events_by_kind, full.events_by_kind);
  EXPECT_EQ(m.pending_tables, full.pending_tables);
  EXPECT_EQ(last_of(m), last_of(full));
}

// Each statement of the snapshot, as SQLite plans it (EXPLAIN QUERY PLAN), one detail a line.
std::vector<std::string> plan_of(const fs::path& db, std::string_view sql) {
  sqlite3* handle = nullptr;
  EXPECT_EQ(sqlite3_open(db.c_str(), &handle), SQLITE_OK);
  const std::string explain = "EXPLAIN QUERY PLAN " + std::string(sql);
  sqlite3_stmt* st = nullptr;
  EXPECT_EQ(sqlite3_prepare_v2(handle, explain.c_str(), -1, &st, nullptr), SQLITE_OK) << sqlite3_errmsg(handle);
  std::vector<std::string> details;
  while (st != nullptr && sqlite3_step(st) == SQLITE_ROW) {
    details.emplace_back(reinterpret_cast<const char*>(sqlite3_column_text(st, 3)));
  }
  sqlite3_finalize(st);
  sqlite3_close(handle);
  return details;
}

// No statement reads runs or events in full: runs only by index seeks, the counts from
// row_counts, the pending tables from their partial index.
TEST_F(MetricsSnapshotTest, ReadsNoBigTableInFull) {
  fill();
  const std::vector<std::string> allowed_scans = {"SCAN row_counts", "SCAN CONSTANT ROW", "SCAN n",
                                                  "SCAN nc_pending USING INDEX nc_pending_one_per_file"};
  std::string all;
  for (std::string_view sql : storage_internal::metrics_snapshot_queries()) {
    const std::vector<std::string> plan = plan_of(db(), sql);
    for (std::size_t k = 0; k < plan.size(); ++k) {
      const std::string& line = plan[k];
      all += line + "\n";
      if (line.starts_with("SCAN ")) {
        EXPECT_NE(std::find(allowed_scans.begin(), allowed_scans.end(), line), allowed_scans.end())
            << "a scan: " << line << "\nof:\n"
            << sql;
      }
      // Only the last step may sort: the lobes found, never the runs of a lobe.
      if (line.starts_with("USE TEMP B-TREE")) {
        EXPECT_EQ(k + 1, plan.size()) << "a sort inside:\n" << sql;
      }
    }
  }
  EXPECT_NE(all.find("SEARCH r USING COVERING INDEX runs_by_lobe_started (machine=? AND part=? AND lobe<?)"),
            std::string::npos)
      << all;
}

TEST(MetricsSnapshotMigration, Version6AddsTheIndexTheCountsAndTheirTriggers) {
  TempDir dir;
  const fs::path db = testing::db_in(dir);
  fs::create_directories(db.parent_path());
  {
    storage_internal::Connection conn;
    conn.path = db;
    ASSERT_EQ(sqlite3_open(db.c_str(), &conn.db), SQLITE_OK);
    ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, 5).ok());
    RawDb raw(db);
    for (const char* status_and_file : {"'measured', NULL", "'measured', NULL", "'pushed', '/nc/A.SPF'"}) {
      raw.exec(std::string("INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, status, nc_file,"
                           " revolutions, degrees_captured, zero_offset_mm, max_abs_error_um, rms_error_um,"
                           " peak_to_valley_um, repeatability_um) VALUES ('2026-11-22T08:00:00Z',"
                           " '2026-11-22T08:01:00Z', 'g1', 'a', 1, 'tcp:sim', ") +
               status_and_file + ", 3, 1080, 0.0, 4.5, 1.0, 6.0, 0.5)");
    }
    raw.exec(
        "INSERT INTO events (at_utc, kind, code, message) VALUES ('2026-11-22T08:00:00Z', 'info', 'plc', 'x'),"
        " ('2026-11-22T08:00:01Z', 'fault', 'gauge timeout', 'y')");
    EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'row_counts'"), 0);
  }
  Result<RunStore> store = RunStore::open(db);
  ASSERT_TRUE(store.ok()) << store.error().message;
  ASSERT_TRUE(store->schema_upgrade().has_value()) << "upgraded without a backup";
  EXPECT_EQ(store->schema_upgrade()->from_version, 5);
  EXPECT_EQ(testing::sqlite_text(store->schema_upgrade()->backup, "PRAGMA user_version"), "5");

  RawDb raw(db);
  EXPECT_GE(raw.query_int("PRAGMA user_version"), 6);
  EXPECT_EQ(raw.query_text("SELECT group_concat(name, ',') FROM"
                           " (SELECT name FROM pragma_index_info('runs_by_lobe_started') ORDER BY seqno)"),
            "machine,part,lobe,started_utc");
  EXPECT_EQ(
      raw.query_text("SELECT group_concat(name, ',') FROM (SELECT name FROM sqlite_schema"
                     " WHERE type = 'trigger' AND name LIKE '%counted%' AND name NOT LIKE 'outbox%' ORDER BY name)"),
      "events_counted_on_delete,events_counted_on_insert,events_counted_on_kind,"
      "runs_counted_on_delete,runs_counted_on_insert,runs_counted_on_status,"
      "runs_verdict_counted_on_delete,runs_verdict_counted_on_insert,runs_verdict_counted_on_update");
  Result<StoreMetrics> m = store->metrics_snapshot();
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->runs_by_status, (Counts{{"measured", 2}, {"pushed", 1}})) << "the rows already there are counted";
  EXPECT_EQ(m->events_by_kind, (Counts{{"fault", 1}, {"refusal", 0}, {"info", 1}}));
  ASSERT_EQ(m->last_runs.size(), 1u);
  EXPECT_EQ(m->last_runs[0].run_id, 3);
  EXPECT_EQ(m->last_runs[0].max_abs_error_um, 4.5);
}

}  // namespace
}  // namespace gaugeloop
