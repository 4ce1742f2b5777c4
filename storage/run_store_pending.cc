// RunStore's pending tables: rendered NC programs kept until a person approves (writes) or
// rejects them, and those decisions.
#include <utility>

#include "core/utc_time.h"
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

// Columns 0..19, read by read_pending(); program_text is column 4 ('' in lists) and
// speed_program_text column 19 (NULL in lists).
constexpr std::string_view kPendingColumns =
    "id, run_id, created_utc, nc_file, {text}, verdict, reason, interpolation, block_count, command_error_um, "
    "point_count, correction_max_um, status, decided_utc, decided_by, note, push_id, superseded_by, gear_run_id, "
    "{speed}";

constexpr std::string_view kInsertPending = R"sql(
INSERT INTO nc_pending (run_id, gear_run_id, created_utc, nc_file, program_text, speed_program_text, verdict, reason,
                        interpolation, block_count, command_error_um, correction_max_um, point_count)
VALUES (:run_id, :gear_run_id, :created_utc, :nc_file, :program_text, :speed_program_text, :verdict, :reason,
        :interpolation, :block_count, :command_error_um, :correction_max_um, :point_count))sql";

std::string select_pending(bool with_text, std::string_view rest) {
  std::string columns(kPendingColumns);
  columns.replace(columns.find("{text}"), 6, with_text ? "program_text" : "''");
  columns.replace(columns.find("{speed}"), 7, with_text ? "speed_program_text" : "NULL");
  return "SELECT " + columns + " FROM nc_pending" + std::string(rest);
}

std::optional<PendingStatus> pending_status_from_db(std::string_view name) {
  for (PendingStatus st :
       {PendingStatus::kPending, PendingStatus::kApproved, PendingStatus::kRejected, PendingStatus::kSuperseded}) {
    if (pending_status_name(st) == name) return st;
  }
  return std::nullopt;
}

PendingTable read_pending(const Statement& s) {
  PendingTable t;
  t.id = s.column<std::int64_t>(0);
  t.run_id = s.column<std::int64_t>(1);
  t.created_utc = s.column<std::string>(2);
  t.nc_file = storage_internal::nc_path_column(s, 3);
  t.program_text = s.column<std::string>(4);
  t.verdict = s.column<std::string>(5) == "hold" ? PendingVerdict::kHold : PendingVerdict::kApply;
  t.reason = s.column<std::string>(6);
  t.table = storage_internal::read_table_facts(s, 7);
  // The schema's CHECK admits only the four names.
  t.status = pending_status_from_db(s.column<std::string>(12)).value_or(PendingStatus::kPending);
  t.decided_utc = s.column<std::string>(13);
  t.decided_by = s.column<std::string>(14);
  t.note = s.column<std::string>(15);
  t.push_id = s.column<std::optional<std::int64_t>>(16);
  t.superseded_by = s.column<std::optional<std::int64_t>>(17);
  t.gear_run_id = s.column<std::optional<std::int64_t>>(18).value_or(0);
  t.speed_program_text = s.column<std::optional<std::string>>(19);
  return t;
}

std::string pending_what(std::int64_t id) { return "pending table " + std::to_string(id); }

// Reads one pending table inside the caller's transaction; kNotFound if absent.
Result<PendingTable> read_one_pending(Connection& conn, std::int64_t id, bool with_text, const std::string& operation) {
  Result<Statement> q = Statement::prepare(conn, select_pending(with_text, " WHERE id = :id"), operation);
  if (!q.ok()) return q.error();
  q->bind(":id", id);
  Result<std::optional<PendingTable>> t = q->first(read_pending);
  if (!t.ok()) return t.error();
  if (!*t) {
    return make_error(ErrorCode::kNotFound, "cannot " + operation + ": " + pending_what(id) +
                                                " is not in run database " + conn.path.string());
  }
  return std::move(**t);
}

