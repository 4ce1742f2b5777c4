// The questions people ask the history: filtered lists, trends, pushes, events, retention,
// and a reader that keeps working while another connection writes.
#include <gtest/gtest.h>

#include <atomic>
#include <optional>
#include <string>
#include <thread>

#include "storage/run_store.h"
#include "storage_test_support.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using testing::has;
using testing::make_record;
using testing::RawDb;
using testing::TempDir;

class QueryTest : public testing::StoreTest {
 protected:
  std::int64_t add(const std::string& part, int lobe, const std::string& machine, const std::string& started,
                   double max_um = 4.0) {
    RunRecord r = make_record(part, started);
    r.lobe = lobe;
    r.machine = machine;
    r.analysis.max_abs_error_um = max_um;
    Result<std::int64_t> id = store().insert_run(r);
    EXPECT_TRUE(id.ok()) << id.error().message;
    return id.ok() ? *id : -1;
  }

  static std::vector<std::int64_t> ids(const Result<std::vector<RunSummary>>& runs) {
    EXPECT_TRUE(runs.ok()) << runs.error().message;
    std::vector<std::int64_t> out;
    if (runs.ok()) {
      for (const RunSummary& r : *runs) out.push_back(r.id);
    }
    return out;
  }
};

using Ids = std::vector<std::int64_t>;

TEST_F(QueryTest, ListFiltersByLobeMachineTimeAndStatus) {
  const auto a1 = add("a", 1, "g1", "2026-11-20T10:00:00Z");
  const auto a2 = add("a", 2, "g1", "2026-11-21T10:00:00Z");
  const auto a1g2 = add("a", 1, "g2", "2026-11-22T10:00:00Z");
  const auto b1 = add("b", 1, "g1", "2026-11-23T10:00:00Z");
  ASSERT_TRUE(store().record_nc_file(a2, "/nc/A2.SPF").ok());

  EXPECT_EQ(ids(store().list_runs([&] {
              RunQuery q;
              q.part = "a";
              q.lobe = 1;
              return q;
            }())),
            (Ids{a1g2, a1}));
  EXPECT_EQ(ids(store().list_runs([&] {
              RunQuery q;
              q.machine = "g1";
              return q;
            }())),
            (Ids{b1, a2, a1}));
  EXPECT_EQ(ids(store().list_runs([&] {
              RunQuery q;
              q.status = "pushed";
              return q;
            }())),
            (Ids{a2}));
  EXPECT_EQ(ids(store().list_runs([&] {
              RunQuery q;
              q.status = "measured";
              return q;
            }())),
            (Ids{b1, a1g2, a1}));
  // since inclusive, until exclusive
  EXPECT_EQ(ids(store().list_runs([&] {
              RunQuery q;
              q.since_utc = "2026-11-21T10:00:00Z";
              q.until_utc = "2026-11-23T10:00:00Z";
              return q;
            }())),
            (Ids{a1g2, a2}));
  EXPECT_EQ(ids(store().list_runs([&] {
              RunQuery q;
              q.part = "a";
              q.lobe = 1;
              q.machine = "g2";
              return q;
            }())),
            (Ids{a1g2}));
  EXPECT_TRUE(ids(store().list_runs([&] {
                RunQuery q;
                q.part = "a";
                q.lobe = 3;
                return q;
              }()))
                  .empty());
}

TEST_F(QueryTest, ListRefusesMalformedFiltersSayingWhatIsExpected) {
  Result<std::vector<RunSummary>> r = store().list_runs([&] {
    RunQuery q;
    q.since_utc = "2026-11-21";
    return q;
  }());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("2026-11-22T02:34:44Z"), std::string::npos) << r.error().message;
  r = store().list_runs([&] {
    RunQuery q;
    q.status = "done";
    return q;
  }());
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("measured, pushed"), std::string::npos) << r.error().message;
}

