// The push: hand-edit check, table version, atomic write, record.
#include "job/nc_push.h"

#include <charconv>
#include <cstdio>
#include <map>
#include <set>

#include "core/atomic_file.h"
#include "core/number_text.h"
#include "core/utc_time.h"
#include "job/pin_files.h"
#include "job/speed_files.h"
#include "nc_out/infeed.h"
#include "nc_out/main_program.h"
#include "nc_out/nc_text.h"
#include "nc_out/slide_compensation.h"
#include "nc_out/stroke_program.h"
#include "nc_out/table_layer.h"
#include "nc_out/table_program.h"
#include "report/run_json.h"

namespace gaugeloop {
namespace {

constexpr std::string_view kVersionLine = "; gaugeloop table_version: ";

// What a pushed program is: a curve table (a cam's, a pin's), a gear's stroke, or the slides'
// compensation tables (their LEC file, the CEC file beside it).
enum class ProgramKind { kTable, kStroke, kSlides };

ProgramKind kind_of_program(std::string_view text) {
  if (is_stroke_program(text)) return ProgramKind::kStroke;
  if (is_slide_compensation(text)) return ProgramKind::kSlides;
  return ProgramKind::kTable;
}

std::string_view program_kind_word(ProgramKind kind) {
  switch (kind) {
    case ProgramKind::kStroke:
      return "stroke program";
    case ProgramKind::kSlides:
      return "slide tables";
    case ProgramKind::kTable:
      break;
  }
  return "table";
}

}  // namespace

Error refused_as_edited(const std::filesystem::path& nc_file, const std::string& what, std::string_view again) {
  return make_error(ErrorCode::kRefused, "NC program " + nc_file.string() + " " + what +
                                             ". gaugeloop does not overwrite it: to keep the change, copy the file "
                                             "elsewhere; then remove it and push again, or " +
                                             std::string(again));
}

namespace {

Error refused(const std::filesystem::path& nc_file, const std::string& what, const std::string& last,
              ProgramKind kind = ProgramKind::kTable) {
  const std::string_view again =
      kind == ProgramKind::kStroke   ? "push the stroke with `gaugeloop gear stroke --overwrite-edited`"
      : kind == ProgramKind::kSlides ? "write the slide tables with `gaugeloop gear slides --overwrite-edited`"
                                     : "approve the pending table with `gaugeloop nc approve ID --overwrite-edited` "
                                       "(`gaugeloop nc pending` lists them)";
  return refused_as_edited(nc_file, what + last, again);
}

}  // namespace

namespace {

std::string header_value(const std::map<std::string, std::string>& header, const std::string& key) {
  auto it = header.find(key);
  return it == header.end() ? std::string("?") : it->second;
}

std::string header_value(const ParsedTable& t, const std::string& key) { return header_value(t.header, key); }

std::string_view push_file_what(PushFileRole role) {
  switch (role) {
    case PushFileRole::kMain:
      return "main program";
    case PushFileRole::kSpeed:
      return "speed program";
    case PushFileRole::kY:
      return "Y table";
    case PushFileRole::kCec:
      return "CEC table";
    case PushFileRole::kTable:
      break;
  }
  return "table";
}

// A program on the control, or as pushed, read for the hand-edit check: a curve table, a
// gear's stroke or the slides' tables.
struct ProgramRead {
  std::map<std::string, std::string> header;
  std::optional<ParsedTable> table;
  std::optional<ParsedStrokeProgram> stroke;
  std::optional<std::vector<SlideCompensationTable>> slides;
  ProgramKind kind() const {
    return stroke ? ProgramKind::kStroke : slides ? ProgramKind::kSlides : ProgramKind::kTable;
  }
};

// Reads `text` as the program it says it is. `edited` is set when it reads but its body does
// not match its checksum (or, for a stroke, its point count): a hand edit rather than a file
// gaugeloop never wrote.
Result<ProgramRead> read_program(std::string_view text, const std::string& name, bool& edited) {
  edited = false;
  ProgramRead r;
  if (is_slide_compensation(text)) {
    Result<std::vector<SlideCompensationTable>> t = parse_slide_compensation(text, name);
    if (!t) {
      edited = t.error().code == ErrorCode::kRefused;
      return t.error();
    }
    r.header = program_header(text);
    r.slides = std::move(*t);
    return r;
  }
  if (is_stroke_program(text)) {
    Result<ParsedStrokeProgram> p = parse_stroke_program(text, name);
    if (!p) {
      edited = p.error().code == ErrorCode::kRefused;
      return p.error();
    }
    r.header = p->header;
    r.stroke = std::move(*p);
    return r;
  }
  Result<ParsedTable> t = parse_table_program(text, name);
  if (!t) return t.error();
  if (Status v = verify_table_checksum(*t, name); !v) {
    edited = true;
    return v.error();
  }
  r.header = t->header;
  r.table = std::move(*t);
  return r;
}

// Whether `here` holds the points `pushed` holds: a table as compare_table_points compares
// them, a stroke point for point as written.
Status compare_points(const ProgramRead& here, const ProgramRead& pushed, const std::string& name) {
  if (here.table && pushed.table) return compare_table_points(*here.table, pushed.table->points, name);
  if (here.kind() != pushed.kind()) {
    return make_error(ErrorCode::kRefused, name + " holds " + std::string(program_kind_word(here.kind())) + " where " +
                                               std::string(program_kind_word(pushed.kind())) + " were pushed");
  }
  if (here.slides) {
    // Table by table, value by value, as the control reads them.
    const std::vector<SlideCompensationTable>& a = *here.slides;
    const std::vector<SlideCompensationTable>& b = *pushed.slides;
    for (std::size_t t = 0; t < std::max(a.size(), b.size()); ++t) {
      if (t >= a.size() || t >= b.size() || a[t].kind != b[t].kind || a[t].input_axis != b[t].input_axis ||
          a[t].output_axis != b[t].output_axis || a[t].min_mm != b[t].min_mm || a[t].step_mm != b[t].step_mm ||
          a[t].error_mm != b[t].error_mm) {
        return make_error(ErrorCode::kRefused, name + ": table " + std::to_string(t + 1) + " is not the one pushed");
      }
    }
    return {};
  }
  const std::vector<StrokeProgramPoint>& a = here.stroke->points;
  const std::vector<StrokeProgramPoint>& b = pushed.stroke->points;
  if (a.size() != b.size()) {
    return make_error(ErrorCode::kRefused, name + " has " + std::to_string(a.size()) +
                                               " spline points, the push wrote " + std::to_string(b.size()));
  }
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (a[i].z_mm != b[i].z_mm || a[i].sim_deg != b[i].sim_deg) {
      return make_error(ErrorCode::kRefused, name + ":" + std::to_string(here.stroke->point_lines[i]) + ": Z" +
                                                 format_fixed(a[i].z_mm, 4) + " SIM1=" + format_fixed(a[i].sim_deg, 6) +
                                                 " where the push wrote Z" + format_fixed(b[i].z_mm, 4) +
                                                 " SIM1=" + format_fixed(b[i].sim_deg, 6));
    }
  }
  return {};
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
  bool edited = false;
  Result<ProgramRead> on_control = read_program(text, name, edited);
  if (!on_control) {
    return refused(nc_file,
                   edited ? "was edited by hand" : (*last ? "was changed by hand" : "was not written by gaugeloop"),
                   since + " (" + on_control.error().message + ")", kind_of_program(text));
  }
  if (*last && (**last).program_text) {
    Result<ProgramRead> pushed = read_program(*(**last).program_text, name + " as pushed", edited);
    if (!pushed) return pushed.error();
    // Its identity first: a gaugeloop program of another run or version copied in is not the
    // program last pushed, even with the same points.
    const std::string thing(program_kind_word(on_control->kind()));
    // Sound, newer than any push the history holds, and of a run whose id the database handed
    // out and no longer holds: a push the database lost, not a hand edit.
    const std::string here_version = header_value(on_control->header, "table_version");
    const std::string here_run = header_value(on_control->header, "run_id");
    int version = 0;
    std::int64_t run = 0;
    std::from_chars(here_version.data(), here_version.data() + here_version.size(), version);
    std::from_chars(here_run.data(), here_run.data() + here_run.size(), run);
    Result<bool> lost = version > (**last).table_version ? store.lost_run(run) : Result<bool>(false);
    if (!lost) return lost.error();
    if (*lost) {
      return refused(nc_file,
                     "holds " + thing + " version " + here_version + " of run " + here_run +
                         ", newer than any push the history holds",
                     " (its last is version " + std::to_string((**last).table_version) +
                         "): the run database lost that push (its write-ahead log deleted after a commit, or the "
                         "file restored from an older copy; `gaugeloop events` names the commits lost)",
                     on_control->kind());
    }
    for (const char* key : {"run_id", "table_version", "body_checksum_fnv1a64"}) {
      const std::string here = header_value(on_control->header, key);
      const std::string pushed_value = header_value(pushed->header, key);
      if (here != pushed_value) {
        return refused(nc_file, "is not the " + thing + " last pushed",
                       since + " (its header says " + key + " " + here + ", the push recorded " + pushed_value +
                           "; it holds " + thing + " version " + header_value(on_control->header, "table_version") +
                           " of run " + header_value(on_control->header, "run_id") + ")",
                       on_control->kind());
      }
    }
    if (Status c = compare_points(*on_control, *pushed, name); !c) {
      return refused(nc_file, "is not the " + thing + " last pushed", since + " (" + c.error().message + ")",
                     on_control->kind());
    }
  }
  return {};
}

namespace {

// `program` with the value of its `key` header line (`; gaugeloop key: value`) set to `value`;
// unchanged when it has no such line.
std::string with_header_value(std::string_view program, std::string_view key, const std::string& value) {
  const std::string prefix = "; gaugeloop " + std::string(key) + ": ";
  const std::size_t at = program.find(prefix);
  if (at == std::string_view::npos || (at > 0 && program[at - 1] != '\n')) return std::string(program);
  const std::size_t from = at + prefix.size();
  std::size_t end = program.find('\n', from);
  if (end == std::string_view::npos) end = program.size();
  if (end > from && program[end - 1] == '\r') --end;  // keep a carriage return
  return std::string(program.substr(0, from)) + value + std::string(program.substr(end));
}

// The table numbers a program's header names (`; gaugeloop table_numbers: A B`), if any.
std::optional<TableNumbers> header_table_numbers(std::string_view program) {
  constexpr std::string_view kNumbers = "; gaugeloop table_numbers: ";
  const std::size_t at = program.find(kNumbers);
  if (at == std::string_view::npos || (at > 0 && program[at - 1] != '\n')) return std::nullopt;
  TableNumbers n{0, 0};
  const std::string line(program.substr(at + kNumbers.size(), program.find('\n', at) - at - kNumbers.size()));
  if (std::sscanf(line.c_str(), "%d %d", &n[0], &n[1]) != 2) return std::nullopt;
  return n;
}

// `program` with CTABDEF's table number (its third argument) set to `number`; the table body
// and so its checksum are untouched.
Result<std::string> with_ctabdef_number(const std::string& program, int number) {
  Result<ParsedTable> t = parse_table_program(program, "the program");
  if (!t) return t.error();
  std::size_t begin = 0;
  for (int line = 1; line < t->ctabdef_line; ++line) begin = program.find('\n', begin) + 1;
  const std::size_t open = program.find('(', begin);
  const std::size_t first = program.find(',', open);
  const std::size_t second = program.find(',', first + 1);
  const std::size_t third = program.find_first_of(",)", second + 1);
  if (open == std::string::npos || first == std::string::npos || second == std::string::npos ||
      third == std::string::npos) {
    return make_error(ErrorCode::kInvalidInput, "the program's CTABDEF has no table number to set");
  }
  return program.substr(0, second + 1) + std::to_string(number) + program.substr(third);
}

}  // namespace

Result<std::string> with_table_version(std::string_view program, int table_version) {
  const std::size_t at = program.find(kVersionLine);
  if (at == std::string_view::npos || (at > 0 && program[at - 1] != '\n')) {
    return make_error(ErrorCode::kInvalidInput,
                      "the program has no `; gaugeloop table_version:` header line; its template needs "
                      "{{table_header}} (docs/nc_output.md)");
  }
  std::string out = with_header_value(program, "table_version", std::to_string(table_version));
  // A table that alternates goes to the number of its new version; one written before the
  // header named its numbers keeps its number.
  const std::optional<TableNumbers> numbers = header_table_numbers(out);
  if (!numbers) return out;
  const int number = table_number_for_version(*numbers, table_version);
  out = with_header_value(out, "table_number", std::to_string(number));
  return with_ctabdef_number(out, number);
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
    case PushStep::kMainWritten:
      return "main program written";
    case PushStep::kRecorded:
      return "recorded";
  }
  return "?";
}

