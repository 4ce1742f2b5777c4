// The ids a run database has handed out, kept beside it, to notice commits it lost.
#include <algorithm>
#include <charconv>
#include <cstdio>

#include "core/atomic_file.h"
#include "core/text_file.h"
#include "storage/run_store.h"
#include "storage/run_store_internal.h"
#include "storage/sqlite_db.h"

namespace gaugeloop {
namespace {

constexpr std::string_view kMarksHeader =
    "# gaugeloop: the highest ids this run database has handed out, kept outside it so that commits it loses "
    "(its -wal deleted, or the file restored from an older copy) are noticed. Written after every run and push; "
    "do not edit.\n";

// The database's AUTOINCREMENT sequences of runs and pushes (0 before the first of each).
Result<IdMarks> sequences(Connection& conn) {
  Result<Statement> q = Statement::prepare(conn,
                                           "SELECT coalesce((SELECT seq FROM sqlite_sequence WHERE name = 'runs'), 0),"
                                           " coalesce((SELECT seq FROM sqlite_sequence WHERE name = 'nc_pushes'), 0)",
                                           "read the ids handed out");
  if (!q.ok()) return q.error();
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  return IdMarks{q->column<std::int64_t>(0), q->column<std::int64_t>(1)};
}

// The marks file, or empty when there is none (a database never written by this version, or
// copied without it).
Result<std::optional<IdMarks>> read_marks(const std::filesystem::path& db_path) {
  const std::filesystem::path path = id_marks_path(db_path);
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return std::optional<IdMarks>();
  Result<std::string> text = read_regular_file(path, "id marks", 4096);
  if (!text.ok()) return text.error();
  IdMarks marks;
  bool runs = false;
  bool pushes = false;
  int line_number = 0;
  std::size_t at = 0;
  while (at < text->size()) {
    std::size_t end = text->find('\n', at);
    if (end == std::string::npos) end = text->size();
    const std::string_view line(text->data() + at, end - at);
    at = end + 1;
    ++line_number;
    if (line.empty() || line.front() == '#') continue;
    const std::size_t space = line.find(' ');
    const std::string_view key = line.substr(0, space);
    const std::string_view value = space == std::string_view::npos ? std::string_view() : line.substr(space + 1);
    std::int64_t n = -1;
    const auto [end_of_number, ec2] = std::from_chars(value.data(), value.data() + value.size(), n);
    if ((key != "runs" && key != "pushes") || ec2 != std::errc() || end_of_number != value.data() + value.size() ||
        n < 0) {
      return make_error(ErrorCode::kInvalidInput,
                        path.string() + ":" + std::to_string(line_number) + ": \"" + std::string(line) +
                            "\" is not \"runs N\" or \"pushes N\"; the file was changed outside gaugeloop. Remove "
                            "it: the next run writes it again (commits lost before then are not noticed)");
    }
    (key == "runs" ? marks.run_id : marks.push_id) = n;
    (key == "runs" ? runs : pushes) = true;
  }
  if (!runs || !pushes) {
    return make_error(ErrorCode::kInvalidInput, path.string() + ": no \"" + (runs ? "pushes" : "runs") +
                                                    " N\" line; remove it: the next run writes it again");
  }
  return std::optional<IdMarks>(marks);
}

std::string range_text(std::string_view what, std::int64_t from, std::int64_t to) {
  if (from > to) return {};
  return std::string(what) +
         (from == to ? " " + std::to_string(from) : "s " + std::to_string(from) + " to " + std::to_string(to));
}

Status raise_sequence(Connection& conn, std::string_view table, std::int64_t value, const std::string& operation) {
  Result<Statement> upd =
      Statement::prepare(conn, "UPDATE sqlite_sequence SET seq = :seq WHERE name = :name AND seq < :seq", operation);
  if (!upd.ok()) return upd.error();
  upd->bind(":seq", value);
  upd->bind(":name", table);
  if (Status s = upd->run(); !s.ok()) return s;
  Result<Statement> ins =
      Statement::prepare(conn,
                         "INSERT INTO sqlite_sequence (name, seq) SELECT :name, :seq WHERE NOT EXISTS "
                         "(SELECT 1 FROM sqlite_sequence WHERE name = :name)",
                         operation);
  if (!ins.ok()) return ins.error();
  ins->bind(":seq", value);
  ins->bind(":name", table);
  return ins->run();
}

}  // namespace

std::filesystem::path id_marks_path(const std::filesystem::path& db_path) { return db_path.string() + ".ids"; }

std::string lost_commits_text(const std::filesystem::path& db_path, const LostCommits& lost) {
  std::string gone = range_text("run", lost.held.run_id + 1, lost.marked.run_id);
  const std::string pushes = range_text("push", lost.held.push_id + 1, lost.marked.push_id);
  if (!pushes.empty()) gone += (gone.empty() ? "" : " and ") + pushes;
  return "run database " + db_path.string() + " lost commits: " + id_marks_path(db_path).filename().string() +
         " says run ids up to " + std::to_string(lost.marked.run_id) + " and push ids up to " +
         std::to_string(lost.marked.push_id) + " were handed out, the database holds them up to " +
         std::to_string(lost.held.run_id) + " and " + std::to_string(lost.held.push_id) + " (its write-ahead log " +
         db_path.filename().string() + "-wal deleted after a commit, or the file restored from an older copy); " +
         gone +
         " are not in the history. Their ids are not handed out again; a program on the control from a lost "
         "push is refused as not the one last pushed until it is replaced (`gaugeloop nc check`)";
}

Status RunStore::mark_ids() const {
  if (conn_->path == ":memory:" || conn_->path.empty()) return {};
  // Under the database's write lock: one writer marks at a time, so the marks never go back
  // and a temporary file left by a writer killed while marking is ours to remove.
  Result<Transaction> tx = Transaction::begin(*conn_, Transaction::Mode::kWrite, "mark the ids handed out");
  if (!tx.ok()) return tx.error();
  Result<IdMarks> now = sequences(*conn_);
  if (!now.ok()) return now.error();
  const std::filesystem::path path = id_marks_path(conn_->path);
  if (Result<int> removed = remove_atomic_leftovers(path); !removed.ok()) return removed.error();
  return write_file_atomically(path, std::string(kMarksHeader) + "runs " + std::to_string(now->run_id) + "\npushes " +
                                         std::to_string(now->push_id) + "\n");
}

Result<std::optional<LostCommits>> storage_internal::find_lost_commits(Connection& conn) {
  if (conn.path == ":memory:" || conn.path.empty()) return std::optional<LostCommits>();
  Result<std::optional<IdMarks>> marks = read_marks(conn.path);
  if (!marks.ok()) return marks.error();
  if (!*marks) return std::optional<LostCommits>();
  Result<IdMarks> held = sequences(conn);
  if (!held.ok()) return held.error();
  if ((**marks).run_id <= held->run_id && (**marks).push_id <= held->push_id) return std::optional<LostCommits>();
  LostCommits lost;
  lost.marked = **marks;
  lost.held = *held;
  lost.held.run_id = std::min(lost.held.run_id, lost.marked.run_id);
  lost.held.push_id = std::min(lost.held.push_id, lost.marked.push_id);
  return std::optional<LostCommits>(lost);
}

Result<std::optional<LostCommits>> RunStore::find_lost_commits() const {
  return storage_internal::find_lost_commits(*conn_);
}

Result<bool> RunStore::lost_run(std::int64_t run_id) const {
  if (run_id <= 0) return false;
  Result<IdMarks> held = sequences(*conn_);
  if (!held.ok()) return held.error();
  std::int64_t handed_out = held->run_id;
  Result<std::optional<IdMarks>> marks = read_marks(conn_->path);
  if (marks.ok() && *marks) handed_out = std::max(handed_out, (**marks).run_id);
  if (run_id > handed_out) return false;
  Result<Statement> q = Statement::prepare(*conn_, "SELECT 1 FROM runs WHERE id = :id", "look for a run");
  if (!q.ok()) return q.error();
  q->bind(":id", run_id);
  Result<bool> row = q->step();
  if (!row.ok()) return row.error();
  return !*row;
}

Result<std::optional<LostCommits>> RunStore::check_ids() {
  if (conn_->path == ":memory:" || conn_->path.empty()) return std::optional<LostCommits>();
  // The write lock only when there is something to do: a reader's check must not wait on a writer.
  const std::filesystem::path path = id_marks_path(conn_->path);
  Result<std::vector<std::filesystem::path>> leftovers = atomic_leftovers(path);
  if (!leftovers.ok()) return leftovers.error();
  Result<std::optional<LostCommits>> seen = storage_internal::find_lost_commits(*conn_);
  if (!seen.ok()) return seen.error();
  if (leftovers->empty() && !*seen) return std::optional<LostCommits>();
  const std::string operation = "check the ids handed out against the run database";
  Result<Transaction> tx = Transaction::begin(*conn_, Transaction::Mode::kWrite, operation);
  if (!tx.ok()) return tx.error();
  // A writer killed while marking left its temporary file: under the write lock, no one is marking.
  if (Result<int> removed = remove_atomic_leftovers(path); !removed.ok()) return removed.error();
  Result<std::optional<LostCommits>> lost = storage_internal::find_lost_commits(*conn_);
  if (!lost.ok() || !*lost) return lost;
  if (Status s = raise_sequence(*conn_, "runs", (**lost).marked.run_id, operation); !s.ok()) return s.error();
  if (Status s = raise_sequence(*conn_, "nc_pushes", (**lost).marked.push_id, operation); !s.ok()) return s.error();
  EventRecord event;
  event.kind = EventKind::kFault;
  event.code = "lost commits";
  event.message = lost_commits_text(conn_->path, **lost);
  if (Result<std::int64_t> e = record_event(event); !e.ok()) return e.error();
  if (Status c = tx->commit(); !c.ok()) return c.error();
  return lost;
}

}  // namespace gaugeloop
