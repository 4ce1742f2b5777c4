// The NC directory as a push sees it: lock it, read the program on the control, write a new
// one atomically, clean up after an interrupted write. A seam, so that a test can make any of
// these fail on demand (a full disk, a share gone, a lock held) beside the real directory.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

#include "core/atomic_file.h"
#include "core/result.h"

namespace gaugeloop {

class NcFiles {
 public:
  virtual ~NcFiles() = default;
  // DirectoryLock::acquire on `dir`: one push at a time, between processes.
  virtual Result<DirectoryLock> lock_directory(const std::filesystem::path& dir) = 0;
  virtual bool is_directory(const std::filesystem::path& dir) = 0;
  // The program at `path`, or empty when there is none. Errors as read_regular_file.
  virtual Result<std::optional<std::string>> read_program(const std::filesystem::path& path) = 0;
  // write_file_atomically: the control sees the old program or the new one, never a mixture.
  virtual Status write_program(const std::filesystem::path& path, std::string_view contents,
                               const AtomicWriteObserver& observer) = 0;
  // remove_atomic_leftovers: temporary files of interrupted writes of `path`.
  virtual Result<int> remove_leftovers(const std::filesystem::path& path) = 0;
};

// The file system itself, through core/atomic_file.h and core/text_file.h.
NcFiles& real_nc_files();

// Writes `text` to `path` (files.write_program, the caller holding the directory's lock), then
// reads it back, which must give the text byte for byte. `what` names the file's role in
// messages ("speed program", "Y table"). kIo for a write or read that failed (the file on the
// control, if any, stays); kRefused if what was read back differs.
Status write_program_read_back(NcFiles& files, const std::filesystem::path& path, std::string_view text,
                               std::string_view what);

}  // namespace gaugeloop
