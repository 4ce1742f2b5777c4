// The plant side of the run database: global identity (UUIDs on runs, pushes and events) and
// the outbox that every broker message passes through, written in the same transaction as the
// record it describes.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <set>
#include <string>
#include <vector>

#include "core/uuid.h"
#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"
#include "storage_test_support.h"
#include "tests/support/store_test.h"

namespace gaugeloop {
namespace {

using testing::make_record;
using testing::RawDb;
using testing::TempDir;

class PlantStoreTest : public testing::StoreTest {
 protected:
  std::int64_t add_run(const std::string& started, Verdict verdict = Verdict::kIn, int lobe = 1) {
    RunRecord r = make_record("intake", started);
    r.lobe = lobe;
    r.verdict = verdict;
    for (Characteristic& c : r.characteristics) c.verdict = verdict;
    Result<std::int64_t> id = store().insert_run(r);
    EXPECT_TRUE(id.ok()) << id.error().message;
    return id.ok() ? *id : 0;
  }
  void push(std::int64_t run_id) {
    NcPush p;
    p.nc_file = "/nc/INTAKE.SPF";
    Status s = store().record_push(run_id, p, "CTABDEF(X,C,1,1)\nCTABEND\n");
    EXPECT_TRUE(s.ok()) << s.error().message;
  }
  std::vector<std::string> topics() {
    Result<std::vector<OutboxMessage>> batch = store().outbox_batch(1000);
    EXPECT_TRUE(batch.ok()) << batch.error().message;
    std::vector<std::string> out;
    if (batch.ok())
      for (const OutboxMessage& m : *batch) out.push_back(m.topic);
    return out;
  }
};

TEST_F(PlantStoreTest, EveryRunPushAndEventHasItsOwnUuid) {
  const std::int64_t a = add_run("2026-11-22T08:00:00Z");
  const std::int64_t b = add_run("2026-11-22T08:01:00Z");
  push(a);
  push(a);  // a second push of the same run: a new push, a new identity
  EventRecord e;
  e.code = "gauge timeout";
  e.message = "the gauge did not answer";
  ASSERT_TRUE(store().record_event(e).ok());

  std::set<std::string> seen;
  for (std::int64_t id : {a, b}) {
    Result<StoredRun> run = store().load_run(id);
    ASSERT_TRUE(run.ok()) << run.error().message;
    EXPECT_TRUE(is_uuid(run->summary.uuid)) << run->summary.uuid;
    seen.insert(run->summary.uuid);
    for (const NcPush& p : run->pushes) {
      EXPECT_TRUE(is_uuid(p.uuid)) << p.uuid;
      seen.insert(p.uuid);
    }
  }
  Result<std::vector<StoredEvent>> events = store().list_events(EventQuery{});
  ASSERT_TRUE(events.ok());
  ASSERT_EQ(events->size(), 1u);
  EXPECT_TRUE(is_uuid(events->front().event.uuid));
  seen.insert(events->front().event.uuid);
  EXPECT_EQ(seen.size(), 5u) << "2 runs, 2 pushes and 1 event, each its own";
}

TEST_F(PlantStoreTest, ARunKeepsTheUuidItWasGivenAndABadOneIsRefused) {
  RunRecord r = make_record("intake", "2026-11-22T08:00:00Z");
  r.uuid = "123e4567-e89b-42d3-a456-426614174000";
  Result<std::int64_t> id = store().insert_run(r);
  ASSERT_TRUE(id.ok()) << id.error().message;
  EXPECT_EQ(store().load_run(*id)->summary.uuid, r.uuid);

  Result<std::int64_t> again = store().insert_run(r);
  EXPECT_FALSE(again.ok()) << "two runs with one identity";

  r.uuid = "not-a-uuid";
  Result<std::int64_t> bad = store().insert_run(r);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("not a UUID"), std::string::npos) << bad.error().message;
  EXPECT_EQ(RawDb(db()).counts().runs, 1);
}

TEST_F(PlantStoreTest, ARowInsertedByHandGetsAUuidFromItsTrigger) {
  add_run("2026-11-22T08:00:00Z");
  RawDb raw(db());
  raw.exec("INSERT INTO events (at_utc, kind, code, message) VALUES ('2026-11-22T08:00:00Z', 'info', 'x', 'y')");
  const std::string u = raw.query_text("SELECT uuid FROM events ORDER BY id DESC LIMIT 1");
  EXPECT_TRUE(is_uuid(u)) << u;
}

TEST_F(PlantStoreTest, NothingIsQueuedUntilTheOutboxIsEnabled) {
  add_run("2026-11-22T08:00:00Z");
  EXPECT_TRUE(topics().empty());
  Result<std::int64_t> state = store().enqueue_state(R"({"state":"running"})");
  ASSERT_TRUE(state.ok());
  EXPECT_EQ(*state, 0) << "a state message with no broker configured would wait forever";
  EXPECT_EQ(store().outbox_counts()->depth, 0);
}

TEST_F(PlantStoreTest, ARunAndItsPushQueueTheirMessagesAndAVerdictChangeQueuesOne) {
  ASSERT_TRUE(store().configure_outbox({true, 1000}).ok());
  const std::int64_t first = add_run("2026-11-22T08:00:00Z", Verdict::kIn);  // first of the lobe: a change
  add_run("2026-11-22T08:01:00Z", Verdict::kIn);                             // same verdict: none
  const std::int64_t out = add_run("2026-11-22T08:02:00Z", Verdict::kOut);   // in -> out
  add_run("2026-11-22T08:03:00Z", Verdict::kOut, 2);                         // another lobe's first
  push(first);
  EXPECT_EQ(topics(), (std::vector<std::string>{"run", "verdict", "run", "run", "verdict", "run", "verdict", "nc"}));

  Result<std::vector<OutboxMessage>> batch = store().outbox_batch(100);
  ASSERT_TRUE(batch.ok());
  const OutboxMessage& change = (*batch)[4];
  EXPECT_EQ(change.run_id, out);
  EXPECT_NE(change.payload.find(R"("verdict":"out")"), std::string::npos) << change.payload;
  EXPECT_NE(change.payload.find(R"("previous_verdict":"in")"), std::string::npos) << change.payload;
  EXPECT_EQ(batch->back().push_id, store().load_run(first)->pushes.at(0).id);
  std::set<std::string> ids;
  for (const OutboxMessage& m : *batch) ids.insert(m.uuid);
  EXPECT_EQ(ids.size(), batch->size()) << "every message its own identity";
}

TEST_F(PlantStoreTest, ARunThatFailsToStoreQueuesNothing) {
  ASSERT_TRUE(store().configure_outbox({true, 1000}).ok());
  RunRecord r = make_record("intake", "2026-11-22T08:00:00Z");
  r.uuid = "123e4567-e89b-42d3-a456-426614174000";
  ASSERT_TRUE(store().insert_run(r).ok());
  ASSERT_FALSE(store().insert_run(r).ok());  // the same identity again: refused by the database
  EXPECT_EQ(topics(), (std::vector<std::string>{"run", "verdict"})) << "the refused run left a message";
}

TEST_F(PlantStoreTest, DeliveredMessagesLeaveAndAreCounted) {
  ASSERT_TRUE(store().configure_outbox({true, 1000}).ok());
  add_run("2026-11-22T08:00:00Z");
  ASSERT_GT(*store().enqueue_state(R"({"state":"running"})"), 0);
  Result<std::vector<OutboxMessage>> batch = store().outbox_batch(2);
  ASSERT_TRUE(batch.ok());
  ASSERT_EQ(batch->size(), 2u);
  ASSERT_TRUE(store().outbox_delivered({(*batch)[0].id, (*batch)[1].id, 999}).ok());
  Result<OutboxCounts> c = store().outbox_counts();
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->depth, 1);
  EXPECT_EQ(c->sent_total, 2) << "an id no longer waiting is not counted";
  EXPECT_EQ(topics(), std::vector<std::string>{"state"});
  EXPECT_FALSE(c->oldest_utc.empty());

