// The plant's broker messages without a broker: the topic tree, the checks of its levels, and
// each payload rendered from the run database's outbox.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "core/uuid.h"
#include "plant/plant_messages.h"
#include "storage/run_store.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using nlohmann::json;

TEST(PlantTopics, AreGaugeloopSiteMachineKind) {
  EXPECT_EQ(plant_topic("plant-a", "grinder-1", "run"), "gaugeloop/plant-a/grinder-1/run");
  EXPECT_EQ(plant_topic("plant-a", "grinder-1", "state"), "gaugeloop/plant-a/grinder-1/state");
}

TEST(PlantTopics, ALevelWithASeparatorOrWildcardIsRefusedNamingTheKey) {
  EXPECT_TRUE(check_topic_level("[plant.mqtt] site", "plant-a").ok());
  for (const char* bad : {"plant/a", "plant+", "#", ""}) {
    const Status s = check_topic_level("[plant.mqtt] site", bad);
    ASSERT_FALSE(s.ok()) << bad;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(s.error().message.find("[plant.mqtt] site"), std::string::npos) << s.error().message;
  }
  const Status slash = check_topic_level("machine", "cell/2");
  ASSERT_FALSE(slash.ok());
  EXPECT_NE(slash.error().message.find("'/'"), std::string::npos) << slash.error().message;
}

class PlantMessagesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Result<RunStore> s = RunStore::open(dir_ / "runs.sqlite");
    ASSERT_TRUE(s.ok()) << s.error().message;
    store_.emplace(std::move(*s));
    ASSERT_TRUE(store_->configure_outbox({true, 1000}).ok());
  }
  std::vector<OutboxMessage> waiting() {
    Result<std::vector<OutboxMessage>> b = store_->outbox_batch(100);
    EXPECT_TRUE(b.ok()) << b.error().message;
    return b.ok() ? *b : std::vector<OutboxMessage>{};
  }
  json render(const OutboxMessage& m) {
    Result<std::optional<PlantMessage>> r = render_message(*store_, m, "plant-a", "grinder-1");
    EXPECT_TRUE(r.ok()) << r.error().message;
    if (!r.ok() || !r->has_value()) return json();
    EXPECT_EQ((*r)->topic, "gaugeloop/plant-a/grinder-1/" + m.topic);
    EXPECT_FALSE((*r)->retain);
    return json::parse((*r)->payload);
  }

  testing::TempDir dir_;
  std::optional<RunStore> store_;
};

TEST_F(PlantMessagesTest, ARunIsItsRunsShowJsonWithTheMessageUuid) {
  Result<std::int64_t> id =
      store_->insert_run(testing::sample_run("intake", 1, "grinder-1", "2026-11-22T08:00:00Z", 4.0));
  ASSERT_TRUE(id.ok()) << id.error().message;
  const std::vector<OutboxMessage> rows = waiting();
  ASSERT_EQ(rows.size(), 2u) << "the run and its lobe's first verdict";
  const OutboxMessage& run_row = rows[0].topic == "run" ? rows[0] : rows[1];
  const OutboxMessage& verdict_row = rows[0].topic == "run" ? rows[1] : rows[0];
  ASSERT_EQ(run_row.topic, "run");
  ASSERT_EQ(verdict_row.topic, "verdict");

  const json run = render(run_row);
  Result<StoredRun> stored = store_->load_run(*id);
  ASSERT_TRUE(stored.ok());
  EXPECT_EQ(run["uuid"], stored->summary.uuid);
  EXPECT_EQ(run["message_uuid"], run_row.uuid);
  EXPECT_NE(run["uuid"], run["message_uuid"]);
  EXPECT_EQ(run["id"], *id);
  EXPECT_EQ(run["machine"], "grinder-1");
  EXPECT_EQ(run["part"], "intake");
  EXPECT_DOUBLE_EQ(run["max_abs_error_um"].get<double>(), 4.0);
  for (const char* key : {"characteristics", "verdict", "nc_pushes", "part_kind", "finished_utc", "settings"}) {
    EXPECT_TRUE(run.contains(key)) << key;
  }

  const json verdict = render(verdict_row);
  EXPECT_EQ(verdict["run_uuid"], stored->summary.uuid);
  EXPECT_EQ(verdict["message_uuid"], verdict_row.uuid);
  EXPECT_EQ(verdict["verdict"], "not_judged");
  EXPECT_EQ(verdict["machine"], "grinder-1");
}

