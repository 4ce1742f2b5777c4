// The push: hand-edit check, table version, atomic write, record.
#include "job/nc_push.h"

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

namespace {

std::string header_value(const ParsedTable& t, const std::string& key) {
  auto it = t.header.find(key);
  return it == t.header.end() ? std::string("?") : it->second;
}

}  // namespace

Status check_not_edited_by_hand(const RunStore& store, const std::filesystem::path& nc_file, NcFiles& files) {
  Result<std::optional<std::string>> on_disk = files.read_program(nc_file);
  if (!on_disk) return on_disk.error();
  if (!*on_disk) return {};
  const std::string& text = **on_disk;
  // Written by a push whose record was interrupted: that push's program, not a hand edit.
  Result<std::vector<PushIntent>> open = store.open_push_intents(nc_file.string());
  if (!open) return open.error();
  for (const PushIntent& i : *open) {
    if (i.push.program_text && *i.push.program_text == text) return {};
  }
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
    // Its identity first: a gaugeloop table of another run or version copied in is not the
    // table last pushed, even with the same points.
    for (const char* key : {"run_id", "table_version", "body_checksum_fnv1a64"}) {
      const std::string here = header_value(*on_control, key);
      const std::string pushed_value = header_value(*pushed, key);
      if (here != pushed_value) {
        return refused(nc_file, "is not the table last pushed",
                       since + " (its header says " + key + " " + here + ", the push recorded " + pushed_value +
                           "; it holds table version " + header_value(*on_control, "table_version") + " of run " +
                           header_value(*on_control, "run_id") + ")");
      }
    }
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

std::string_view push_step_name(PushStep step) {
  switch (step) {
    case PushStep::kIntentRecorded:
      return "intent recorded";
    case PushStep::kTemporaryWritten:
      return "temporary file written";
    case PushStep::kFlushed:
      return "temporary file flushed";
    case PushStep::kRenamed:
      return "renamed into place";
    case PushStep::kRecorded:
      return "recorded";
  }
  return "?";
}

namespace {

// reconcile_pushes with the directory's lock already held.
Result<ReconcileReport> reconcile_locked(RunStore& store, const std::filesystem::path& nc_file, NcFiles& files) {
  ReconcileReport report;
  Result<std::vector<PushIntent>> open = store.open_push_intents(nc_file.string());
  if (!open) return open.error();
  if (!open->empty()) {
    Result<std::optional<std::string>> on_disk = files.read_program(nc_file);
    if (!on_disk) return on_disk.error();
    for (const PushIntent& i : *open) {
      const std::string what = "table version " + std::to_string(i.push.table_version) + " of run " +
                               std::to_string(i.run_id) + " (" + i.created_utc + ")";
      if (*on_disk && i.push.program_text && **on_disk == *i.push.program_text) {
        Result<PushCompletion> done =
            store.complete_push(i.id, "found on the control after an interrupted push; recorded by reconciliation");
        if (!done) return done.error();
        ++report.completed;
        report.messages.push_back(nc_file.string() + ": " + what +
                                  " is on the control; its interrupted push is now recorded");
      } else {
        if (Status a = store.abandon_push(
                i.id, "the control does not hold it: the push was interrupted before the program was in place");
            !a) {
          return a.error();
        }
        ++report.abandoned;
        report.messages.push_back(nc_file.string() + ": " + what +
                                  " never reached the control; its interrupted push is abandoned");
      }
    }
  }
  if (files.is_directory(directory_of(nc_file))) {
    Result<int> removed = files.remove_leftovers(nc_file);
    if (!removed) return removed.error();
    report.leftovers_removed = *removed;
    if (*removed > 0) {
      report.messages.push_back(nc_file.string() + ": removed " + std::to_string(*removed) +
                                " temporary file(s) left by an interrupted write");
    }
  }
  return report;
}

void merge_into(ReconcileReport& total, ReconcileReport one) {
  total.completed += one.completed;
  total.abandoned += one.abandoned;
  total.leftovers_removed += one.leftovers_removed;
  for (std::string& m : one.messages) total.messages.push_back(std::move(m));
}

}  // namespace

Result<ReconcileReport> reconcile_pushes(RunStore& store, const std::filesystem::path& nc_file, NcFiles& files) {
  if (!files.is_directory(directory_of(nc_file))) {
    // No directory, no file and no leftovers: every open intent never reached the control.
    return reconcile_locked(store, nc_file, files);
  }
  Result<DirectoryLock> lock = files.lock_directory(directory_of(nc_file));
  if (!lock) return lock.error();
  return reconcile_locked(store, nc_file, files);
}

Result<ReconcileReport> reconcile_all_pushes(RunStore& store) {
  Result<std::vector<PushIntent>> open = store.open_push_intents();
  if (!open) return open.error();
  ReconcileReport total;
  for (const PushIntent& i : *open) {
    Result<ReconcileReport> one = reconcile_pushes(store, i.push.nc_file);
    if (!one) return one.error();
    merge_into(total, std::move(*one));
  }
  return total;
}

Result<PushCompletion> push_program(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                                    const RenderForVersion& render, const PushOptions& options) {
  auto reached = [&options](PushStep step) {
    if (options.observer) options.observer(step);
  };
  NcFiles& files = options.files != nullptr ? *options.files : real_nc_files();
  Result<DirectoryLock> lock = files.lock_directory(directory_of(nc_file));
  if (!lock) return lock.error();
  if (Result<ReconcileReport> r = reconcile_locked(store, nc_file, files); !r) return r.error();
  if (!options.overwrite_edited) {
    if (Status c = check_not_edited_by_hand(store, nc_file, files); !c) return c.error();
  }
  Result<int> version = store.next_table_version(nc_file.string());
  if (!version) return version.error();
  Result<std::string> program = render(*version);
  if (!program) return program.error();
  const std::string what = "run " + std::to_string(facts.run_id) + ": table version " + std::to_string(*version);
  auto not_pushed = [&what](Error e) {
    e.message = what + " was not pushed (the program on the control is unchanged): " + e.message;
    return e;
  };

  PushIntent intent;
  intent.run_id = facts.run_id;
  intent.push.nc_file = nc_file.string();
  intent.push.table_version = *version;
  intent.push.reason = facts.reason;
  intent.push.table = facts.table;
  intent.push.program_text = *program;
  intent.pending_id = facts.pending_id;
  intent.approved_by = facts.approved_by;
  intent.note = facts.note;
  Result<std::int64_t> intent_id = store.begin_push(intent);
  if (!intent_id) return not_pushed(intent_id.error());
  reached(PushStep::kIntentRecorded);

  Status written = files.write_program(nc_file, *program, [&reached](AtomicWriteStep step) {
    switch (step) {
      case AtomicWriteStep::kTemporaryWritten:
        return reached(PushStep::kTemporaryWritten);
      case AtomicWriteStep::kFlushed:
        return reached(PushStep::kFlushed);
      case AtomicWriteStep::kRenamed:
        return reached(PushStep::kRenamed);
    }
  });
  if (!written) {
    // Best effort: should this fail too, the next push finds the intent open, the file
    // without its program, and abandons it then.
    (void)store.abandon_push(*intent_id, "the write failed: " + written.error().message);
    return not_pushed(written.error());
  }
  Result<PushCompletion> done = store.complete_push(*intent_id, "written");
  if (!done) {
    Error e = done.error();
    e.message = what + " was written to " + nc_file.string() +
                " and is on the control, but its record was not completed (" + e.message +
                "); the push journal holds it, and the next push to this file or `gaugeloop nc reconcile` "
                "records it";
    return e;
  }
  reached(PushStep::kRecorded);
  return done;
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
  facts.table = t->table;
  facts.pending_id = pending_id;
  facts.approved_by = by;
  facts.note = note;
  PushOutcome out;
  out.nc_file = t->nc_file;
  out.run_id = t->run_id;
  const std::string& text = t->program_text;
  PushOptions options;
  options.overwrite_edited = overwrite_edited;
  Result<PushCompletion> pushed = push_program(
      store, t->nc_file, facts, [&text](int version) { return with_table_version(text, version); }, options);
  if (!pushed) return pushed.error();
  out.table_version = pushed->table_version;
  out.decision_recorded = pushed->decision_recorded;
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
  facts.table = old->table;
  const std::string& text = *old->program_text;
  Result<PushCompletion> pushed =
      push_program(store, nc_file, facts, [&text](int version) { return with_table_version(text, version); });
  if (!pushed) return pushed.error();
  return PushOutcome{nc_file, pushed->table_version, old->run_id, true};
}

}  // namespace gaugeloop
