// The slides' compensation files in the NC directory (docs/gears.md, "The slides"): the tables
// in force read back, and new ones written as a pair under the directory's lock, each atomically
// and read back, the first put back as it was if the second cannot be written.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "core/result.h"
#include "core/slide_table.h"
#include "job/nc_files.h"
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

// Writes both files: the CEC file, then the LEC file. Each is rendered before anything is
// written (kInvalidInput then, nothing written). If the LEC file cannot be written, the CEC
// file is put back as it was (or removed when there was none) and the error says so.
Status push_slide_tables(const std::filesystem::path& nc_dir, const std::vector<SlideCompensationTable>& tables,
                         const SlideAxisNames& names, const std::map<std::string, std::string>& header,
                         NcFiles& files = real_nc_files());

}  // namespace gaugeloop