std::string stale_main_text(const StaleMain& stale) {
  return stale.main_file.filename().string() + " couples table " + std::to_string(stale.coupled_number) +
         ", that of version " + std::to_string(stale.coupled_version) + ", while " + stale.nc_file.filename().string() +
         " on the control is version " + std::to_string(stale.table_version) + " (table " +
         std::to_string(stale.table_number) + "): the control grinds version " + std::to_string(stale.coupled_version);
}

std::string push_file_mismatch_text(const PushFileMismatch& m) {
  const std::string name = std::filesystem::path(m.file.path).filename().string();
  const std::string what = std::string(push_file_what(m.file.role));
  const std::string version = std::to_string(m.file.table_version);
  if (m.missing) return name + " is not on the control: the " + what + " of version " + version + " is missing";
  if (m.written_for) {
    return name + " holds the " + what + " written for version " + std::to_string(*m.written_for) +
           ", not that of version " + version + ", the version in force";
  }
  return name + " is not the " + what + " version " + version + " wrote";
}

Result<std::vector<PushFileMismatch>> compare_push_files(const RunStore& store, const std::filesystem::path& nc_file,
                                                         NcFiles& files) {
  Result<std::vector<PushFile>> recorded = store.files_of_last_push(nc_file.string());
  if (!recorded) return recorded.error();
  std::vector<PushFileMismatch> out;
  for (const PushFile& f : *recorded) {
    if (f.role == PushFileRole::kTable) continue;
    Result<std::optional<std::string>> held = files.read_program(f.path);
    if (!held) return held.error();
    PushFileMismatch m;
    m.file = f;
    if (!*held) {
      m.missing = true;
    } else {
      const std::string hash = settings_hash(**held);
      if (hash == f.hash) continue;
      Result<std::optional<int>> wrote = store.version_that_wrote(f.path, hash);
      if (!wrote) return wrote.error();
      m.written_for = *wrote;
    }
    out.push_back(std::move(m));
  }
  return out;
}