TEST_F(QueryTest, TrendIsOldestFirstAndKeepsTheNewestLimit) {
  add("a", 1, "g1", "2026-11-20T10:00:00Z", 9.0);
  const auto second = add("a", 1, "g1", "2026-11-21T10:00:00Z", 6.0);
  add("a", 2, "g1", "2026-11-21T11:00:00Z", 50.0);  // another lobe
  const auto third = add("a", 1, "g1", "2026-11-22T10:00:00Z", 3.0);
  Result<std::vector<RunSummary>> t = store().trend([&] {
    RunQuery q;
    q.limit = 2;
    q.part = "a";
    q.lobe = 1;
    return q;
  }());
  EXPECT_EQ(ids(t), (Ids{second, third}));
  ASSERT_TRUE(t.ok());
  EXPECT_EQ((*t)[0].max_abs_error_um, 6.0);
  ASSERT_TRUE((*t)[1].phase_error_deg.has_value());
  EXPECT_EQ(*(*t)[1].phase_error_deg, make_record("a", "x").analysis.phase_error_deg);
  EXPECT_EQ(*(*t)[1].base_circle_runout_um, 1.75);
}

TEST_F(QueryTest, EveryPushIsKeptWithWhatWasPushed) {
  const auto id = add("a", 1, "g1", "2026-11-20T10:00:00Z");
  ASSERT_TRUE(store().record_nc_file(id, "/nc/A.SPF").ok());
  NcPush push;
  push.pushed_utc = "2026-11-20T10:05:00Z";
  push.nc_file = "/nc/B.SPF";
  push.table.point_count = 361;
  push.table.correction_max_um = 16.6;
  Status s = store().record_push(id, push, "CTABDEF(X,C,1,1)\n");
  ASSERT_TRUE(s.ok()) << s.error().message;
  Result<StoredRun> run = store().load_run(id);
  ASSERT_TRUE(run.ok()) << run.error().message;
  EXPECT_EQ(run->summary.nc_file, "/nc/B.SPF") << "the run names the newest push";
  ASSERT_EQ(run->pushes.size(), 2u);
  EXPECT_EQ(run->pushes[0].nc_file, "/nc/A.SPF");
  EXPECT_EQ(run->pushes[0].pushed_utc.size(), 20u) << "recorded now, as an ISO time: " << run->pushes[0].pushed_utc;
  EXPECT_FALSE(run->pushes[0].table.point_count.has_value());
  EXPECT_EQ(run->pushes[1].pushed_utc, "2026-11-20T10:05:00Z");
  EXPECT_EQ(run->pushes[1].table.point_count, 361);
  EXPECT_EQ(run->pushes[1].table.correction_max_um, 16.6);
  EXPECT_EQ(run->pushes[1].program_hash, settings_hash("CTABDEF(X,C,1,1)\n"));
}

TEST_F(QueryTest, AFailedPushRecordLeavesNoHalf) {
  NcPush push;
  push.nc_file = "/nc/A.SPF";
  Status s = store().record_push(77, push);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kNotFound);
  EXPECT_EQ(RawDb(db_in(dir_)).query_int("SELECT count(*) FROM nc_pushes"), 0);
}

TEST_F(QueryTest, EventsAreKeptAndListedNewestFirstByKind) {
  const auto run = add("a", 1, "g1", "2026-11-20T10:00:00Z");
  EventRecord fault;
  fault.at_utc = "2026-11-20T09:00:00Z";
  fault.kind = EventKind::kFault;
  fault.code = std::string(error_code_name(ErrorCode::kGaugeTimeout));
  fault.machine = "g1";
  fault.part = "a";
  fault.lobe = 1;
  fault.message = "gauge tcp:127.0.0.1:1502 stopped answering during revolution 2";
  ASSERT_TRUE(store().record_event(fault).ok());
  EventRecord refusal = fault;
  refusal.at_utc = "2026-11-20T10:01:00Z";
  refusal.kind = event_kind_for(ErrorCode::kRefused);
  refusal.code = "refused";
  refusal.run_id = run;
  refusal.message = "correction 120 um at cam degree 95 exceeds 100 um";
  ASSERT_TRUE(store().record_event(refusal).ok());

  Result<std::vector<StoredEvent>> all = store().list_events({});
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->size(), 2u);
  EXPECT_EQ((*all)[0].event.kind, EventKind::kRefusal);
  EXPECT_EQ((*all)[0].event.run_id, run);
  EXPECT_EQ((*all)[1].event.message, fault.message);
  EXPECT_EQ((*all)[1].event.lobe, 1);
  Result<std::vector<StoredEvent>> faults = store().list_events([&] {
    EventQuery q;
    q.kind = EventKind::kFault;
    return q;
  }());
  ASSERT_TRUE(faults.ok());
  ASSERT_EQ(faults->size(), 1u);
  EXPECT_EQ((*faults)[0].event.code, "gauge timeout");
  EXPECT_FALSE(store().record_event(EventRecord{}).ok()) << "an event needs a message";
}

