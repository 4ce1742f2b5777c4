// RunStore's pushes: the NC programs written to the control (nc_pushes) and the push journal
// that records each one before its file is renamed into place (nc_push_intents).
#include <type_traits>
#include <utility>

#include "core/utc_time.h"
#include "core/uuid.h"
#include "storage/record_checks.h"
#include "storage/run_store.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {

using storage_internal::Connection;
using storage_internal::Statement;
using storage_internal::text_or_null;
using storage_internal::Transaction;

namespace storage_internal {
namespace {

constexpr std::string_view kRecordNcFile = "UPDATE runs SET status = 'pushed', nc_file = :nc_file WHERE id = :run_id";

constexpr std::string_view kInsertPush = R"sql(
INSERT INTO nc_pushes (run_id, pushed_utc, nc_file, table_version, reason, interpolation, block_count,
                       command_error_um, point_count, correction_max_um, program_hash, program_text, uuid)
VALUES (:run_id, :pushed_utc, :nc_file, :table_version, :reason, :interpolation, :block_count,
        :command_error_um, :point_count, :correction_max_um, :program_hash, :program_text, :uuid))sql";

Status check_claimed_version(const NcPush& push, int next, const std::string& operation) {
  if (push.table_version == 0 || push.table_version == next) return {};
  return make_error(ErrorCode::kInvalidInput,
                    "cannot " + operation + ": table version " + std::to_string(push.table_version) +
                        " is not the next for " + push.nc_file + " (the next is " + std::to_string(next) +
                        "): another push was recorded since the version was asked; nothing was recorded, "
                        "render the program again with the next version");
}

}  // namespace

void bind_table_facts(Statement& s, const TableFacts& table) {
  s.bind(":interpolation", text_or_null(table.interpolation));
  s.bind(":block_count", table.block_count);
  s.bind(":command_error_um", table.command_error_um);
  s.bind(":point_count", table.point_count);
  s.bind(":correction_max_um", table.correction_max_um);
}

TableFacts read_table_facts(const Statement& s, int first) {
  TableFacts t;
  t.interpolation = s.column<std::string>(first);
  t.block_count = s.column<std::optional<int>>(first + 1);
  t.command_error_um = s.column<std::optional<double>>(first + 2);
  t.point_count = s.column<std::optional<int>>(first + 3);
  t.correction_max_um = s.column<std::optional<double>>(first + 4);
  return t;
}

NcPush read_push(const Statement& s, bool with_text) {
  NcPush p;
  p.id = s.column<std::int64_t>(0);
  p.run_id = s.column<std::int64_t>(1);
  p.pushed_utc = s.column<std::string>(2);
  p.nc_file = nc_path_column(s, 3);
  p.table_version = s.column<int>(4);
  p.reason = s.column<std::string>(5);
  p.table = read_table_facts(s, 6);
  p.program_hash = s.column<std::string>(11);
  p.uuid = s.column<std::string>(12);
  if (with_text) p.program_text = s.column<std::optional<std::string>>(13);
  return p;
}

Result<int> next_version_of(Connection& conn, std::string_view nc_file, const std::string& operation) {
  Result<Statement> next = Statement::prepare(
      conn, "SELECT coalesce(max(table_version), 0) + 1 FROM nc_pushes WHERE nc_file = :nc_file", operation);
  if (!next.ok()) return next.error();
  next->bind(":nc_file", nc_key(conn, nc_file));
  Result<bool> row = next->step();
  if (!row.ok()) return row.error();
  return next->column<int>(0);
}

std::string default_reason(std::int64_t run_id) {
  return run_id != 0 ? "run " + std::to_string(run_id) : std::string("new program");
}