  // A message that cannot be sent leaves counted dropped, not sent.
  ASSERT_TRUE(store().outbox_delivered({(*store().outbox_batch(1))[0].id}, RunStore::OutboxOutcome::kSkipped).ok());
  c = store().outbox_counts();
  ASSERT_TRUE(c.ok());
  EXPECT_EQ(c->depth, 0);
  EXPECT_EQ(c->sent_total, 2);
  EXPECT_EQ(c->dropped_total, 1);
}

TEST_F(PlantStoreTest, TheOutboxIsBoundedByDroppingTheOldestAndCountingIt) {
  ASSERT_TRUE(store().configure_outbox({true, 3}).ok());
  for (int i = 0; i < 5; ++i) ASSERT_GT(*store().enqueue_state("{\"n\":" + std::to_string(i) + "}"), 0);
  Result<std::vector<OutboxMessage>> batch = store().outbox_batch(10);
  ASSERT_TRUE(batch.ok());
  ASSERT_EQ(batch->size(), 3u);
  EXPECT_EQ(batch->front().payload, R"({"n":2})");
  Result<OutboxCounts> c = store().outbox_counts();
  EXPECT_EQ(c->depth, 3);
  EXPECT_EQ(c->dropped_total, 2);
  EXPECT_FALSE(store().configure_outbox({true, 0}).ok());
}