// kRefused for a table that left kPending, saying how and when.
Status require_pending(const PendingTable& t, const std::string& operation) {
  if (t.status == PendingStatus::kPending) return {};
  std::string how = "it is already " + std::string(pending_status_name(t.status));
  switch (t.status) {
    case PendingStatus::kApproved:
    case PendingStatus::kRejected:
      how += " (by " + t.decided_by + " at " + t.decided_utc + ")";
      break;
    case PendingStatus::kSuperseded:
      how += " by the newer " + (t.superseded_by ? pending_what(*t.superseded_by) : std::string("pending table")) +
             " at " + t.decided_utc + "; only the newest measurement can be approved";
      break;
    case PendingStatus::kPending:
      break;
  }
  return make_error(ErrorCode::kRefused, "cannot " + operation + ": " + how + "; nothing was changed");
}

// "run 12", or "gear run 3" for a gear's stroke.
std::string pending_source(const PendingTable& table) {
  return table.gear_run_id != 0 ? "gear run " + std::to_string(table.gear_run_id)
                                : "run " + std::to_string(table.run_id);
}

Status check_pending(const PendingTable& table) {
  const std::string what = "cannot keep a pending table for " + pending_source(table);
  if (table.gear_run_id != 0 && table.run_id != 0) {
    return make_error(ErrorCode::kInvalidInput, what + ": it names run " + std::to_string(table.run_id) +
                                                    " too; a table comes from a lobe run or a gear run, not both");
  }
  if (table.nc_file.empty()) return make_error(ErrorCode::kInvalidInput, what + ": the NC file path is empty");
  if (table.program_text.empty()) {
    return make_error(ErrorCode::kInvalidInput, what + " (" + table.nc_file + "): the program text is empty");
  }
  if (table.speed_program_text && table.speed_program_text->empty()) {
    return make_error(ErrorCode::kInvalidInput, what + " (" + table.nc_file + "): the speed program text is empty");
  }
  if (!table.created_utc.empty() && !is_utc_timestamp(table.created_utc)) {
    return storage_internal::bad_bound(what + ": created_utc", table.created_utc);
  }
  return storage_internal::check_table_figures(what + " (" + table.nc_file + ")", table.table);
}

// The table still pending for `nc_file`, if any (at most one: nc_pending_one_per_file), is
// marked superseded at `created`; returns its id.
Result<std::optional<std::int64_t>> supersede_pending(Connection& conn, const std::string& nc_file,
                                                      const std::string& created, const std::string& operation) {
  Result<Statement> q =
      Statement::prepare(conn, "SELECT id FROM nc_pending WHERE nc_file = :nc_file AND status = 'pending'", operation);
  if (!q.ok()) return q.error();
  q->bind(":nc_file", storage_internal::nc_key(conn, nc_file));
  Result<std::optional<std::int64_t>> older = q->first([](const Statement& s) { return s.column<std::int64_t>(0); });
  if (!older.ok() || !*older) return older;
  Result<Statement> sup = Statement::prepare(
      conn, "UPDATE nc_pending SET status = 'superseded', decided_utc = :decided_utc WHERE id = :id", operation);
  if (!sup.ok()) return sup.error();
  sup->bind(":id", **older);
  sup->bind(":decided_utc", created);
  if (Status s = sup->run(); !s.ok()) return s.error();
  return older;
}

Result<std::int64_t> insert_pending(Connection& conn, const PendingTable& table, const std::string& created,
                                    const std::string& operation) {
  Result<Statement> ins = Statement::prepare(conn, kInsertPending, operation);
  if (!ins.ok()) return ins.error();
  ins->bind(":run_id", table.gear_run_id != 0 ? std::nullopt : std::optional<std::int64_t>(table.run_id));
  ins->bind(":gear_run_id", table.gear_run_id != 0 ? std::optional<std::int64_t>(table.gear_run_id) : std::nullopt);
  ins->bind(":created_utc", created);
  ins->bind(":nc_file", storage_internal::nc_key(conn, table.nc_file));
  ins->bind(":program_text", table.program_text);
  ins->bind(":speed_program_text", table.speed_program_text);
  ins->bind(":verdict", pending_verdict_name(table.verdict));
  ins->bind(":reason", table.reason);
  storage_internal::bind_table_facts(*ins, table.table);
  if (Status s = ins->run(); !s.ok()) return s.error();
  return conn.last_insert_rowid();
}