Result<std::int64_t> insert_push(Connection& conn, std::int64_t run_id, const NcPush& push, std::string_view text,
                                 const std::string& operation) {
  if (Status s = note_nc_directory(conn, push.nc_file, operation); !s.ok()) return s.error();
  // Run 0: a program written from a drawing (nc new), with no run behind it.
  if (run_id != 0) {
    Result<Statement> upd = Statement::prepare(conn, kRecordNcFile, operation);
    if (!upd.ok()) return upd.error();
    upd->bind(":run_id", run_id);
    upd->bind(":nc_file", nc_key(conn, push.nc_file));
    if (Status s = upd->run(); !s.ok()) return s.error();
    if (conn.changes() == 0) return run_not_found(conn, run_id, operation);
  }
  Result<int> version = next_version_of(conn, push.nc_file, operation);
  if (!version.ok()) return version.error();
  if (Status s = check_claimed_version(push, *version, operation); !s.ok()) return s.error();

  Result<Statement> ins = Statement::prepare(conn, kInsertPush, operation);
  if (!ins.ok()) return ins.error();
  ins->bind(":run_id", run_id != 0 ? std::optional<std::int64_t>(run_id) : std::nullopt);
  ins->bind(":pushed_utc", std::string_view(push.pushed_utc.empty() ? utc_now() : push.pushed_utc));
  ins->bind(":nc_file", nc_key(conn, push.nc_file));
  ins->bind(":table_version", *version);
  ins->bind(":reason", std::string_view(push.reason.empty() ? default_reason(run_id) : push.reason));
  storage_internal::bind_table_facts(*ins, push.table);
  const std::string hash = text.empty() ? push.program_hash : settings_hash(text);
  ins->bind(":program_hash", text_or_null(hash));
  ins->bind(":program_text", text_or_null(text));
  ins->bind(":uuid", std::string_view(new_uuid()));  // a rollback re-records a loaded push: always a new one
  if (Status s = ins->run(); !s.ok()) return s.error();
  return conn.last_insert_rowid();
}

}  // namespace storage_internal

Status RunStore::record_nc_file(std::int64_t run_id, const std::string& nc_path) {
  NcPush push;
  push.nc_file = nc_path;
  return record_push(run_id, push);
}

Status RunStore::record_push(std::int64_t run_id, const NcPush& push, std::string_view program_text) {
  if (Status s = storage_internal::check_push(run_id, push); !s.ok()) return s;
  if (program_text.empty() && push.program_text) program_text = *push.program_text;
  Connection& conn = *conn_;
  const std::string operation = "record NC file " + push.nc_file + " for run " + std::to_string(run_id);
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<std::int64_t> id = storage_internal::insert_push(conn, run_id, push, program_text, operation);
  if (!id.ok()) return id.error();
  return tx->commit();
}

Result<int> RunStore::next_table_version(const std::string& nc_file) const {
  if (nc_file.empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot find the next table version: the NC file path is empty");
  }
  return storage_internal::next_version_of(*conn_, nc_file, "find the next table version of " + nc_file);
}

Result<std::vector<NcPush>> RunStore::list_pushes(const PushQuery& q) const {
  if (q.limit < 1) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list NC pushes: the limit must be 1 or more, not " + std::to_string(q.limit));
  }
  if (q.lobe < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot list NC pushes: lobe " + std::to_string(q.lobe) + " is negative");
  }
  storage_internal::WhereClause where;
  if (!q.nc_file.empty()) where.add("p.nc_file =", storage_internal::nc_key(*conn_, q.nc_file));
  if (!q.machine.empty()) where.add("r.machine =", q.machine);
  if (!q.part.empty()) where.add("r.part =", q.part);
  if (q.lobe > 0) where.add_literal("r.lobe = " + std::to_string(q.lobe));
  Result<Statement> st = Statement::prepare(*conn_,
                                            "SELECT " + std::string(storage_internal::kPushColumns) +
                                                " FROM nc_pushes AS p LEFT JOIN runs AS r ON r.id = p.run_id" +
                                                where.sql() + " ORDER BY p.id DESC LIMIT :limit",
                                            "list NC pushes");
  if (!st.ok()) return st.error();
  st->bind(":limit", q.limit);
  where.bind(*st);
  return st->collect([](const Statement& s) { return storage_internal::read_push(s, false); });
}

