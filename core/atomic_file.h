// Writing a file so that readers see the old contents or the new, never a mixture.
#pragma once

#include <filesystem>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// Writes `contents` to a temporary file beside `path`, fsyncs it, renames it over `path`
// and fsyncs the directory. After a crash at any point `path` holds either its old
// contents or the new ones. The directory must exist. Errors name the path and the reason.
Status write_file_atomically(const std::filesystem::path& path, std::string_view contents);

}  // namespace gaugeloop
