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

Status push_slide_tables(const std::filesystem::path& nc_dir, const std::vector<SlideCompensationTable>& tables,
                         const SlideAxisNames& names, const std::map<std::string, std::string>& header,
                         NcFiles& files) {
  Result<std::string> cec = render_slide_compensation(SlideTableKind::kInterpolatory, tables, names, header);
  if (!cec) return cec.error();
  Result<std::string> lec = render_slide_compensation(SlideTableKind::kLeadscrew, tables, names, header);
  if (!lec) return lec.error();
  if (!files.is_directory(nc_dir)) {
    return make_error(ErrorCode::kIo, "NC directory " + nc_dir.string() + " is not a directory: nothing was written");
  }
  Result<DirectoryLock> lock = files.lock_directory(nc_dir);
  if (!lock) return lock.error();
  const std::filesystem::path cec_path = slide_file(nc_dir, SlideTableKind::kInterpolatory);
  const std::filesystem::path lec_path = slide_file(nc_dir, SlideTableKind::kLeadscrew);
  Result<std::optional<std::string>> cec_before = files.read_program(cec_path);
  if (!cec_before) return cec_before.error();
  if (Status w = write_program_read_back(files, cec_path, *cec, "CEC table"); !w) return w;
  Status w = write_program_read_back(files, lec_path, *lec, "LEC table");
  if (w) return {};
  // The pair stays a pair: the CEC file back as it was.
  std::string put_back;
  if (*cec_before) {
    put_back = write_program_read_back(files, cec_path, **cec_before, "CEC table").ok()
                   ? "; " + cec_path.string() + " was put back as it was"
                   : "; " + cec_path.string() +
                         " could not be put back: it holds the new CEC tables beside the old "
                         "LEC tables, write both again";
  } else {
    std::error_code ec;
    std::filesystem::remove(cec_path, ec);
    put_back = ec ? "; " + cec_path.string() + " (new) could not be removed: " + ec.message()
                  : "; " + cec_path.string() + " (new) was removed again";
  }
  return make_error(w.error().code, w.error().message + put_back);
}

}  // namespace gaugeloop