Result<std::vector<std::string>> RunStore::pushed_files() const {
  // One seek per file through the (nc_file, table_version) key.
  Result<Statement> st =
      Statement::prepare(*conn_, "SELECT DISTINCT nc_file FROM nc_pushes ORDER BY nc_file", "list the NC files pushed");
  if (!st.ok()) return st.error();
  return st->collect([](const Statement& s) { return storage_internal::nc_path_column(s, 0); });
}

namespace {

// "its versions are 1 to 4", for a version that is not there.
Result<std::string> versions_of(Connection& conn, const std::string& nc_file, const std::string& operation) {
  Result<Statement> have = Statement::prepare(
      conn, "SELECT count(*), min(table_version), max(table_version) FROM nc_pushes WHERE nc_file = :nc_file",
      operation);
  if (!have.ok()) return have.error();
  have->bind(":nc_file", storage_internal::nc_key(conn, nc_file));
  Result<bool> row = have->step();
  if (!row.ok()) return row.error();
  const int count = have->column<int>(0);
  const int lowest = have->column<int>(1);
  const int highest = have->column<int>(2);
  if (count == 0) return std::string("nothing was ever pushed to it");
  if (count == 1) return "its only version is " + std::to_string(lowest);
  std::string versions = "its versions are " + std::to_string(lowest) + " to " + std::to_string(highest);
  if (highest - lowest + 1 != count) versions += " (" + std::to_string(count) + " of them)";
  return versions;
}

// A program text read back must be the text whose hash was stored with it: one changed outside
// SQLite (a damaged page) is never written to the control again.
template <typename Push>
Result<Push> checked_program_text(const Connection& conn, Push push) {
  const auto check = [&conn](const NcPush& p) -> Status {
    if (!p.program_text || p.program_text->empty() || p.program_hash.empty()) return {};
    if (settings_hash(*p.program_text) == p.program_hash) return {};
    return make_error(ErrorCode::kStorage, "run database " + conn.path.string() + ": table version " +
                                               std::to_string(p.table_version) + " of " + p.nc_file +
                                               ": its stored program text does not match the hash kept with it (a "
                                               "page changed outside SQLite), so it is not written to the control; "
                                               "restore a backup (gaugeloop db check lists what is damaged)");
  };
  if constexpr (std::is_same_v<Push, NcPush>) {
    if (Status s = check(push); !s.ok()) return s.error();
  } else {
    if (push) {
      if (Status s = check(*push); !s.ok()) return s.error();
    }
  }
  return push;
}

}  // namespace

Result<NcPush> RunStore::load_push(const std::string& nc_file, int table_version) const {
  Connection& conn = *conn_;
  const std::string operation = "load table version " + std::to_string(table_version) + " of " + nc_file;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kRead, operation);
  if (!tx.ok()) return tx.error();
  Result<Statement> q = Statement::prepare(conn,
                                           "SELECT " + std::string(storage_internal::kPushColumns) +
                                               ", p.program_text FROM nc_pushes AS p"
                                               " WHERE p.nc_file = :nc_file AND p.table_version = :table_version",
                                           operation);
  if (!q.ok()) return q.error();
  q->bind(":nc_file", storage_internal::nc_key(*conn_, nc_file));
  q->bind(":table_version", table_version);
  Result<std::optional<NcPush>> push =
      q->first([](const Statement& s) { return storage_internal::read_push(s, true); });
  if (!push.ok()) return push.error();
  if (*push) return checked_program_text(*conn_, std::move(**push));

  Result<std::string> versions = versions_of(conn, nc_file, operation);
  if (!versions.ok()) return versions.error();
  return make_error(ErrorCode::kNotFound, "NC file " + nc_file + " has no table version " +
                                              std::to_string(table_version) + " in run database " + conn.path.string() +
                                              ": " + *versions);
}