// kNotFound unless gear run `id` is stored.
Status require_gear_run(Connection& conn, std::int64_t id, const std::string& operation) {
  Result<Statement> q = Statement::prepare(conn, "SELECT 1 FROM gear_runs WHERE id = :id", operation);
  if (!q.ok()) return q.error();
  q->bind(":id", id);
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  if (*row) return {};
  return make_error(ErrorCode::kNotFound, "cannot " + operation + ": gear run " + std::to_string(id) +
                                              " is not in run database " + conn.path.string());
}

}  // namespace

Result<std::int64_t> RunStore::add_pending(const PendingTable& table) {
  if (Status s = check_pending(table); !s.ok()) return s.error();
  const std::string created = table.created_utc.empty() ? utc_now() : table.created_utc;
  Connection& conn = *conn_;
  const std::string operation = "keep the table of " + pending_source(table) + " for " + table.nc_file + " pending";
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  if (table.gear_run_id != 0) {
    if (Status s = require_gear_run(conn, table.gear_run_id, operation); !s.ok()) return s.error();
  } else if (Status s = storage_internal::require_run(conn, table.run_id, operation); !s.ok()) {
    return s.error();
  }
  if (Status s = storage_internal::note_nc_directory(conn, table.nc_file, operation); !s.ok()) return s.error();
  // The older pending table steps aside before the new row goes in (the unique index allows
  // one pending table per file), and learns the new id after.
  Result<std::optional<std::int64_t>> older = supersede_pending(conn, table.nc_file, created, operation);
  if (!older.ok()) return older.error();
  Result<std::int64_t> id = insert_pending(conn, table, created, operation);
  if (!id.ok()) return id.error();
  if (*older) {
    Result<Statement> link =
        Statement::prepare(conn, "UPDATE nc_pending SET superseded_by = :superseded_by WHERE id = :id", operation);
    if (!link.ok()) return link.error();
    link->bind(":id", **older);
    link->bind(":superseded_by", *id);
    if (Status s = link->run(); !s.ok()) return s.error();
  }
  if (Status s = tx->commit(); !s.ok()) return s.error();
  return id;
}

Result<std::vector<PendingTable>> RunStore::list_pending(const PendingQuery& q) const {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list pending tables: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  storage_internal::WhereClause where;
  if (q.status) where.add("status =", std::string(pending_status_name(*q.status)));
  if (!q.nc_file.empty()) where.add("nc_file =", storage_internal::nc_key(*conn_, q.nc_file));
  Result<Statement> st = Statement::prepare(
      *conn_, select_pending(false, where.sql() + " ORDER BY id DESC LIMIT :limit"), "list pending tables");
  if (!st.ok()) return st.error();
  st->bind(":limit", q.limit);
  where.bind(*st);
  return st->collect(read_pending);
}

Result<PendingTable> RunStore::load_pending(std::int64_t id) const {
  return read_one_pending(*conn_, id, true, "load " + pending_what(id));
}

Status RunStore::reject_pending(std::int64_t id, const std::string& by, const std::string& note) {
  const std::string operation = "reject " + pending_what(id);
  if (by.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": say who rejects it (the name is empty)");
  }
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<PendingTable> t = read_one_pending(conn, id, false, operation);
  if (!t.ok()) return t.error();
  if (Status s = require_pending(*t, operation + " for " + t->nc_file); !s.ok()) return s;
  Result<Statement> upd = Statement::prepare(conn,
                                             "UPDATE nc_pending SET status = 'rejected', decided_utc = :decided_utc,"
                                             " decided_by = :decided_by, note = :note WHERE id = :id",
                                             operation);
  if (!upd.ok()) return upd.error();
  upd->bind(":id", id);
  upd->bind(":decided_utc", std::string_view(utc_now()));
  upd->bind(":decided_by", by);
  upd->bind(":note", note);
  if (Status s = upd->run(); !s.ok()) return s;
  return tx->commit();
}

