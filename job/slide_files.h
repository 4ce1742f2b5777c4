// The slides' compensation files in the NC directory (docs/gears.md, "The slides"): the tables
// in force read back, and new ones pushed as a pair through the push journal, one version of
// AX_EEC.INI with NC_CEC.INI beside it.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/result.h"
#include "core/slide_table.h"
#include "job/nc_files.h"
#include "job/nc_push.h"
#include "nc_out/slide_compensation.h"

namespace gaugeloop {

// <nc_dir>/AX_EEC.INI (LEC) and <nc_dir>/NC_CEC.INI (CEC).
std::filesystem::path slide_file(const std::filesystem::path& nc_dir, SlideTableKind kind);

// The tables in force: the LEC file's, then the CEC file's (the order slide_tables writes them
// in); none from a file that is not there. Errors: parse_slide_compensation's (a file edited by
// hand is refused), a file that cannot be read.
Result<std::vector<SlideCompensationTable>> slide_tables_in_force(const std::filesystem::path& nc_dir,
                                                                  const SlideAxisNames& names,
                                                                  NcFiles& files = real_nc_files());

// How a pair of slide tables is pushed.
struct SlidePush {
  std::string source;             // where the tables come from (a ballbar test's file): header and reason
  bool overwrite_edited = false;  // a person approved overwriting files edited by hand
  NcFiles* files = nullptr;       // null: the real NC directory
};

// Pushes both files as one version of <nc_dir>/AX_EEC.INI through the push journal, as a
// measurement pushes a cam's table (push_program, job/nc_push.h): under the directory's lock,
// the intent recorded with both texts, the CEC file written beside first, then the LEC file,
// each atomically and read back; `nc history`, `nc check`, `nc reconcile` and `nc rollback`
// (which puts the CEC file of that version back with it) work on AX_EEC.INI. Each file is
// rendered before anything is written (kInvalidInput then, nothing written); a file edited by
// hand (the LEC one, or the CEC one: not the one last pushed, or its checksum broken) is
// refused (kRefused) unless push.overwrite_edited. If the LEC file cannot be written, the CEC
// file is put back as it was (or removed when there was none) and the error says so.
Result<PushCompletion> push_slide_tables(RunStore& store, const std::filesystem::path& nc_dir,
                                         const std::vector<SlideCompensationTable>& tables, const SlideAxisNames& names,
                                         const SlidePush& push);

}  // namespace gaugeloop