Result<std::optional<NcPush>> RunStore::push_by_id(std::int64_t push_id) const {
  Result<Statement> q = Statement::prepare(
      *conn_, "SELECT " + std::string(storage_internal::kPushColumns) + " FROM nc_pushes AS p WHERE p.id = :id",
      "load push " + std::to_string(push_id));
  if (!q.ok()) return q.error();
  q->bind(":id", push_id);
  return q->first([](const Statement& s) { return storage_internal::read_push(s, false); });
}

Result<std::optional<NcPush>> RunStore::last_push(const std::string& nc_file) const {
  Result<Statement> q = Statement::prepare(*conn_,
                                           "SELECT " + std::string(storage_internal::kPushColumns) +
                                               ", p.program_text FROM nc_pushes AS p WHERE p.nc_file = :nc_file"
                                               " ORDER BY p.table_version DESC LIMIT 1",
                                           "load the last push of " + nc_file);
  if (!q.ok()) return q.error();
  q->bind(":nc_file", storage_internal::nc_key(*conn_, nc_file));
  Result<std::optional<NcPush>> push =
      q->first([](const Statement& s) { return storage_internal::read_push(s, true); });
  if (!push.ok()) return push.error();
  return checked_program_text(*conn_, std::move(*push));
}

// ---- the push journal ----

namespace {

constexpr std::string_view kIntentColumns =
    "id, created_utc, run_id, nc_file, table_version, reason, interpolation, block_count, command_error_um, "
    "point_count, correction_max_um, program_hash, program_text, pending_id, approved_by, note";

constexpr std::string_view kInsertIntent = R"sql(
INSERT INTO nc_push_intents (created_utc, run_id, nc_file, table_version, reason, interpolation, block_count,
                             command_error_um, point_count, correction_max_um, program_hash, program_text,
                             pending_id, approved_by, note)
VALUES (:created_utc, :run_id, :nc_file, :table_version, :reason, :interpolation, :block_count,
        :command_error_um, :point_count, :correction_max_um, :program_hash, :program_text,
        :pending_id, :approved_by, :note))sql";

PushIntent read_intent(const Statement& s) {
  PushIntent i;
  i.id = s.column<std::int64_t>(0);
  i.created_utc = s.column<std::string>(1);
  i.run_id = s.column<std::int64_t>(2);
  i.push.run_id = i.run_id;
  i.push.nc_file = storage_internal::nc_path_column(s, 3);
  i.push.table_version = s.column<int>(4);
  i.push.reason = s.column<std::string>(5);
  i.push.table = storage_internal::read_table_facts(s, 6);
  i.push.program_hash = s.column<std::string>(11);
  i.push.program_text = s.column<std::string>(12);
  i.pending_id = s.column<std::optional<std::int64_t>>(13);
  i.approved_by = s.column<std::string>(14);
  i.note = s.column<std::string>(15);
  return i;
}

Result<std::optional<PushIntent>> read_open_intent(Connection& conn, std::int64_t id, const std::string& operation) {
  Result<Statement> q = Statement::prepare(
      conn, "SELECT " + std::string(kIntentColumns) + " FROM nc_push_intents WHERE id = :id AND state = 'open'",
      operation);
  if (!q.ok()) return q.error();
  q->bind(":id", id);
  return q->first(read_intent);
}

Status resolve_intent(Connection& conn, std::int64_t id, std::string_view state, const std::string& resolution,
                      std::optional<std::int64_t> push_id, const std::string& operation) {
  Result<Statement> upd = Statement::prepare(conn,
                                             "UPDATE nc_push_intents SET state = :state, resolved_utc = :resolved_utc,"
                                             " resolution = :resolution, push_id = :push_id, program_text = ''"
                                             " WHERE id = :id AND state = 'open'",
                                             operation);
  if (!upd.ok()) return upd.error();
  upd->bind(":id", id);
  upd->bind(":state", state);
  upd->bind(":resolved_utc", std::string_view(utc_now()));
  upd->bind(":resolution", resolution);
  upd->bind(":push_id", push_id);
  if (Status s = upd->run(); !s.ok()) return s;
  if (conn.changes() == 0) {
    return make_error(ErrorCode::kRefused, "cannot " + operation + ": push intent " + std::to_string(id) +
                                               " is not open (already resolved by another command)");
  }
  return {};
}