Result<std::optional<StaleMain>> find_stale_main(const RunStore& store, const std::filesystem::path& nc_file,
                                                 NcFiles& files) {
  const std::filesystem::path main_file = main_program_path(nc_file);
  Result<std::optional<std::string>> main_text = files.read_program(main_file);
  if (!main_text) return main_text.error();
  Result<std::optional<std::string>> table_text = files.read_program(nc_file);
  if (!table_text) return table_text.error();
  if (!*main_text || !*table_text || is_stroke_program(**table_text)) return std::optional<StaleMain>();
  Result<ParsedTable> table = parse_table_program(**table_text, nc_file.string());
  if (!table) return std::optional<StaleMain>();
  Result<int> coupled = coupled_table_number(**main_text, main_file.string(), table->following_axis);
  if (!coupled || *coupled == table->table_number) return std::optional<StaleMain>();
  StaleMain stale;
  stale.main_file = main_file;
  stale.nc_file = nc_file;
  stale.coupled_number = *coupled;
  stale.table_number = table->table_number;
  const std::string version = header_value(*table, "table_version");
  std::from_chars(version.data(), version.data() + version.size(), stale.table_version);
  // The version the coupled table holds: the newest other push that went to that number.
  Result<std::optional<NcPush>> last = store.last_push(nc_file.string());
  if (!last) return last.error();
  for (int v = *last ? (**last).table_version : 0; v >= 1; --v) {
    if (v == stale.table_version) continue;
    Result<NcPush> push = store.load_push(nc_file.string(), v);
    if (!push) return push.error();
    if (!push->program_text) break;  // pushed before program texts were kept: cannot tell
    Result<ParsedTable> t = parse_table_program(*push->program_text, nc_file.string());
    if (t && t->table_number == *coupled) {
      stale.coupled_version = v;
      return std::optional<StaleMain>(stale);
    }
  }
  return std::optional<StaleMain>();
}

