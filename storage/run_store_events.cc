// RunStore's events: the faults, refusals and service steps worth keeping.
#include <utility>

#include "core/utc_time.h"
#include "core/uuid.h"
#include "storage/record_checks.h"
#include "storage/run_store.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::bad_bound;
using storage_internal::Connection;
using storage_internal::Statement;

namespace {

constexpr std::string_view kInsertEvent = R"sql(
INSERT INTO events (at_utc, kind, code, machine, part, lobe, run_id, message, uuid)
VALUES (:at_utc, :kind, :code, :machine, :part, :lobe, :run_id, :message, :uuid))sql";

Status check_event(const EventRecord& event) {
  if (event.message.empty() || event.code.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot record an event without a code and a message");
  }
  if (!event.at_utc.empty() && !is_utc_timestamp(event.at_utc)) {
    return bad_bound("cannot record an event: at_utc", event.at_utc);
  }
  if (event.lobe < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot record an event: lobe " + std::to_string(event.lobe) + " is negative (0: no lobe)");
  }
  return {};
}

EventKind event_kind_from_db(std::string_view name) {
  if (name == "refusal") return EventKind::kRefusal;
  if (name == "info") return EventKind::kInfo;
  return EventKind::kFault;
}

constexpr std::string_view kEventColumns = "id, at_utc, kind, code, machine, part, lobe, run_id, message, uuid";

StoredEvent read_event(const Statement& s) {
  StoredEvent e;
  e.id = s.column<std::int64_t>(0);
  e.event.at_utc = s.column<std::string>(1);
  e.event.kind = event_kind_from_db(s.column<std::string>(2));
  e.event.code = s.column<std::string>(3);
  e.event.machine = s.column<std::string>(4);
  e.event.part = s.column<std::string>(5);
  e.event.lobe = s.column<std::optional<int>>(6).value_or(0);
  e.event.run_id = s.column<std::optional<std::int64_t>>(7);
  e.event.message = s.column<std::string>(8);
  e.event.uuid = s.column<std::string>(9);
  return e;
}

}  // namespace

namespace {

// Binds `event` to the prepared insert.
void bind_event(Statement& ins, const EventRecord& event) {
  ins.bind(":at_utc", std::string_view(event.at_utc.empty() ? utc_now() : event.at_utc));
  ins.bind(":kind", event_kind_name(event.kind));
  ins.bind(":code", event.code);
  ins.bind(":machine", event.machine);
  ins.bind(":part", event.part);
  ins.bind(":lobe", event.lobe > 0 ? std::optional<int>(event.lobe) : std::nullopt);
  ins.bind(":run_id", event.run_id);
  ins.bind(":message", event.message);
  ins.bind(":uuid", std::string_view(event.uuid.empty() ? new_uuid() : event.uuid));
}

}  // namespace

Result<std::int64_t> RunStore::record_event(const EventRecord& event) {
  if (Status s = check_event(event); !s.ok()) return s.error();
  Connection& conn = *conn_;
  const std::string operation = "record a " + std::string(event_kind_name(event.kind)) + " event";
  Result<Statement> ins = Statement::prepare(conn, kInsertEvent, operation);
  if (!ins.ok()) return ins.error();
  bind_event(*ins, event);
  if (Status s = ins->run(); !s.ok()) return s.error();
  return conn.last_insert_rowid();
}

Status RunStore::record_events(const std::vector<EventRecord>& events) {
  for (std::size_t i = 0; i < events.size(); ++i) {
    if (Status s = check_event(events[i]); !s.ok()) {
      Error e = s.error();
      e.message = "event " + std::to_string(i + 1) + " of " + std::to_string(events.size()) + ": " + e.message +
                  "; none of them was recorded";
      return e;
    }
  }
  Connection& conn = *conn_;
  const std::string operation = "record " + std::to_string(events.size()) + " events";
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> ins = Statement::prepare(conn, kInsertEvent, operation);
  if (!ins.ok()) return ins.error();
  for (const EventRecord& event : events) {
    bind_event(*ins, event);
    if (Status s = ins->run(); !s.ok()) return s.error();
    ins->reset();
  }
  return tx->commit();
}

Result<std::vector<StoredEvent>> RunStore::list_events(const EventQuery& q) const {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list events: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  if (!storage_internal::is_time_bound(q.since_utc)) return bad_bound("cannot list events: since", q.since_utc);
  if (!storage_internal::is_time_bound(q.until_utc)) return bad_bound("cannot list events: until", q.until_utc);
  storage_internal::WhereClause where;
  if (!q.machine.empty()) where.add("machine =", q.machine);
  if (!q.part.empty()) where.add("part =", q.part);
  if (q.kind) where.add("kind =", std::string(event_kind_name(*q.kind)));
  if (!q.since_utc.empty()) where.add("at_utc >=", q.since_utc);
  if (!q.until_utc.empty()) where.add("at_utc <", q.until_utc);
  Result<Statement> st = Statement::prepare(*conn_,
                                            "SELECT " + std::string(kEventColumns) + " FROM events" + where.sql() +
                                                " ORDER BY at_utc DESC, id DESC LIMIT :limit",
                                            "list events");
  if (!st.ok()) return st.error();
  st->bind(":limit", q.limit);
  where.bind(*st);
  return st->collect(read_event);
}

Result<std::vector<StoredEvent>> RunStore::events_after(std::int64_t after_id, int limit) const {
  if (limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot read events to replicate: limit " + std::to_string(limit) + " is not 1 or more");
  }
  // The run's UUID beside its local id (a correlated lookup by primary key: one row a event).
  Result<Statement> st = Statement::prepare(*conn_,
                                            "SELECT " + std::string(kEventColumns) +
                                                ", (SELECT r.uuid FROM runs AS r WHERE r.id = events.run_id) "
                                                "FROM events WHERE id > :after ORDER BY id LIMIT :limit",
                                            "read events to replicate");
  if (!st.ok()) return st.error();
  st->bind(":after", after_id);
  st->bind(":limit", limit);
  return st->collect([](const Statement& row) {
    StoredEvent e = read_event(row);
    e.run_uuid = row.column<std::optional<std::string>>(10).value_or("");
    return e;
  });
}

std::string_view event_kind_name(EventKind kind) {
  switch (kind) {
    case EventKind::kFault:
      return "fault";
    case EventKind::kRefusal:
      return "refusal";
    case EventKind::kInfo:
      return "info";
  }
  return "fault";
}

EventKind event_kind_for(ErrorCode code) {
  return code == ErrorCode::kRefused ? EventKind::kRefusal : EventKind::kFault;
}

}  // namespace gaugeloop