// kRefused if an intent is open for `nc_file` (one push at a time per file).
Status require_no_open_intent(Connection& conn, const std::string& nc_file, const std::string& operation) {
  Result<Statement> open = Statement::prepare(
      conn, "SELECT id, created_utc, run_id FROM nc_push_intents WHERE nc_file = :nc_file AND state = 'open'",
      operation);
  if (!open.ok()) return open.error();
  open->bind(":nc_file", storage_internal::nc_key(conn, nc_file));
  Result<bool> row = open->step();
  if (!row.ok()) return row.error();
  if (!*row) return {};
  return make_error(ErrorCode::kRefused,
                    "cannot " + operation + ": push intent " + std::to_string(open->column<std::int64_t>(0)) +
                        " (run " + std::to_string(open->column<std::int64_t>(2)) + ", " + open->column<std::string>(1) +
                        ") is still open for this file: another push is under way, or one "
                        "was interrupted and must be reconciled first");
}

Status insert_push_file(Connection& conn, std::int64_t intent_id, const PushFile& f, const std::string& operation) {
  Result<Statement> ins = Statement::prepare(conn,
                                             "INSERT INTO nc_push_files (intent_id, role, file, hash, text)"
                                             " VALUES (:intent_id, :role, :file, :hash, :text)",
                                             operation);
  if (!ins.ok()) return ins.error();
  ins->bind(":intent_id", intent_id);
  ins->bind(":role", push_file_role_name(f.role));
  ins->bind(":file", storage_internal::nc_key(conn, f.path));
  ins->bind(":hash", std::string_view(f.hash));
  ins->bind(":text", f.role == PushFileRole::kTable ? std::optional<std::string>() : f.text);
  return ins->run();
}

Result<std::int64_t> insert_intent(Connection& conn, const PushIntent& intent, const std::string& operation) {
  const NcPush& p = intent.push;
  Result<Statement> ins = Statement::prepare(conn, kInsertIntent, operation);
  if (!ins.ok()) return ins.error();
  ins->bind(":created_utc", std::string_view(utc_now()));
  ins->bind(":run_id", intent.run_id != 0 ? std::optional<std::int64_t>(intent.run_id) : std::nullopt);
  ins->bind(":nc_file", storage_internal::nc_key(conn, p.nc_file));
  ins->bind(":table_version", p.table_version);
  ins->bind(":reason", std::string_view(p.reason.empty() ? storage_internal::default_reason(intent.run_id) : p.reason));
  storage_internal::bind_table_facts(*ins, p.table);
  ins->bind(":program_hash", std::string_view(settings_hash(*p.program_text)));
  ins->bind(":program_text", *p.program_text);
  ins->bind(":pending_id", intent.pending_id);
  ins->bind(":approved_by", text_or_null(intent.approved_by));
  ins->bind(":note", text_or_null(intent.note));
  if (Status s = ins->run(); !s.ok()) return s.error();
  return conn.last_insert_rowid();
}

}  // namespace

