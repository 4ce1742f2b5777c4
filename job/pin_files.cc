// The Y table program beside a crankpin's X table, and the push of both.
#include "job/pin_files.h"

#include "nc_out/main_program.h"
#include "nc_out/table_program.h"

namespace gaugeloop {

std::filesystem::path y_table_program_path(const std::filesystem::path& nc_file) {
  return nc_file.parent_path() / (pin_y_program_name(nc_file.stem().string()) + ".SPF");
}

Status write_program_beside(const std::filesystem::path& path, std::string_view text, std::string_view what,
                            NcFiles& files) {
  Result<DirectoryLock> lock = files.lock_directory(path.parent_path());
  if (!lock) return lock.error();
  if (Result<int> removed = files.remove_leftovers(path); !removed) return removed.error();
  return write_program_read_back(files, path, text, what);
}

Result<PushCompletion> push_pin_programs(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                                         const RenderForVersion& render_x, const RenderYForVersion& render_y,
                                         const PushOptions& options) {
  NcFiles& files = options.files != nullptr ? *options.files : real_nc_files();
  // Settled first, so the version asked for now is the one push_program will take.
  if (Result<ReconcileReport> r = reconcile_pushes(store, nc_file, files); !r) return r.error();
  Result<int> version = store.next_table_version(nc_file.string());
  if (!version) return version.error();
  const std::filesystem::path y_path = y_table_program_path(nc_file);
  Result<std::string> y_text = render_y(*version);
  if (!y_text) return y_text.error();
  Result<ParsedTable> y = parse_table_program(*y_text, y_path.string());
  if (!y) return y.error();
  if (y->following_axis != "Y") {
    return make_error(ErrorCode::kInvalidInput, y_path.string() + ": the Y table program defines a table for " +
                                                    y->following_axis + " (CTABDEF line " +
                                                    std::to_string(y->ctabdef_line) +
                                                    "); its template must say CTABDEF(Y,C,...)");
  }
  if (Status s = verify_table_checksum(*y, y_path.string()); !s) {
    return make_error(ErrorCode::kInvalidInput, s.error().message);
  }
  PushOptions with_y = options;
  with_y.beside.push_back(ProgramBeside{PushFileRole::kY, y_path, *y_text});
  Result<PushCompletion> done = push_program(store, nc_file, facts, render_x, with_y);
  if (!done) return done;
  if (done->table_version != *version) {
    return make_error(ErrorCode::kStorage, nc_file.string() + ": the X table became version " +
                                               std::to_string(done->table_version) + " but " + y_path.string() +
                                               " was written for version " + std::to_string(*version) +
                                               " (another push came between); push again");
  }
  return done;
}

}  // namespace gaugeloop