namespace {

Result<MainProgramSource> main_for_run(const RunStore& store, std::int64_t run_id, MainProgramSource main,
                                       const std::string& nc_file, std::string_view what,
                                       std::string_view program_text = {});

// Writes the main program again for the table on the control, when it is the one last pushed
// and `main` can render it; "" when written, otherwise why not.
Result<std::string> repoint_main(const RunStore& store, const StaleMain& stale, const MainProgramSource& main,
                                 NcFiles& files) {
  Result<std::optional<NcPush>> last = store.last_push(stale.nc_file.string());
  if (!last) return last.error();
  Result<std::optional<std::string>> on_control = files.read_program(stale.nc_file);
  if (!on_control) return on_control.error();
  if (!*last || !(**last).program_text || !*on_control || **on_control != *(**last).program_text) {
    return std::string("the table on the control is not the one last pushed");
  }
  // As the last push wrote it, when it recorded its files.
  Result<std::vector<PushFile>> recorded = store.files_of_last_push(stale.nc_file.string());
  if (!recorded) return recorded.error();
  for (const PushFile& f : *recorded) {
    if (f.role != PushFileRole::kMain || !f.text) continue;
    if (Status w = write_program_read_back(files, stale.main_file, *f.text, "main program"); !w) {
      return w.error().message;
    }
    return std::string();
  }
  if (main.template_text.empty()) return std::string("no main program template to write it from");
  // A job's own source knows its part (and a C-X-Y pin's Y table); a command's is completed from the run.
  Result<MainProgramSource> source =
      main.y_program_name.empty()
          ? main_for_run(store, (**last).run_id, main, stale.nc_file.string(), "repointed", **on_control)
          : Result<MainProgramSource>(main);
  if (!source) return source.error().message;
  Result<std::string> text = render_main_for_table(*source, stale.nc_file, **on_control);
  if (!text) return text.error().message;
  if (Status w = files.write_program(stale.main_file, *text, {}); !w) return w.error().message;
  return std::string();
}

// The files beside the table that the control does not hold as the last push wrote them, each
// written again when it is missing or holds another push's file of ours (the directory's lock
// held). skip_main: a stale main program was dealt with already.
Result<std::vector<PushFileMismatch>> put_back_files(const RunStore& store, const std::filesystem::path& nc_file,
                                                     NcFiles& files, bool skip_main) {
  Result<std::vector<PushFileMismatch>> found = compare_push_files(store, nc_file, files);
  if (!found) return found.error();
  std::vector<PushFileMismatch> out;
  for (PushFileMismatch& m : *found) {
    if (m.file.role == PushFileRole::kMain && skip_main) continue;
    if ((m.missing || m.written_for) && m.file.text) {
      Status w = write_program_read_back(files, m.file.path, *m.file.text, push_file_what(m.file.role));
      if (!w) return w.error();
      m.restored = true;
    }
    out.push_back(std::move(m));
  }
  return out;
}

// RunStore::check_ids, what it found said in `report`.
Status check_ids_into(RunStore& store, ReconcileReport& report) {
  Result<std::optional<LostCommits>> lost = store.check_ids();
  if (!lost) return lost.error();
  if (*lost) {
    report.lost_commits = **lost;
    report.messages.push_back(lost_commits_text(store.path(), **lost));
  }
  return {};
}

// reconcile_pushes with the directory's lock already held.
Result<ReconcileReport> reconcile_locked(RunStore& store, const std::filesystem::path& nc_file, NcFiles& files,
                                         const MainProgramSource* main) {
  ReconcileReport report;
  if (Status ids = check_ids_into(store, report); !ids) return ids.error();
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
        (void)store.mark_ids();  // best effort, as after any push recorded
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
  if (!files.is_directory(directory_of(nc_file))) return report;
  for (const std::filesystem::path& path : files_of_push(nc_file)) {
    Result<int> removed = files.remove_leftovers(path);
    if (!removed) return removed.error();
    report.leftovers_removed += *removed;
    if (*removed > 0) {
      report.messages.push_back(path.string() + ": removed " + std::to_string(*removed) +
                                " temporary file(s) left by an interrupted write");
    }
  }
  Result<std::optional<StaleMain>> stale = find_stale_main(store, nc_file, files);
  if (!stale) return stale.error();
  if (*stale) {
    StaleMain& found = **stale;
    Result<std::string> not_repointed =
        repoint_main(store, found, main != nullptr ? *main : MainProgramSource{}, files);
    if (!not_repointed) return not_repointed.error();
    found.repointed = not_repointed->empty();
    report.messages.push_back(found.main_file.string() + ": " + stale_main_text(found) +
                              (found.repointed
                                   ? "; written again, it couples table " + std::to_string(found.table_number) +
                                         " of version " + std::to_string(found.table_version)
                                   : "; left as it is (" + *not_repointed +
                                         "): `gaugeloop nc reconcile` with the main template writes it again"));
    report.stale_mains.push_back(found);
  }
  Result<std::vector<PushFileMismatch>> beside = put_back_files(store, nc_file, files, stale->has_value());
  if (!beside) return beside.error();
  for (PushFileMismatch& m : *beside) {
    report.messages.push_back(m.file.path + ": " + push_file_mismatch_text(m) +
                              (m.restored ? "; written again as that push wrote it"
                                          : "; left as it is: no push of gaugeloop wrote what it holds (edited by "
                                            "hand?); copy it elsewhere to keep it, remove it, and reconcile again"));
    report.files.push_back(std::move(m));
  }
  return report;
}

void merge_into(ReconcileReport& total, ReconcileReport one) {
  total.completed += one.completed;
  total.abandoned += one.abandoned;
  total.leftovers_removed += one.leftovers_removed;
  for (StaleMain& s : one.stale_mains) total.stale_mains.push_back(std::move(s));
  for (PushFileMismatch& f : one.files) total.files.push_back(std::move(f));
  if (!total.lost_commits) total.lost_commits = one.lost_commits;
  for (std::string& m : one.messages) total.messages.push_back(std::move(m));
}

}  // namespace

Result<ReconcileReport> reconcile_pushes(RunStore& store, const std::filesystem::path& nc_file, NcFiles& files,
                                         const MainProgramSource* main) {
  if (!files.is_directory(directory_of(nc_file))) {
    // No directory, no file and no leftovers: every open intent never reached the control.
    return reconcile_locked(store, nc_file, files, main);
  }
  Result<DirectoryLock> lock = files.lock_directory(directory_of(nc_file));
  if (!lock) return lock.error();
  return reconcile_locked(store, nc_file, files, main);
}

Result<int> next_table_version_settled(RunStore& store, const std::filesystem::path& nc_file,
                                       const PushOptions& options) {
  NcFiles& files = options.files ? *options.files : real_nc_files();
  if (Result<ReconcileReport> r = reconcile_pushes(store, nc_file, files); !r) return r.error();
  return store.next_table_version(nc_file.string());
}