TEST_F(PlantMessagesTest, APushIsItsNcHistoryJsonWithMachineAndRunUuid) {
  Result<std::int64_t> id =
      store_->insert_run(testing::sample_run("intake", 1, "grinder-7", "2026-11-22T08:00:00Z", 4.0));
  ASSERT_TRUE(id.ok());
  ASSERT_TRUE(store_->outbox_delivered({waiting()[0].id, waiting()[1].id}).ok());
  NcPush p;
  p.nc_file = "/nc/INTAKE.SPF";
  ASSERT_TRUE(store_->record_push(*id, p, "CTABDEF(X,C,1,1)\nCTABEND\n").ok());
  const std::vector<OutboxMessage> rows = waiting();
  ASSERT_EQ(rows.size(), 1u);
  ASSERT_EQ(rows[0].topic, "nc");
  const json nc = render(rows[0]);
  Result<StoredRun> stored = store_->load_run(*id);
  ASSERT_TRUE(stored.ok());
  ASSERT_EQ(stored->pushes.size(), 1u);
  EXPECT_EQ(nc["uuid"], stored->pushes[0].uuid);
  EXPECT_EQ(nc["run_uuid"], stored->summary.uuid);
  EXPECT_EQ(nc["machine"], "grinder-7");
  EXPECT_EQ(nc["table_version"], 1);
  EXPECT_EQ(nc["nc_file"], "/nc/INTAKE.SPF");
  EXPECT_EQ(nc["message_uuid"], rows[0].uuid);
}

// A program written from the drawing (nc new) has no run: its message is the push with this
// machine's name and no run UUID, not a message dropped.
TEST_F(PlantMessagesTest, APushWithNoRunIsSentWithTheMachineAndNoRunUuid) {
  NcPush p;
  p.nc_file = "/nc/INTAKE.SPF";
  p.reason = "new program from intake.toml by anna";
  ASSERT_TRUE(store_->record_push(0, p, "CTABDEF(X,C,1,1)\nCTABEND\n").ok());
  const std::vector<OutboxMessage> rows = waiting();
  ASSERT_EQ(rows.size(), 1u);
  ASSERT_EQ(rows[0].topic, "nc");
  EXPECT_EQ(rows[0].run_id, 0);
  const json nc = render(rows[0]);
  EXPECT_EQ(nc["machine"], "grinder-1");
  EXPECT_TRUE(nc["run_uuid"].is_null());
  EXPECT_EQ(nc["table_version"], 1);
  EXPECT_EQ(nc["reason"], "new program from intake.toml by anna");
  EXPECT_EQ(nc["message_uuid"], rows[0].uuid);
}

TEST_F(PlantMessagesTest, AStateIsItsStoredPayload) {
  Result<std::int64_t> id = store_->enqueue_state(state_payload("grinder-1", "started", "version 1"));
  ASSERT_TRUE(id.ok());
  const std::vector<OutboxMessage> rows = waiting();
  ASSERT_EQ(rows.size(), 1u);
  const json state = render(rows[0]);
  EXPECT_EQ(state["state"], "started");
  EXPECT_EQ(state["machine"], "grinder-1");
  EXPECT_EQ(state["detail"], "version 1");
  EXPECT_TRUE(state["at_utc"].is_string());
}

TEST_F(PlantMessagesTest, AMessageWhoseRunIsGoneIsEmpty) {
  OutboxMessage gone;
  gone.id = 99;
  gone.uuid = new_uuid();
  gone.topic = "run";
  gone.run_id = 12345;
  Result<std::optional<PlantMessage>> r = render_message(*store_, gone, "plant-a", "grinder-1");
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->has_value());
  gone.topic = "nc";
  gone.push_id = 3;
  r = render_message(*store_, gone, "plant-a", "grinder-1");
  ASSERT_TRUE(r.ok());
  EXPECT_FALSE(r->has_value());
}

TEST_F(PlantMessagesTest, AStoredPayloadThatIsNotAnObjectIsRefused) {
  OutboxMessage bad;
  bad.id = 7;
  bad.uuid = new_uuid();
  bad.topic = "state";
  bad.payload = "not json";
  Result<std::optional<PlantMessage>> r = render_message(*store_, bad, "plant-a", "grinder-1");
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("outbox message 7"), std::string::npos) << r.error().message;
}

TEST_F(PlantMessagesTest, ANoteThatIsNotUtf8IsSentWithAReplacementCharacter) {
  RunRecord r = testing::sample_run("intake", 1, "grinder-1", "2026-11-22T08:00:00Z", 4.0);
  r.note = "wheel \xff dressed";
  ASSERT_TRUE(store_->insert_run(r).ok());
  for (const OutboxMessage& m : waiting()) {
    if (m.topic != "run") continue;
    const json run = render(m);
    EXPECT_EQ(run["note"], "wheel \xEF\xBF\xBD dressed");
  }
}

}  // namespace
}  // namespace gaugeloop