Result<std::int64_t> RunStore::begin_push(const PushIntent& intent) {
  const NcPush& p = intent.push;
  if (Status s = storage_internal::check_push(intent.run_id, p); !s.ok()) return s.error();
  const std::string operation = "record the intent to push table version " + std::to_string(p.table_version) + " of " +
                                p.nc_file + " for run " + std::to_string(intent.run_id);
  if (!p.program_text || p.program_text->empty()) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": the program text is empty");
  }
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  if (Status s = storage_internal::note_nc_directory(conn, p.nc_file, operation); !s.ok()) return s.error();
  if (Status s = require_no_open_intent(conn, p.nc_file, operation); !s.ok()) return s.error();
  if (intent.run_id != 0) {
    if (Status s = storage_internal::require_run(conn, intent.run_id, operation); !s.ok()) return s.error();
  }
  Result<int> next = storage_internal::next_version_of(conn, p.nc_file, operation);
  if (!next.ok()) return next.error();
  if (*next != p.table_version) {
    return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": the next version of the file is " +
                                                    std::to_string(*next) + "; render the program again with it");
  }
  Result<std::int64_t> id = insert_intent(conn, intent, operation);
  if (!id.ok()) return id.error();
  PushFile table;
  table.role = PushFileRole::kTable;
  table.path = p.nc_file;
  table.hash = settings_hash(*p.program_text);
  if (Status s = insert_push_file(conn, *id, table, operation); !s.ok()) return s.error();
  for (const PushFile& f : intent.files) {
    if (f.role == PushFileRole::kTable || !f.text) {
      return make_error(ErrorCode::kInvalidInput, "cannot " + operation + ": the " +
                                                      std::string(push_file_role_name(f.role)) + " file " + f.path +
                                                      " is given without its text, or as a second table");
    }
    PushFile beside = f;
    beside.hash = settings_hash(*f.text);
    if (Status s = insert_push_file(conn, *id, beside, operation); !s.ok()) return s.error();
  }
  if (Status c = tx->commit(); !c.ok()) return c.error();
  return id;
}

Result<PushCompletion> RunStore::complete_push(std::int64_t intent_id, const std::string& resolution) {
  const std::string operation = "complete push intent " + std::to_string(intent_id);
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  Result<std::optional<PushIntent>> intent = read_open_intent(conn, intent_id, operation);
  if (!intent.ok()) return intent.error();
  if (!*intent) {
    return make_error(ErrorCode::kRefused, "cannot " + operation + ": it is not open (resolved by another command)");
  }
  const PushIntent& i = **intent;
  PushCompletion out;
  out.table_version = i.push.table_version;
  Result<std::int64_t> push_id = make_error(ErrorCode::kInternal, "no push");
  if (i.pending_id) {
    push_id = storage_internal::approve_in_transaction(conn, *i.pending_id, i.push, i.approved_by, i.note, operation);
    // Rejected or superseded since it was checked: the file is written, so the history must
    // still say so, as a plain push.
    if (!push_id.ok() && push_id.error().code == ErrorCode::kRefused) {
      out.decision_recorded = false;
      push_id = storage_internal::insert_push(conn, i.run_id, i.push, *i.push.program_text, operation);
    }
  } else {
    push_id = storage_internal::insert_push(conn, i.run_id, i.push, *i.push.program_text, operation);
  }
  if (!push_id.ok()) return push_id.error();
  out.push_id = *push_id;
  if (Status s = resolve_intent(conn, intent_id, "completed", resolution, *push_id, operation); !s.ok()) {
    return s.error();
  }
  if (Status c = tx->commit(); !c.ok()) return c.error();
  return out;
}