Result<ReconcileReport> reconcile_all_pushes(RunStore& store, const MainProgramSource* main, NcFiles& files) {
  ReconcileReport total;
  // Once before any file: a history that lost commits says so even with nothing pushed yet.
  if (Status ids = check_ids_into(store, total); !ids) return ids.error();
  Result<std::vector<PushIntent>> open = store.open_push_intents();
  if (!open) return open.error();
  Result<std::vector<std::string>> pushed = store.pushed_files();
  if (!pushed) return pushed.error();
  std::set<std::string> with_intent;
  for (const PushIntent& i : *open) with_intent.insert(i.push.nc_file);
  std::set<std::string> nc_files(pushed->begin(), pushed->end());
  nc_files.insert(with_intent.begin(), with_intent.end());
  for (const std::string& nc_file : nc_files) {
    Result<ReconcileReport> one = reconcile_pushes(store, nc_file, files, main);
    if (!one && with_intent.count(nc_file) != 0) return one.error();
    if (!one) {
      // Only looked at for a stale main program or leftovers: a share that cannot be read now
      // (or a lock held) is said, and stops nothing; the next push to it reconciles it.
      total.messages.push_back(nc_file + ": not checked (" + one.error().message + ")");
      continue;
    }
    merge_into(total, std::move(*one));
  }
  return total;
}

std::filesystem::path main_program_path(const std::filesystem::path& nc_file) {
  return nc_file.parent_path() / (nc_file.stem().string() + "_MAIN.MPF");
}

std::vector<std::filesystem::path> files_of_push(const std::filesystem::path& nc_file) {
  std::vector<std::filesystem::path> out{nc_file, main_program_path(nc_file), speed_program_path(nc_file),
                                         y_table_program_path(nc_file)};
  if (nc_file.filename() == slide_compensation_file_name(SlideTableKind::kLeadscrew)) {
    out.push_back(nc_file.parent_path() / std::string(slide_compensation_file_name(SlideTableKind::kInterpolatory)));
  }
  return out;
}

namespace {

// True when the template names {{infeed_blocks}} or {{speed_infeed_blocks}} (any of Mustache's
// forms): the main program feeds the wheel to size.
bool has_infeed_placeholder(std::string_view text) {
  for (std::string_view name : {"infeed_blocks", "speed_infeed_blocks"}) {
    for (const std::string& tag :
         {"{{" + std::string(name) + "}}", "{{{" + std::string(name) + "}}}", "{{&" + std::string(name) + "}}"}) {
      if (text.find(tag) != std::string_view::npos) return true;
    }
  }
  return false;
}

}  // namespace

std::string origin_text(std::int64_t run_id) {
  return run_id != 0 ? "run " + std::to_string(run_id) : std::string("the drawing (no part measured yet)");
}

Result<std::string> render_main_for_table(const MainProgramSource& given, const std::filesystem::path& nc_file,
                                          std::string_view table_program) {
  Result<ParsedTable> t = parse_table_program(table_program, nc_file.string());
  if (!t) return t.error();
  Result<LayerOf> layer = layer_of(*t, nc_file.string());
  if (!layer) return layer.error();
  // A correction layer's main program: its own template when one is given, and the design
  // table beside the layer, where the wheel starts.
  MainProgramSource layered;
  std::optional<DesignTable> design;
  if (!layer->design_program.empty()) {
    layered = given;
    if (!given.layer_template_text.empty()) {
      layered.template_text = given.layer_template_text;
      layered.template_name = given.layer_template_name;
    }
    const std::filesystem::path design_file = nc_file.parent_path() / (layer->design_program + ".SPF");
    std::string text = given.design_table_program;
    if (text.empty()) {
      NcFiles& files = given.files != nullptr ? *given.files : real_nc_files();
      Result<std::optional<std::string>> read = files.read_program(design_file);
      if (!read) return read.error();
      if (!*read) {
        return make_error(ErrorCode::kInvalidInput,
                          design_file.string() + " is not there: the correction layer " + nc_file.string() +
                              " is added to that design table, so the main program cannot couple it; write the "
                              "first program from the drawing (`gaugeloop nc new`)");
      }
      text = std::move(**read);
    }
    Result<DesignTable> d = read_design_table(text, design_file.string(), layer->design_table_number);
    if (!d) return d.error();
    design = std::move(*d);
  }
  const MainProgramSource& source = design ? layered : given;
  std::map<std::string, std::string> values = {
      {"program_name", nc_file.stem().string()},
      {"part", source.part},
      {"lobe", std::to_string(source.lobe)},
      {"version", GAUGELOOP_VERSION},
      {"run_id", header_value(*t, "run_id")},
      {"origin", header_value(*t, "run_id") == "0" ? origin_text(0) : "run " + header_value(*t, "run_id")},
      {"created_utc", source.created_utc.empty() ? utc_now() : source.created_utc},
      {"table_version", header_value(*t, "table_version")},
      {"table_number", std::to_string(t->table_number)},
      {"table_start_c_deg", format_fixed(t->points.front().c_deg, 3)},
      {"point_count", std::to_string(t->points.size())},
      {"interpolation", std::string(interpolation_name(t->interpolation))}};
  // The passes from blank to size: the part's cycle as the table's header carries it (a table
  // pushed before it did: the defaults at 60 rpm on the 0.1 um grid).
  if (!has_infeed_placeholder(source.template_text)) {
    return make_error(
        ErrorCode::kInvalidInput,
        source.template_name +
            ": no {{infeed_blocks}} (or {{speed_infeed_blocks}} with a speed subprogram): the main program "
            "would couple the wheel to the part and never feed it from the stock to size; put it after the "
            "coupling, as examples/sinumerik/cam_main.mpf does (docs/nc_output.md, \"Allowance and infeed\")");
  }
  CycleOnControl cycle;
  if (auto it = t->header.find("grinding_cycle"); it != t->header.end()) {
    Result<CycleOnControl> read = read_grinding_cycle_text(it->second);
    if (!read) return make_error(ErrorCode::kInvalidInput, nc_file.string() + ": " + read.error().message);
    cycle = *read;
  }
  Result<InfeedPlan> infeed = plan_infeed(cycle.cycle, cycle.format);
  if (!infeed) return infeed.error();
  values["infeed_blocks"] = render_infeed_blocks(*infeed, cycle.work_speed_rpm, cycle.format);
  values["speed_infeed_blocks"] = render_speed_infeed_blocks(*infeed, speed_program_name(nc_file.stem().string()));
  values["start_offset_mm"] = format_fixed(infeed->start_offset_mm, cycle.format.x_decimals());
  // Where the wheel is at C: the table, plus the design table under a layer.
  auto design_at = [&design](double c_deg) { return design ? design->nc.at(c_deg).x_mm : 0.0; };
  const double c_start = t->points.front().c_deg;
  values["start_x_mm"] =
      format_fixed(t->points.front().x_mm + design_at(c_start) + infeed->start_offset_mm, cycle.format.x_decimals());
  Result<TableInterpolant> nc = TableInterpolant::of(t->points, t->interpolation);
  if (!nc) return make_error(ErrorCode::kInvalidInput, nc_file.string() + ": " + nc.error().message);
  values["start_x_at_c0_mm"] =
      format_fixed(nc->at(0.0).x_mm + design_at(0.0) + infeed->start_offset_mm, cycle.format.x_decimals());
  if (design) {
    values["design_program_name"] = layer->design_program;
    values["design_table_number"] = std::to_string(layer->design_table_number);
    values["leading_axis"] = std::string(kLayerLeadingAxis);
  }
  values["infeed_turns"] = std::to_string(infeed->turns());
  if (!source.y_program_name.empty()) {
    // The Y table of a version goes to the number of that version, as the X table does.
    const std::string version_text = header_value(*t, "table_version");
    std::int64_t version = 0;
    std::from_chars(version_text.data(), version_text.data() + version_text.size(), version);
    values["y_program_name"] = source.y_program_name;
    values["y_table_number"] = std::to_string(table_number_for_version(source.y_table_numbers, version));
  }
  Result<std::string> main = render_main_program(source.template_text, source.template_name, values);
  // The main program is loaded the way its table is: with an archive header when the table has one.
  if (!main || !has_archive_header(table_program)) return main;
  Result<std::string> header = archive_header(nc_file.stem().string() + "_MAIN", NcProgramKind::kMainProgram);
  if (!header) return header.error();
  return *header + *main;
}

