// The push: hand-edit check, table version, atomic write, record.
#include "app/nc_push.h"

#include <fstream>
#include <sstream>

#include "core/atomic_file.h"
#include "nc_out/table_program.h"

namespace gaugeloop {
namespace {

constexpr std::string_view kVersionLine = "; gaugeloop table_version: ";

Error refused(const std::filesystem::path& nc_file, const std::string& what, const std::string& last) {
  return make_error(
      ErrorCode::kRefused,
      "NC program " + nc_file.string() + " " + what + last +
          ". gaugeloop does not overwrite it: to keep the change, copy the file elsewhere; then remove it and "
          "push again, or approve the pending table with `gaugeloop nc approve ID --overwrite-edited` "
          "(`gaugeloop nc pending` lists them)");
}

}  // namespace

Status check_not_edited_by_hand(const RunStore& store, const std::filesystem::path& nc_file) {
  std::error_code ec;
  if (!std::filesystem::exists(nc_file, ec)) return {};
  std::ifstream in(nc_file, std::ios::binary);
  if (!in) return make_error(ErrorCode::kIo, "NC program " + nc_file.string() + ": cannot be read");
  std::ostringstream buf;
  buf << in.rdbuf();
  const std::string text = buf.str();
  Result<std::optional<NcPush>> last = store.last_push(nc_file.string());
  if (!last) return last.error();
  const std::string since = *last ? " since version " + std::to_string((**last).table_version) + " was pushed (run " +
                                        std::to_string((**last).run_id) + ")"
                                  : "";
  const std::string name = nc_file.string();
  Result<ParsedTable> on_control = parse_table_program(text, name);
  if (!on_control) {
    return refused(nc_file, *last ? "was changed by hand" : "was not written by gaugeloop",
                   since + " (" + on_control.error().message + ")");
  }
  if (Status v = verify_table_checksum(*on_control, name); !v) {
    return refused(nc_file, "was edited by hand", since + " (" + v.error().message + ")");
  }
  if (*last && (**last).program_text) {
    Result<ParsedTable> pushed = parse_table_program(*(**last).program_text, name + " as pushed");
    if (!pushed) return pushed.error();
    if (Status c = compare_table_points(*on_control, pushed->points, name); !c) {
      return refused(nc_file, "is not the table last pushed", since + " (" + c.error().message + ")");
    }
  }
  return {};
}

Result<std::string> with_table_version(std::string_view program, int table_version) {
  const std::size_t at = program.find(kVersionLine);
  if (at == std::string_view::npos || (at > 0 && program[at - 1] != '\n')) {
    return make_error(ErrorCode::kInvalidInput,
                      "the program has no `; gaugeloop table_version:` header line; its template needs "
                      "{{table_header}} (docs/nc_output.md)");
  }
  const std::size_t value = at + kVersionLine.size();
  std::size_t end = program.find('\n', value);
  if (end == std::string_view::npos) end = program.size();
  std::string out(program.substr(0, value));
  out += std::to_string(table_version);
  // Keep a carriage return if the line had one.
  if (end > value && program[end - 1] == '\r') out += '\r';
  out += program.substr(end);
  return out;
}

Result<int> push_program(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                         const RenderForVersion& render, const RecordPush& record, bool overwrite_edited) {
  if (!overwrite_edited) {
    if (Status c = check_not_edited_by_hand(store, nc_file); !c) return c.error();
  }
  Result<int> version = store.next_table_version(nc_file.string());
  if (!version) return version.error();
  Result<std::string> program = render(*version);
  if (!program) return program.error();
  if (Status w = write_file_atomically(nc_file, *program); !w) {
    Error e = w.error();
    e.message = "run " + std::to_string(facts.run_id) + ": table version " + std::to_string(*version) +
                " was not pushed: " + e.message;
    return e;
  }
  NcPush push;
  push.nc_file = nc_file.string();
  push.table_version = *version;
  push.reason = facts.reason;
  push.interpolation = facts.interpolation;
  push.block_count = facts.block_count;
  push.command_error_um = facts.command_error_um;
  push.point_count = facts.point_count;
  push.correction_max_um = facts.correction_max_um;
  push.program_text = *program;
  Status recorded = record ? record(push) : store.record_push(facts.run_id, push, *program);
  if (!recorded) {
    Error e = recorded.error();
    e.message = "table version " + std::to_string(*version) + " was written to " + nc_file.string() +
                " but not recorded: " + e.message;
    return e;
  }
  return *version;
}

Result<PushOutcome> approve_pending(RunStore& store, std::int64_t pending_id, const std::string& by,
                                    const std::string& note, bool overwrite_edited) {
  Result<PendingTable> t = store.load_pending(pending_id);
  if (!t) return t.error();
  if (t->status != PendingStatus::kPending) {
    return make_error(ErrorCode::kRefused, "pending table " + std::to_string(pending_id) + " is " +
                                               std::string(pending_status_name(t->status)) +
                                               ", not pending; `gaugeloop nc pending` lists those waiting");
  }
  PushFacts facts;
  facts.run_id = t->run_id;
  facts.reason = "approved by " + by;
  facts.interpolation = t->interpolation;
  facts.block_count = t->block_count;
  facts.command_error_um = t->command_error_um;
  facts.point_count = t->point_count;
  facts.correction_max_um = t->correction_max_um;
  PushOutcome out;
  out.nc_file = t->nc_file;
  out.run_id = t->run_id;
  const std::string& text = t->program_text;
  Result<int> pushed = push_program(
      store, t->nc_file, facts, [&text](int version) { return with_table_version(text, version); },
      [&](const NcPush& push) -> Status {
        Status s = store.record_approved_push(pending_id, push, by, note);
        if (s || s.error().code != ErrorCode::kRefused) return s;
        // Superseded or rejected between the check and the write: the file is written, so
        // the history must still say so.
        out.decision_recorded = false;
        return store.record_push(t->run_id, push);
      },
      overwrite_edited);
  if (!pushed) return pushed.error();
  out.table_version = *pushed;
  return out;
}

Result<PushOutcome> rollback_to_version(RunStore& store, const std::string& nc_file, int table_version,
                                        const std::string& by) {
  Result<NcPush> old = store.load_push(nc_file, table_version);
  if (!old) return old.error();
  if (!old->program_text) {
    return make_error(ErrorCode::kNotFound, "table version " + std::to_string(table_version) + " of " + nc_file +
                                                " was pushed before gaugeloop kept program texts; it cannot be "
                                                "rolled back to");
  }
  PushFacts facts;
  facts.run_id = old->run_id;
  facts.reason = "rollback to version " + std::to_string(table_version) + " by " + by;
  facts.interpolation = old->interpolation;
  facts.block_count = old->block_count;
  facts.command_error_um = old->command_error_um;
  facts.point_count = old->point_count;
  facts.correction_max_um = old->correction_max_um;
  const std::string& text = *old->program_text;
  Result<int> pushed =
      push_program(store, nc_file, facts, [&text](int version) { return with_table_version(text, version); });
  if (!pushed) return pushed.error();
  return PushOutcome{nc_file, *pushed, old->run_id, true};
}

}  // namespace gaugeloop