Status RunStore::abandon_push(std::int64_t intent_id, const std::string& resolution) {
  const std::string operation = "abandon push intent " + std::to_string(intent_id);
  Connection& conn = *conn_;
  Result<Transaction> tx = Transaction::begin(conn, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  if (Status s = resolve_intent(conn, intent_id, "abandoned", resolution, std::nullopt, operation); !s.ok()) return s;
  return tx->commit();
}

std::string_view push_file_role_name(PushFileRole role) {
  switch (role) {
    case PushFileRole::kTable:
      return "table";
    case PushFileRole::kMain:
      return "main";
    case PushFileRole::kSpeed:
      return "speed";
    case PushFileRole::kY:
      return "y";
    case PushFileRole::kCec:
      return "cec";
  }
  return "table";
}

Result<std::vector<PushFile>> RunStore::files_of_last_push(const std::string& nc_file) const {
  return files_of_push(nc_file, 0);
}

Result<std::vector<PushFile>> RunStore::files_of_push(const std::string& nc_file, int table_version) const {
  const std::string operation =
      "read the files of " +
      (table_version > 0 ? "table version " + std::to_string(table_version) : std::string("the last push")) + " of " +
      nc_file;
  Result<Statement> q = Statement::prepare(*conn_,
                                           "SELECT f.role, f.file, f.hash, f.text, p.table_version"
                                           " FROM nc_pushes AS p"
                                           " JOIN nc_push_intents AS i ON i.push_id = p.id"
                                           " JOIN nc_push_files AS f ON f.intent_id = i.id"
                                           " WHERE p.id = (SELECT id FROM nc_pushes WHERE nc_file = :nc_file"
                                           "               AND (:version = 0 OR table_version = :version)"
                                           "               ORDER BY table_version DESC LIMIT 1)"
                                           " ORDER BY f.role = 'table' DESC, f.role",
                                           operation);
  if (!q.ok()) return q.error();
  q->bind(":nc_file", storage_internal::nc_key(*conn_, nc_file));
  q->bind(":version", table_version);
  Result<std::vector<PushFile>> files = q->collect([](const Statement& s) {
    PushFile f;
    const std::string role = s.column<std::string>(0);
    f.role = role == "main"    ? PushFileRole::kMain
             : role == "speed" ? PushFileRole::kSpeed
             : role == "y"     ? PushFileRole::kY
             : role == "cec"   ? PushFileRole::kCec
                               : PushFileRole::kTable;
    f.path = storage_internal::nc_path_column(s, 1);
    f.hash = s.column<std::string>(2);
    f.text = s.column<std::optional<std::string>>(3);
    f.table_version = s.column<int>(4);
    return f;
  });
  if (!files.ok()) return files.error();
  for (const PushFile& f : *files) {
    if (f.text && settings_hash(*f.text) != f.hash) {
      return make_error(ErrorCode::kStorage, "run database " + conn_->path.string() + ": the " +
                                                 std::string(push_file_role_name(f.role)) + " file " + f.path +
                                                 " of table version " + std::to_string(f.table_version) +
                                                 ": its stored text does not match the hash kept with it (a page "
                                                 "changed outside SQLite), so it is not written to the control; "
                                                 "restore a backup (gaugeloop db check lists what is damaged)");
    }
  }
  return files;
}

Result<std::optional<int>> RunStore::version_that_wrote(const std::string& path, const std::string& hash) const {
  Result<Statement> q = Statement::prepare(*conn_,
                                           "SELECT max(v) FROM ("
                                           " SELECT i.table_version AS v FROM nc_push_files AS f"
                                           " JOIN nc_push_intents AS i ON i.id = f.intent_id"
                                           " WHERE f.file = :file AND f.hash = :hash"
                                           " UNION ALL SELECT table_version FROM nc_pushes"
                                           " WHERE nc_file = :file AND program_hash = :hash)",
                                           "look for the push that wrote " + path);
  if (!q.ok()) return q.error();
  q->bind(":file", storage_internal::nc_key(*conn_, path));
  q->bind(":hash", std::string_view(hash));
  Result<std::optional<std::optional<int>>> v =
      q->first([](const Statement& s) { return s.column<std::optional<int>>(0); });
  if (!v.ok()) return v.error();
  return *v ? **v : std::nullopt;
}

Result<std::vector<PushIntent>> RunStore::open_push_intents(const std::string& nc_file) const {
  Result<Statement> q = Statement::prepare(*conn_,
                                           "SELECT " + std::string(kIntentColumns) +
                                               " FROM nc_push_intents WHERE state = 'open'"
                                               " AND (:nc_file = '' OR nc_file = :nc_file) ORDER BY id",
                                           "list the open push intents");
  if (!q.ok()) return q.error();
  q->bind(":nc_file", storage_internal::nc_key(*conn_, nc_file));
  return q->collect(read_intent);
}

}  // namespace gaugeloop