Result<std::string> render_main_for_stroke(const MainProgramSource& source, const std::filesystem::path& nc_file,
                                           std::string_view stroke_program) {
  Result<ParsedStrokeProgram> p = parse_stroke_program(stroke_program, nc_file.string());
  if (!p) return make_error(ErrorCode::kInvalidInput, p.error().message);
  const std::map<std::string, std::string>& h = p->header;
  auto missing = [&nc_file](const std::string& key) {
    return make_error(ErrorCode::kInvalidInput, nc_file.string() + ": the stroke program's header has no readable `" +
                                                    key + "`; the main program's gearbox cannot be written from it");
  };
  GearboxFactors f;
  const std::string s_bc = header_value(h, "s_bc");
  if (std::sscanf(s_bc.c_str(), "%d/%d", &f.b_numerator, &f.b_denominator) != 2 || f.b_denominator <= 0) {
    return missing("s_bc");
  }
  const std::optional<double> z = nc_text::parse_number(header_value(h, "s_zc_deg_per_mm"));
  if (!z) return missing("s_zc_deg_per_mm");
  const std::optional<double> y = nc_text::parse_number(header_value(h, "s_yc_deg_per_mm"));
  if (!y) return missing("s_yc_deg_per_mm");
  f.z_deg_per_mm = *z;
  f.y_deg_per_mm = *y;
  const std::string run_id = header_value(h, "run_id");
  const std::map<std::string, std::string> values = {
      {"program_name", nc_file.stem().string()},
      {"part", source.part.empty() ? header_value(h, "part") : source.part},
      {"version", GAUGELOOP_VERSION},
      {"run_id", run_id},
      {"origin",
       run_id == "0" || run_id == "?" ? std::string("the axes' errors (no gear measured yet)") : "run " + run_id},
      {"created_utc", source.created_utc.empty() ? utc_now() : source.created_utc},
      {"table_version", header_value(h, "table_version")},
      {"point_count", std::to_string(p->points.size())},
      {"sim_max_abs_deg", header_value(h, "sim_max_abs_deg")},
      {"gearbox_coupling", render_gearbox_coupling(f)}};
  const bool gear = !source.gear_template_text.empty();
  return render_gear_main_program(gear ? source.gear_template_text : source.template_text,
                                  gear ? source.gear_template_name : source.template_name, values);
}

namespace {

// Before a table goes to `number`: a main program on the control that couples `number` (its
// write after the last table failed or was cut short) is rewritten for the table last pushed,
// whose number differs, so the table a coupling may hold is not the one redefined. Nothing is
// done when there is no main program, it couples another table, or nothing was pushed before.
Status repoint_stale_main(const RunStore& store, const std::filesystem::path& nc_file, const MainProgramSource& main,
                          int number, NcFiles& files) {
  const std::filesystem::path main_file = main_program_path(nc_file);
  Result<std::optional<std::string>> on_disk = files.read_program(main_file);
  if (!on_disk) return on_disk.error();
  if (!*on_disk) return {};
  Result<int> coupled = coupled_table_number(**on_disk, main_file.string());
  if (!coupled || *coupled != number) return {};
  Result<std::optional<NcPush>> last = store.last_push(nc_file.string());
  if (!last) return last.error();
  if (!*last || !(**last).program_text) return {};
  Result<std::string> text = render_main_for_table(main, nc_file, *(**last).program_text);
  if (!text) return text.error();
  Result<int> last_number = coupled_table_number(*text, main_file.string());
  if (!last_number || *last_number == number) return {};
  return files.write_program(main_file, *text, {});
}

}  // namespace