TEST_F(PlantStoreTest, ReplicationReadsEachTableInIdOrderFromWhereItStopped) {
  const std::int64_t a = add_run("2026-11-22T09:00:00Z");
  const std::int64_t b = add_run("2026-11-22T08:00:00Z");  // started earlier, stored later
  push(b);
  EventRecord e;
  e.code = "refused";
  e.message = "x";
  ASSERT_TRUE(store().record_event(e).ok());
  EXPECT_EQ(*store().run_ids_after(0, 10), (std::vector<std::int64_t>{a, b}));
  EXPECT_EQ(*store().run_ids_after(a, 10), std::vector<std::int64_t>{b});
  EXPECT_EQ(store().run_ids_after(0, 1)->size(), 1u);
  Result<std::vector<ReplicatedPush>> pushes = store().pushes_after(0, 10);
  ASSERT_TRUE(pushes.ok()) << pushes.error().message;
  ASSERT_EQ(pushes->size(), 1u);
  EXPECT_EQ(pushes->front().run_uuid, store().load_run(b)->summary.uuid);
  EXPECT_EQ(pushes->front().machine, "grinder-1");
  EXPECT_TRUE(is_uuid(pushes->front().push.uuid));
  EXPECT_EQ(store().events_after(0, 10)->size(), 1u);
  EXPECT_TRUE(store().events_after(store().events_after(0, 10)->front().id, 10)->empty());
  EXPECT_FALSE(store().run_ids_after(0, 0).ok());
}

TEST(PlantStoreMigration, Version9GivesEveryOlderRecordAUniqueUuid) {
  TempDir dir;
  const std::filesystem::path db = testing::db_in(dir);
  std::filesystem::create_directories(db.parent_path());
  {
    storage_internal::Connection conn;
    conn.path = db;
    ASSERT_EQ(sqlite3_open(db.c_str(), &conn.db), SQLITE_OK);
    ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, 8).ok());
    RawDb raw(db);
    for (int i = 0; i < 50; ++i) {
      raw.exec(
          "INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, status, revolutions,"
          " degrees_captured, zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um,"
          " repeatability_um) VALUES ('2026-11-22T08:00:00Z', '2026-11-22T08:01:00Z', 'g1', 'a', 1,"
          " 'tcp:sim', 'measured', 3, 1080, 0.0, 4.5, 1.0, 6.0, 0.5)");
    }
    raw.exec("INSERT INTO events (at_utc, kind, code, message) VALUES ('2026-11-22T08:00:00Z', 'info', 'plc', 'x')");
  }
  Result<RunStore> store = RunStore::open(db);
  ASSERT_TRUE(store.ok()) << store.error().message;
  RawDb raw(db);
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_int("SELECT count(DISTINCT uuid) FROM runs"), 50);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM runs WHERE uuid LIKE '________-____-4___-____-____________'"
                          " AND substr(uuid, 20, 1) IN ('8', '9', 'a', 'b') AND uuid = lower(uuid)"),
            50);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM events WHERE uuid IS NOT NULL"), 1);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM outbox"), 0) << "old records are history, not news";
}

}  // namespace
}  // namespace gaugeloop