namespace storage_internal {
namespace {

// The push as approving `t` records it: the fields left unset come from the table.
NcPush approved_push(const NcPush& push, const PendingTable& t, const std::string& by) {
  NcPush full = push;
  full.nc_file = t.nc_file;
  if (full.reason.empty()) full.reason = "approved by " + by;
  TableFacts& f = full.table;
  if (f.interpolation.empty()) f.interpolation = t.table.interpolation;
  if (!f.block_count) f.block_count = t.table.block_count;
  if (!f.command_error_um) f.command_error_um = t.table.command_error_um;
  if (!f.correction_max_um) f.correction_max_um = t.table.correction_max_um;
  if (!f.point_count) f.point_count = t.table.point_count;
  if (!full.program_text || full.program_text->empty()) full.program_text = t.program_text;
  return full;
}

}  // namespace

Result<std::int64_t> approve_in_transaction(Connection& conn, std::int64_t pending_id, const NcPush& push,
                                            const std::string& by, const std::string& note,
                                            const std::string& operation) {
  if (by.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": say who approves it (the name is empty)");
  }
  Result<PendingTable> t = read_one_pending(conn, pending_id, true, operation);
  if (!t.ok()) return t.error();
  if (!push.nc_file.empty() &&
      storage_internal::nc_key(conn, push.nc_file) != storage_internal::nc_key(conn, t->nc_file)) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": it was rendered for " + t->nc_file +
                                                    ", not for " + push.nc_file + "; nothing was recorded");
  }
  if (Status s = require_pending(*t, operation + " for " + t->nc_file); !s.ok()) return s.error();
  const NcPush full = approved_push(push, *t, by);
  if (Status s = check_push(t->run_id, full); !s.ok()) return s.error();

  Result<std::int64_t> push_id = insert_push(conn, t->run_id, full, *full.program_text, operation);
  if (!push_id.ok()) return push_id.error();
  if (t->gear_run_id != 0) {
    // The gear run learns the stroke version pushed from it with the approval.
    Result<Statement> gear = Statement::prepare(
        conn,
        "UPDATE gear_runs SET pushed_version = (SELECT table_version FROM nc_pushes WHERE id = :push_id) "
        "WHERE id = :gear_run_id",
        operation);
    if (!gear.ok()) return gear.error();
    gear->bind(":push_id", *push_id);
    gear->bind(":gear_run_id", t->gear_run_id);
    if (Status s = gear->run(); !s.ok()) return s.error();
  }
  Result<Statement> upd = Statement::prepare(conn,
                                             "UPDATE nc_pending SET status = 'approved', decided_utc = :decided_utc,"
                                             " decided_by = :decided_by, note = :note, push_id = :push_id"
                                             " WHERE id = :id",
                                             operation);
  if (!upd.ok()) return upd.error();
  upd->bind(":id", pending_id);
  upd->bind(":decided_utc", std::string_view(utc_now()));
  upd->bind(":decided_by", by);
  upd->bind(":note", note);
  upd->bind(":push_id", *push_id);
  if (Status s = upd->run(); !s.ok()) return s.error();
  return push_id;
}

}  // namespace storage_internal

Status RunStore::record_approved_push(std::int64_t pending_id, const NcPush& push, const std::string& by,
                                      const std::string& note) {
  const std::string operation = "record the approved push of " + pending_what(pending_id);
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<std::int64_t> push_id = storage_internal::approve_in_transaction(conn, pending_id, push, by, note, operation);
  if (!push_id.ok()) return push_id.error();
  return tx->commit();
}

std::string_view pending_verdict_name(PendingVerdict verdict) {
  return verdict == PendingVerdict::kHold ? "hold" : "apply";
}

std::string_view pending_status_name(PendingStatus status) {
  switch (status) {
    case PendingStatus::kPending:
      return "pending";
    case PendingStatus::kApproved:
      return "approved";
    case PendingStatus::kRejected:
      return "rejected";
    case PendingStatus::kSuperseded:
      return "superseded";
  }
  return "pending";
}

}  // namespace gaugeloop
