// The slides' compensation files in the NC directory.
#include "job/slide_files.h"

#include <optional>
#include <system_error>

namespace gaugeloop {

std::filesystem::path slide_file(const std::filesystem::path& nc_dir, SlideTableKind kind) {
  return nc_dir / std::string(slide_compensation_file_name(kind));
}

Result<std::vector<SlideCompensationTable>> slide_tables_in_force(const std::filesystem::path& nc_dir,
                                                                  const SlideAxisNames& names, NcFiles& files) {
  std::vector<SlideCompensationTable> out;
  for (const SlideTableKind kind : {SlideTableKind::kLeadscrew, SlideTableKind::kInterpolatory}) {
    const std::filesystem::path path = slide_file(nc_dir, kind);
    Result<std::optional<std::string>> text = files.read_program(path);
    if (!text) return text.error();
    if (!*text) continue;
    Result<std::vector<SlideCompensationTable>> tables = parse_slide_compensation(**text, path.string(), names);
    if (!tables) return tables.error();
    out.insert(out.end(), tables->begin(), tables->end());
  }
  return out;
}

namespace {

// A CEC file on the control that is not what gaugeloop last wrote there: its checksum broken, or
// (with a push recorded) not the text of the push in force. Empty when it is, or absent.
Result<std::string> cec_edited(const RunStore& store, const std::filesystem::path& lec_path,
                               const std::filesystem::path& cec_path, const std::optional<std::string>& on_disk) {
  if (!on_disk) return std::string();
  if (Result<std::vector<SlideCompensationTable>> t = parse_slide_compensation(*on_disk, cec_path.string()); !t) {
    return t.error().message;
  }
  Result<std::vector<PushFile>> last = store.files_of_last_push(lec_path.string());
  if (!last) return last.error();
  for (const PushFile& f : *last) {
    if (f.role == PushFileRole::kCec && f.text && *f.text != *on_disk) {
      return cec_path.string() + " is not the CEC file the last push of " + lec_path.filename().string() +
             " wrote (version " + std::to_string(f.table_version) + ")";
    }
  }
  return std::string();
}

}  // namespace

Result<PushCompletion> push_slide_tables(RunStore& store, const std::filesystem::path& nc_dir,
                                         const std::vector<SlideCompensationTable>& tables, const SlideAxisNames& names,
                                         const SlidePush& push) {
  NcFiles& files = push.files != nullptr ? *push.files : real_nc_files();
  const std::filesystem::path cec_path = slide_file(nc_dir, SlideTableKind::kInterpolatory);
  const std::filesystem::path lec_path = slide_file(nc_dir, SlideTableKind::kLeadscrew);
  auto header_for = [&push](int version) {
    return std::map<std::string, std::string>{
        {"source", push.source}, {"run_id", "0"}, {"table_version", std::to_string(version)}};
  };
  // Both rendered first: a table the control cannot take writes nothing.
  for (const SlideTableKind kind : {SlideTableKind::kInterpolatory, SlideTableKind::kLeadscrew}) {
    if (Result<std::string> r = render_slide_compensation(kind, tables, names, header_for(0)); !r) return r.error();
  }
  if (!files.is_directory(nc_dir)) {
    return make_error(ErrorCode::kIo, "NC directory " + nc_dir.string() + " is not a directory: nothing was written");
  }
  Result<std::optional<std::string>> cec_before = files.read_program(cec_path);
  if (!cec_before) return cec_before.error();
  if (!push.overwrite_edited) {
    Result<std::string> edited = cec_edited(store, lec_path, cec_path, *cec_before);
    if (!edited) return edited.error();
    if (!edited->empty()) {
      return refused_as_edited(cec_path, "was changed by hand (" + *edited + ")",
                               "write the slide tables with `gaugeloop gear slides --overwrite-edited`");
    }
  }
  PushOptions options;
  options.overwrite_edited = push.overwrite_edited;
  options.files = &files;
  Result<int> version = next_table_version_settled(store, lec_path, options);
  if (!version) return version.error();
  Result<std::string> cec =
      render_slide_compensation(SlideTableKind::kInterpolatory, tables, names, header_for(*version));
  if (!cec) return cec.error();
  options.beside.push_back(ProgramBeside{PushFileRole::kCec, cec_path, *cec});
  PushFacts facts;
  facts.reason = "slide tables from " + push.source;
  int points = 0;
  for (const SlideCompensationTable& t : tables) points += static_cast<int>(t.error_mm.size());
  facts.table.interpolation = "slides";  // the history's "table" column: what the file holds
  facts.table.point_count = points;
  const RenderForVersion render = [&](int v) {
    return render_slide_compensation(SlideTableKind::kLeadscrew, tables, names, header_for(v));
  };
  Result<PushCompletion> pushed = push_program(store, lec_path, facts, render, options);
  if (pushed) return pushed;
  // The pair stays a pair: unless the new LEC file is in place, the CEC file this push wrote goes
  // back as it was (the journal puts back only what an earlier push of it wrote), under the
  // directory's lock, so no other push's files are touched.
  Error e = pushed.error();
  Result<DirectoryLock> lock = files.lock_directory(nc_dir);
  if (!lock) return e;
  Result<std::optional<std::string>> lec_now = files.read_program(lec_path);
  Result<std::optional<std::string>> cec_now = files.read_program(cec_path);
  if (!lec_now || !cec_now || (*lec_now && **lec_now == *render(*version))) return e;
  if (!*cec_now || **cec_now != *cec) return e;  // not this push's: put back already, or another's
  if (*cec_before) {
    e.message += write_program_read_back(files, cec_path, **cec_before, "CEC table").ok()
                     ? "; " + cec_path.string() + " was put back as it was"
                     : "; " + cec_path.string() +
                           " could not be put back: it holds the new CEC tables beside the old LEC tables, push both "
                           "again";
  } else {
    std::error_code ec;
    std::filesystem::remove(cec_path, ec);
    e.message += ec ? "; " + cec_path.string() + " (new) could not be removed: " + ec.message()
                    : "; " + cec_path.string() + " (new) was removed again";
  }
  return e;
}

}  // namespace gaugeloop
