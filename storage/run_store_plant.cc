// The plant side of the run database (schema 9): the outbox of broker messages and reading
// records in id order for replication to the central history. docs/plant.md.
#include <string>
#include <utility>
#include <vector>

#include "core/utc_time.h"
#include "core/uuid.h"
#include "storage/run_store.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::Connection;
using storage_internal::Statement;
using storage_internal::Transaction;

namespace {

Status check_limit(int limit, std::string_view what) {
  if (limit >= 1) return {};
  return make_error(ErrorCode::kInvalidInput,
                    "cannot read " + std::string(what) + ": limit " + std::to_string(limit) + " is not 1 or more");
}

OutboxMessage read_message(const Statement& s) {
  OutboxMessage m;
  m.id = s.column<std::int64_t>(0);
  m.uuid = s.column<std::string>(1);
  m.topic = s.column<std::string>(2);
  m.run_id = s.column<std::optional<std::int64_t>>(3).value_or(0);
  m.push_id = s.column<std::optional<std::int64_t>>(4).value_or(0);
  m.created_utc = s.column<std::string>(5);
  m.payload = s.column<std::string>(6);  // NULL reads as ""
  return m;
}

}  // namespace

Status RunStore::configure_outbox(const OutboxSettings& settings) {
  if (settings.max_depth < 1) {
    return make_error(ErrorCode::kInvalidInput, "the outbox bound " + std::to_string(settings.max_depth) +
                                                    " is not 1 or more; give max_depth in [plant.mqtt]");
  }
  Result<Statement> st =
      Statement::prepare(*conn_, "UPDATE outbox_state SET enabled = :enabled, max_depth = :max_depth WHERE id = 1",
                         "configure the outbox");
  if (!st.ok()) return st.error();
  st->bind(":enabled", settings.enabled ? 1 : 0);
  st->bind(":max_depth", settings.max_depth);
  return st->run();
}

Result<std::vector<OutboxMessage>> RunStore::outbox_batch(int limit) const {
  if (Status s = check_limit(limit, "the outbox"); !s.ok()) return s.error();
  Result<Statement> st = Statement::prepare(
      *conn_, "SELECT id, uuid, topic, run_id, push_id, created_utc, payload FROM outbox ORDER BY id LIMIT :limit",
      "read the outbox");
  if (!st.ok()) return st.error();
  st->bind(":limit", limit);
  return st->collect(read_message);
}