// A burst of events in one transaction: all of them, in order; one refused (no code), none.
TEST_F(QueryTest, EventsRecordedTogetherAreAllKeptInOrderOrNoneIs) {
  const auto run = add("a", 1, "g1", "2026-11-20T10:00:00Z");
  std::vector<EventRecord> burst;
  for (int i = 0; i < 300; ++i) {
    EventRecord e;
    e.at_utc = "2026-11-20T10:02:00Z";
    e.kind = EventKind::kInfo;
    e.code = "plc request";
    e.machine = "g1";
    e.run_id = i == 0 ? std::optional<std::int64_t>(run) : std::nullopt;
    e.message = "request " + std::to_string(i);
    burst.push_back(e);
  }
  std::vector<EventRecord> refused = burst;
  refused[150].code.clear();
  Status r = store().record_events(refused);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("event 151 of 300"), std::string::npos) << r.error().message;
  Result<std::vector<StoredEvent>> none = store().list_events({});
  ASSERT_TRUE(none.ok());
  EXPECT_TRUE(none->empty()) << "none of a refused burst is kept";

  ASSERT_TRUE(store().record_events(burst).ok());
  EventQuery q;
  q.limit = 1000;
  Result<std::vector<StoredEvent>> all = store().list_events(q);
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->size(), 300u);
  for (std::size_t i = 0; i < 300; ++i) {
    const StoredEvent& e = (*all)[299 - i];  // newest first
    EXPECT_EQ(e.event.message, "request " + std::to_string(i));
    if (i > 0) {
      EXPECT_GT(e.id, (*all)[300 - i].id) << "in order";
    }
  }
  EXPECT_EQ((*all)[299].event.run_id, run);
}

TEST_F(QueryTest, InfoEventsOfTheServiceAreKeptAndListedApart) {
  const auto run = add("a", 1, "g1", "2026-11-20T10:00:00Z");
  EventRecord info;
  info.at_utc = "2026-11-20T10:02:00Z";
  info.kind = EventKind::kInfo;
  info.code = "plc done";
  info.machine = "g1";
  info.part = "a";
  info.lobe = 1;
  info.run_id = run;
  info.message = "PLC request part number 7 lobe 1: done, result 0 (table pushed), run " + std::to_string(run);
  ASSERT_TRUE(store().record_event(info).ok());
  EventRecord fault = info;
  fault.kind = EventKind::kFault;
  fault.code = "gauge timeout";
  ASSERT_TRUE(store().record_event(fault).ok());
  Result<std::vector<StoredEvent>> infos = store().list_events([&] {
    EventQuery q;
    q.kind = EventKind::kInfo;
    return q;
  }());
  ASSERT_TRUE(infos.ok()) << infos.error().message;
  ASSERT_EQ(infos->size(), 1u);
  EXPECT_EQ((*infos)[0].event.kind, EventKind::kInfo);
  EXPECT_EQ((*infos)[0].event.code, "plc done");
  EXPECT_EQ((*infos)[0].event.run_id, run);
  EXPECT_EQ(event_kind_name(EventKind::kInfo), "info");
}