Result<PushCompletion> push_program(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                                    const RenderForVersion& render, const PushOptions& options) {
  auto reached = [&options](PushStep step) {
    if (options.observer) options.observer(step);
  };
  NcFiles& files = options.files != nullptr ? *options.files : real_nc_files();
  Result<DirectoryLock> lock = files.lock_directory(directory_of(nc_file));
  if (!lock) return lock.error();
  if (Result<ReconcileReport> r = reconcile_locked(store, nc_file, files, &options.main); !r) return r.error();
  if (!options.overwrite_edited) {
    if (Status c = check_not_edited_by_hand(store, nc_file, files); !c) return c.error();
  }
  Result<int> version = store.next_table_version(nc_file.string());
  if (!version) return version.error();
  Result<std::string> program = render(*version);
  if (!program) return program.error();
  // A gear's stroke couples no curve table: its main program has no table number to alternate.
  // The slides' tables have no main program: the control loads them at a reset.
  const ProgramKind kind = kind_of_program(*program);
  const bool stroke = kind == ProgramKind::kStroke;
  const bool with_main = kind != ProgramKind::kSlides &&
                         (!options.main.template_text.empty() || (stroke && !options.main.gear_template_text.empty()));
  const std::filesystem::path main_file = main_program_path(nc_file);
  std::string main_text;
  int number = 0;
  if (with_main) {
    Result<std::string> m = stroke ? render_main_for_stroke(options.main, nc_file, *program)
                                   : render_main_for_table(options.main, nc_file, *program);
    if (!m) return m.error();
    main_text = std::move(*m);
    if (!stroke) {
      Result<int> n = coupled_table_number(main_text, main_file.string());
      if (!n) return n.error();
      number = *n;
    }
  }
  const std::string what = "run " + std::to_string(facts.run_id) + ": " +
                           (kind == ProgramKind::kTable ? std::string("table") : std::string(program_kind_word(kind))) +
                           " version " + std::to_string(*version);
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
  for (const ProgramBeside& b : options.beside) {
    intent.files.push_back(PushFile{b.role, b.path.string(), {}, b.text, 0});
  }
  if (with_main) intent.files.push_back(PushFile{PushFileRole::kMain, main_file.string(), {}, main_text, 0});
  if (with_main && !stroke) {
    if (Status r = repoint_stale_main(store, nc_file, options.main, number, files); !r) {
      Error e = r.error();
      e.message = "main program " + main_file.string() + " couples table " + std::to_string(number) +
                  ", the number the new table goes to, and could not be pointed at the table in force: " + e.message;
      return not_pushed(e);
    }
  }
  Result<std::int64_t> intent_id = store.begin_push(intent);
  if (!intent_id) return not_pushed(intent_id.error());
  reached(PushStep::kIntentRecorded);

  // The files beside first, so that a main program calling them never finds them missing;
  // one not written: the push is abandoned and those written are put back.
  for (const ProgramBeside& b : options.beside) {
    Status w = write_program_read_back(files, b.path, b.text, push_file_what(b.role));
    if (w) continue;
    (void)store.abandon_push(*intent_id, "a file beside the table was not written: " + w.error().message);
    Result<std::vector<PushFileMismatch>> put_back = put_back_files(store, nc_file, files, false);
    Error e = w.error();
    if (!put_back) {
      e.message += "; the files beside the table could not be put back as the last push wrote them (" +
                   put_back.error().message + "): `gaugeloop nc reconcile` does it";
    }
    return not_pushed(e);
  }

  bool renamed = false;
  Status written = files.write_program(nc_file, *program, [&reached, &renamed](AtomicWriteStep step) {
    switch (step) {
      case AtomicWriteStep::kTemporaryWritten:
        return reached(PushStep::kTemporaryWritten);
      case AtomicWriteStep::kFlushed:
        return reached(PushStep::kFlushed);
      case AtomicWriteStep::kRenamed:
        renamed = true;
        return reached(PushStep::kRenamed);
    }
  });
  if (!written && renamed) {
    // On the control, but perhaps not after a power cut: neither pushed nor abandoned. The
    // intent stays open; reconciliation records it if the control still holds the program,
    // abandons it if the old one came back.
    Error e = written.error();
    e.message = what + " is on the control, but not known to be on its disk (" + e.message +
                "); the push journal keeps it open, and the next push to this file or `gaugeloop nc reconcile` "
                "records it if the control still holds it";
    return e;
  }
  if (!written) {
    // Best effort: should this fail too, the next push finds the intent open, the file
    // without its program, and abandons it then.
    (void)store.abandon_push(*intent_id, "the write failed: " + written.error().message);
    if (!options.beside.empty()) (void)put_back_files(store, nc_file, files, false);
    return not_pushed(written.error());
  }
  Status main_written;
  bool main_renamed = false;
  if (with_main) {
    main_written = files.write_program(main_file, main_text, [&main_renamed](AtomicWriteStep step) {
      if (step == AtomicWriteStep::kRenamed) main_renamed = true;
    });
    if (main_written) reached(PushStep::kMainWritten);
  }
  Result<PushCompletion> done = store.complete_push(
      *intent_id, main_written ? "written" : "written; the main program was not: " + main_written.error().message);
  // Best effort: the push is recorded; a mark not written only means a loss of it goes unnoticed.
  if (done) (void)store.mark_ids();
  if (done && !main_written && main_renamed) {
    // In place but not known to be on disk (its directory not flushed): after a power cut the
    // control may hold the previous main program again, which reconciliation writes anew.
    Error e = main_written.error();
    e.message = what + " was written to " + nc_file.string() + " and recorded, and the main program " +
                main_file.string() + " coupling it is in place, but not known to be on the control's disk (" +
                e.message +
                "); should a power cut bring the previous one back, `gaugeloop nc check` names it and "
                "`gaugeloop nc reconcile` (or the next push) writes it again";
    return e;
  }
  if (done && !main_written) {
    // The table is on the control and recorded; the main program still couples the previous
    // table, which the new one did not redefine (another number), so the machine grinds with
    // the table it had until a push writes the main program.
    Error e = main_written.error();
    e.message = what + " was written to " + nc_file.string() + " and recorded, but the main program " +
                main_file.string() + " was not written (" + e.message +
                "); it still couples the previous table, which is unchanged. Push again (or `gaugeloop nc "
                "rollback`) once the NC directory takes writes";
    return e;
  }
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

namespace {

// `main` for pushing run `run_id`'s table again (`what`: "approved", "rolled back"), with the
// run's part and lobe where it leaves them open. A C-X pin's table gets main.pin_cx_template
// when there is one. A C-X-Y pin's table is refused: its Y table is written only with a
// measurement, and the X table alone would run with a Y table of another version.
// The part a program written from the drawing (run 0) grinds, from its header: a table
// written before the header named it is taken for a lobe.
RunPart part_of_program(std::string_view program_text, const std::string& nc_file, std::string& name, int& lobe) {
  RunPart part;
  if (is_stroke_program(program_text)) {
    if (Result<ParsedStrokeProgram> p = parse_stroke_program(program_text, nc_file))
      name = header_value(p->header, "part");
    return part;
  }
  Result<ParsedTable> t = parse_table_program(program_text, nc_file);
  if (!t) return part;
  name = header_value(*t, "part");
  const std::string number = header_value(*t, "lobe");
  std::from_chars(number.data(), number.data() + number.size(), lobe);
  const std::string mode = header_value(*t, "pin_mode");
  if (!mode.empty()) {
    part.kind = PartKind::kPin;
    part.pin_mode = pin_mode_from_name(mode);
  }
  return part;
}

Result<MainProgramSource> main_for_run(const RunStore& store, std::int64_t run_id, MainProgramSource main,
                                       const std::string& nc_file, std::string_view what,
                                       std::string_view program_text) {
  std::string part_name;
  int lobe = 0;
  RunPart part;
  if (run_id != 0) {
    Result<StoredRun> run = store.load_run(run_id);
    if (!run) return run.error();
    part = run_part(*run);
    part_name = run->summary.part;
    lobe = run->summary.lobe;
  } else {
    part = part_of_program(program_text, nc_file, part_name, lobe);
  }
  if (part.pin_mode == PinMode::kCXY) {
    return make_error(ErrorCode::kRefused,
                      nc_file + " is the X table of a crankpin ground C-X-Y (" + origin_text(run_id) +
                          "); it cannot be " + std::string(what) +
                          " alone: its Y table is written only with a measurement, and X would run with a Y table of "
                          "another version. Measure the pin again to push a matched pair");
  }
  if (part.pin_mode == PinMode::kCX && !main.pin_cx_template_text.empty()) {
    main.template_text = main.pin_cx_template_text;
    main.template_name = main.pin_cx_template_name;
  }
  if (main.template_text.empty()) return main;
  if (main.part.empty()) main.part = part_name;
  if (main.lobe == 0) main.lobe = lobe;
  return main;
}

}  // namespace

Result<PushOutcome> approve_pending(RunStore& store, std::int64_t pending_id, const std::string& by,
                                    const std::string& note, bool overwrite_edited, const MainProgramSource& main) {
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
  out.gear_run_id = t->gear_run_id;
  const std::string& text = t->program_text;
  out.stroke = is_stroke_program(text);
  PushOptions options;
  options.overwrite_edited = overwrite_edited;
  MainProgramSource approved_main = main;
  if (t->speed_program_text && !main.speed_template_text.empty()) {
    approved_main.template_text = main.speed_template_text;
    approved_main.template_name = main.speed_template_name;
  }
  Result<MainProgramSource> m = main_for_run(store, t->run_id, approved_main, t->nc_file, "approved", text);
  if (!m) return m.error();
  options.main = std::move(*m);
  const RenderForVersion render = [&text](int version) { return with_table_version(text, version); };
  std::optional<std::string> speed;
  if (t->speed_program_text) {
    // The speed subprogram kept with the table, naming the version it goes beside.
    Result<int> next = next_table_version_settled(store, t->nc_file, options);
    if (!next) return next.error();
    speed = with_header_value(*t->speed_program_text, "table_version", std::to_string(*next));
  }
  Result<PushCompletion> pushed = speed ? push_program_with_speed(store, t->nc_file, facts, render, *speed, options)
                                        : push_program(store, t->nc_file, facts, render, options);
  if (!pushed) return pushed.error();
  out.table_version = pushed->table_version;
  out.decision_recorded = pushed->decision_recorded;
  return out;
}

Result<PushOutcome> rollback_to_version(RunStore& store, const std::string& nc_file, int table_version,
                                        const std::string& by, const MainProgramSource& main) {
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
  // The speed subprogram that version was pushed with goes back with it, naming the new version.
  Result<std::vector<PushFile>> old_files = store.files_of_push(nc_file, table_version);
  if (!old_files) return old_files.error();
  std::optional<std::string> old_speed;
  std::optional<PushFile> old_cec;  // the slides' CEC file, beside their LEC file
  for (const PushFile& f : *old_files) {
    if (f.role == PushFileRole::kSpeed && f.text) old_speed = *f.text;
    if (f.role == PushFileRole::kCec && f.text) old_cec = f;
  }
  PushOptions options;
  if (old_cec) {
    Result<int> next = next_table_version_settled(store, nc_file, options);
    if (!next) return next.error();
    options.beside.push_back(
        ProgramBeside{PushFileRole::kCec,
                      std::filesystem::path(nc_file).parent_path() /
                          std::string(slide_compensation_file_name(SlideTableKind::kInterpolatory)),
                      with_header_value(*old_cec->text, "table_version", std::to_string(*next))});
  }
  MainProgramSource rolled_back_main = main;
  if (old_speed && !main.speed_template_text.empty()) {
    rolled_back_main.template_text = main.speed_template_text;
    rolled_back_main.template_name = main.speed_template_name;
  }
  Result<MainProgramSource> m = main_for_run(store, old->run_id, rolled_back_main, nc_file, "rolled back", text);
  if (!m) return m.error();
  options.main = std::move(*m);
  const RenderForVersion render = [&text](int version) { return with_table_version(text, version); };
  std::optional<std::string> speed;
  if (old_speed) {
    Result<int> next = next_table_version_settled(store, nc_file, options);
    if (!next) return next.error();
    speed = with_header_value(*old_speed, "table_version", std::to_string(*next));
  }
  Result<PushCompletion> pushed = speed ? push_program_with_speed(store, nc_file, facts, render, *speed, options)
                                        : push_program(store, nc_file, facts, render, options);
  if (!pushed) return pushed.error();
  PushOutcome out{nc_file, pushed->table_version, old->run_id, true, is_stroke_program(text)};
  out.slides = is_slide_compensation(text);
  return out;
}

}  // namespace gaugeloop