Status RunStore::outbox_delivered(const std::vector<std::int64_t>& ids, OutboxOutcome outcome) {
  if (ids.empty()) return {};
  const bool as_sent = outcome == OutboxOutcome::kSent;
  const std::string operation = as_sent ? "mark outbox messages sent" : "drop outbox messages that cannot be sent";
  Result<Transaction> tx = Transaction::begin(*conn_, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> del = Statement::prepare(*conn_, "DELETE FROM outbox WHERE id = :id", operation);
  if (!del.ok()) return del.error();
  std::int64_t deleted = 0;
  for (std::int64_t id : ids) {
    del->reset();
    del->bind(":id", id);
    if (Status s = del->run(); !s.ok()) return s;
    deleted += conn_->changes();
  }
  Result<Statement> count =
      Statement::prepare(*conn_,
                         as_sent ? "UPDATE outbox_state SET sent_total = sent_total + :count WHERE id = 1"
                                 : "UPDATE outbox_state SET dropped_total = dropped_total + :count WHERE id = 1",
                         operation);
  if (!count.ok()) return count.error();
  count->bind(":count", deleted);
  if (Status s = count->run(); !s.ok()) return s;
  return tx->commit();
}

Result<std::int64_t> RunStore::enqueue_state(const std::string& payload_json) {
  if (payload_json.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot queue a state message without a payload");
  }
  Result<Statement> st = Statement::prepare(*conn_,
                                            "INSERT INTO outbox (uuid, topic, created_utc, payload) "
                                            "SELECT :uuid, 'state', :created_utc, :payload FROM outbox_state "
                                            "WHERE id = 1 AND enabled",
                                            "queue a state message");
  if (!st.ok()) return st.error();
  st->bind(":uuid", std::string_view(new_uuid()));
  st->bind(":created_utc", std::string_view(utc_now()));
  st->bind(":payload", payload_json);
  if (Status s = st->run(); !s.ok()) return s.error();
  return conn_->changes() == 0 ? std::int64_t{0} : conn_->last_insert_rowid();
}

Result<OutboxCounts> RunStore::outbox_counts() const {
  Result<Statement> st =
      Statement::prepare(*conn_,
                         "SELECT enabled, max_depth, depth, sent_total, dropped_total, "
                         "(SELECT created_utc FROM outbox ORDER BY id LIMIT 1) FROM outbox_state WHERE id = 1",
                         "read the outbox counts");
  if (!st.ok()) return st.error();
  Result<std::optional<OutboxCounts>> row = st->first([](const Statement& s) {
    OutboxCounts c;
    c.settings.enabled = s.column<bool>(0);
    c.settings.max_depth = s.column<std::int64_t>(1);
    c.depth = s.column<std::int64_t>(2);
    c.sent_total = s.column<std::int64_t>(3);
    c.dropped_total = s.column<std::int64_t>(4);
    c.oldest_utc = s.column<std::string>(5);
    return c;
  });
  if (!row.ok()) return row.error();
  return row->value_or(OutboxCounts{});
}

Result<std::vector<std::int64_t>> RunStore::run_ids_after(std::int64_t after_id, int limit) const {
  if (Status s = check_limit(limit, "runs to replicate"); !s.ok()) return s.error();
  Result<Statement> st = Statement::prepare(*conn_, "SELECT id FROM runs WHERE id > :after ORDER BY id LIMIT :limit",
                                            "read runs to replicate");
  if (!st.ok()) return st.error();
  st->bind(":after", after_id);
  st->bind(":limit", limit);
  return st->collect([](const Statement& s) { return s.column<std::int64_t>(0); });
}

Result<std::vector<PrunedRun>> RunStore::runs_pruned_after(const std::string& after_utc, std::int64_t after_id,
                                                           int limit) const {
  if (Status s = check_limit(limit, "pruned runs"); !s.ok()) return s.error();
  // (raw_pruned_utc, id) > (after_utc, after_id) as the index orders them: runs_by_raw_pruned.
  Result<Statement> st =
      Statement::prepare(*conn_,
                         "SELECT id, uuid, raw_pruned_utc FROM runs WHERE raw_pruned_utc IS NOT NULL"
                         " AND (raw_pruned_utc, id) > (:after_utc, :after_id) ORDER BY raw_pruned_utc, id LIMIT :limit",
                         "read the pruned runs");
  if (!st.ok()) return st.error();
  st->bind(":after_utc", after_utc);
  st->bind(":after_id", after_id);
  st->bind(":limit", limit);
  return st->collect([](const Statement& s) {
    return PrunedRun{s.column<std::int64_t>(0), s.column<std::string>(1), s.column<std::string>(2)};
  });
}

Result<std::set<std::string>> RunStore::runs_here(const std::vector<std::string>& uuids) const {
  Result<Statement> st = Statement::prepare(*conn_, "SELECT 1 FROM runs WHERE uuid = :uuid", "look runs up by UUID");
  if (!st.ok()) return st.error();
  std::set<std::string> here;
  for (const std::string& uuid : uuids) {
    st->reset();
    st->bind(":uuid", uuid);
    Result<bool> row = st->step();
    if (!row.ok()) return row.error();
    if (*row) here.insert(uuid);
  }
  return here;
}

Result<std::vector<ReplicatedPush>> RunStore::pushes_after(std::int64_t after_id, int limit, bool program_text) const {
  if (Status s = check_limit(limit, "pushes to replicate"); !s.ok()) return s.error();
  Result<Statement> st = Statement::prepare(*conn_,
                                            "SELECT " + std::string(storage_internal::kPushColumns) +
                                                (program_text ? ", p.program_text" : ", NULL") +
                                                ", r.uuid, r.machine FROM nc_pushes AS p JOIN runs AS r "
                                                "ON r.id = p.run_id WHERE p.id > :after ORDER BY p.id LIMIT :limit",
                                            "read pushes to replicate");
  if (!st.ok()) return st.error();
  st->bind(":after", after_id);
  st->bind(":limit", limit);
  return st->collect([program_text](const Statement& s) {
    ReplicatedPush p;
    p.push = storage_internal::read_push(s, program_text);
    p.run_uuid = s.column<std::string>(14);
    p.machine = s.column<std::string>(15);
    return p;
  });
}

}  // namespace gaugeloop