TEST_F(QueryTest, PruneRemovesOldRawSamplesAndKeepsEverythingElse) {
  const auto old_run = add("a", 1, "g1", "2026-10-01T10:00:00Z");
  const auto new_run = add("a", 1, "g1", "2026-11-20T10:00:00Z");
  ASSERT_TRUE(store().record_nc_file(old_run, "/nc/A.SPF").ok());
  Result<std::int64_t> pruned = store().prune_raw_samples("2026-11-01T00:00:00Z", "2026-11-22T00:00:00Z");
  ASSERT_TRUE(pruned.ok()) << pruned.error().message;
  EXPECT_EQ(*pruned, 1);

  Result<StoredRun> old_loaded = store().load_run(old_run);
  ASSERT_TRUE(old_loaded.ok()) << old_loaded.error().message;
  EXPECT_TRUE(old_loaded->revolutions.empty());
  EXPECT_EQ(old_loaded->summary.raw_pruned_utc, "2026-11-22T00:00:00Z");
  EXPECT_EQ(old_loaded->summary.revolutions, 3) << "the summary still says what was measured";
  const RunRecord expected = make_record("a", "x");
  EXPECT_NEAR(old_loaded->analysis.error_um[100], expected.analysis.error_um[100], 1e-4);
  EXPECT_NEAR(old_loaded->correction_um[200], expected.correction_um[200], 1e-4);
  EXPECT_EQ(old_loaded->pushes.size(), 1u);
  Result<StoredRun> new_loaded = store().load_run(new_run);
  ASSERT_TRUE(new_loaded.ok());
  EXPECT_EQ(new_loaded->revolutions.size(), 3u);

  // Pruning again finds nothing more to do.
  pruned = store().prune_raw_samples("2026-11-01T00:00:00Z", "2026-11-23T00:00:00Z");
  ASSERT_TRUE(pruned.ok());
  EXPECT_EQ(*pruned, 0);
  RawDb raw(db_in(dir_));
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_samples WHERE run_id = " + std::to_string(old_run)), 0);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_profile WHERE run_id = " + std::to_string(old_run)), 360);
}

// The pruned runs in the order the central sync follows them, by prune time then id, after a
// given (time, id), read through the index of pruned runs.
TEST_F(QueryTest, PrunedRunsAreListedByPruneTimeThenIdAfterAGivenOne) {
  const auto first = add("a", 1, "g1", "2026-10-01T10:00:00Z");
  const auto second = add("a", 1, "g1", "2026-10-02T10:00:00Z");
  const auto third = add("a", 1, "g1", "2026-10-20T10:00:00Z");
  add("a", 1, "g1", "2026-11-20T10:00:00Z");  // never pruned
  ASSERT_TRUE(store().prune_raw_samples("2026-10-10T00:00:00Z", "2026-11-22T00:00:00Z").ok());
  ASSERT_TRUE(store().prune_raw_samples("2026-11-01T00:00:00Z", "2026-11-23T00:00:00Z").ok());

  Result<std::vector<PrunedRun>> all = store().runs_pruned_after("", 0, 10);
  ASSERT_TRUE(all.ok()) << all.error().message;
  std::vector<std::string> listed;
  for (const PrunedRun& p : *all) listed.push_back(std::to_string(p.id) + " " + p.pruned_utc);
  EXPECT_EQ(listed, (std::vector<std::string>{std::to_string(first) + " 2026-11-22T00:00:00Z",
                                              std::to_string(second) + " 2026-11-22T00:00:00Z",
                                              std::to_string(third) + " 2026-11-23T00:00:00Z"}));
  Result<StoredRun> loaded = store().load_run(first);
  ASSERT_TRUE(loaded.ok());
  EXPECT_EQ((*all)[0].uuid, loaded->summary.uuid);

  // After the first run of the first prune: the second of it, then the later prune's.
  Result<std::vector<PrunedRun>> after = store().runs_pruned_after("2026-11-22T00:00:00Z", first, 1);
  ASSERT_TRUE(after.ok()) << after.error().message;
  ASSERT_EQ(after->size(), 1u) << "the limit";
  EXPECT_EQ((*after)[0].id, second);
  after = store().runs_pruned_after("2026-11-22T00:00:00Z", second, 10);
  ASSERT_TRUE(after.ok());
  ASSERT_EQ(after->size(), 1u);
  EXPECT_EQ((*after)[0].id, third);
  after = store().runs_pruned_after("2026-11-23T00:00:00Z", third, 10);
  ASSERT_TRUE(after.ok());
  EXPECT_TRUE(after->empty());
  EXPECT_FALSE(store().runs_pruned_after("", 0, 0).ok()) << "a limit below 1";

  const std::string plan =
      RawDb(db_in(dir_))
          .query_plan(
              "SELECT id, uuid, raw_pruned_utc FROM runs WHERE raw_pruned_utc IS NOT NULL AND (raw_pruned_utc, id) > "
              "('2026-11-22T00:00:00Z', 1) ORDER BY raw_pruned_utc, id LIMIT 10");
  EXPECT_TRUE(has(plan, "runs_by_raw_pruned")) << plan;
  EXPECT_FALSE(has(plan, "TEMP B-TREE")) << plan;
}

// ---- Concurrency: two connections, real threads, no sleeps ----

// A reader lists and loads runs while a writer on another connection stores 40 runs. Every
// reader call must succeed (WAL: readers never wait for the writer) and see whole runs only.
TEST(Concurrency, AReaderWorksWhileAWriterWrites) {
  TempDir dir;
  Result<RunStore> writer = RunStore::open(db_in(dir));
  ASSERT_TRUE(writer.ok()) << writer.error().message;
  Result<RunStore> reader = RunStore::open(db_in(dir));
  ASSERT_TRUE(reader.ok()) << reader.error().message;

  constexpr int kRuns = 40;
  std::atomic<bool> done{false};
  std::atomic<int> writer_failures{0};
  std::thread write_thread([&] {
    for (int i = 0; i < kRuns; ++i) {
      if (!writer->insert_run(make_record("c", "2026-11-22T02:34:44Z")).ok()) ++writer_failures;
    }
    done = true;
  });
  int reads = 0;
  std::string first_failure;
  std::size_t seen = 0;
  // Runs until the writer is done, then once more: at least one read overlaps the writes
  // unless the writer finished first, and every read is checked either way.
  for (bool last = false; !last;) {
    last = done.load();
    Result<std::vector<RunSummary>> runs = reader->list_runs([&] {
      RunQuery q;
      q.limit = kRuns;
      return q;
    }());
    ++reads;
    if (!runs.ok()) {
      first_failure = runs.error().message;
      break;
    }
    ASSERT_GE(runs->size(), seen) << "runs disappeared";
    seen = runs->size();
    if (!runs->empty()) {
      Result<StoredRun> run = reader->load_run(runs->front().id);
      if (!run.ok()) {
        first_failure = run.error().message;
        break;
      }
      ASSERT_EQ(run->revolutions.size(), 3u);
    }
  }
  write_thread.join();
  EXPECT_EQ(first_failure, "") << "after " << reads << " reads";
  EXPECT_EQ(writer_failures.load(), 0);
  EXPECT_EQ(seen, static_cast<std::size_t>(kRuns));
}

// Two writers on two connections: BEGIN IMMEDIATE and the busy timeout queue them, so
// neither sees "database is locked".
TEST(Concurrency, TwoWritersBothSucceed) {
  TempDir dir;
  ASSERT_TRUE(RunStore::open(db_in(dir)).ok());
  constexpr int kRunsEach = 25;
  std::atomic<int> failures{0};
  std::string failure;
  auto write = [&](const std::string& machine) {
    Result<RunStore> store = RunStore::open(db_in(dir));
    if (!store.ok()) {
      ++failures;
      return;
    }
    for (int i = 0; i < kRunsEach; ++i) {
      RunRecord r = make_record("w", "2026-11-22T02:34:44Z");
      r.machine = machine;
      if (!store->insert_run(r).ok()) ++failures;
      EventRecord e;
      e.code = "x";
      e.machine = machine;
      e.message = "m";
      if (!store->record_event(e).ok()) ++failures;
    }
  };
  std::thread a(write, "g1");
  std::thread b(write, "g2");
  a.join();
  b.join();
  EXPECT_EQ(failures.load(), 0);
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.counts().runs, 2 * kRunsEach);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM events"), 2 * kRunsEach);
}

}  // namespace
}  // namespace gaugeloop
