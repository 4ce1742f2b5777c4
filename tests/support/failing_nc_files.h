// The real NC directory with faults on demand: each operation a push makes can be told to fail
// with a given error (a full disk, a share gone, a lock held elsewhere), the others reach the
// real file system. For the push's error paths, beside the tests on real full disks.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "job/nc_files.h"

namespace gaugeloop::testing {

class FailingNcFiles final : public NcFiles {
 public:
  enum class Op { kLock, kRead, kWrite, kRemoveLeftovers };

  std::map<Op, Error> fail;  // an operation listed fails with its error, every time
  std::vector<Op> calls;     // every operation asked for, in order
  // A write to a file whose name ends with this ("_MAIN.MPF") fails as on a full disk; empty: none.
  std::string fail_writes_ending_with;
  // Writes go through, and then fail as a directory that cannot be flushed does (EIO after the
  // rename, write_file_atomically): the file is in place, the error says it may not stay.
  bool fail_directory_flush = false;
  // The same for a file whose name ends with this ("_MAIN.MPF") alone; empty: none.
  std::string fail_directory_flush_ending_with;

  Result<DirectoryLock> lock_directory(const std::filesystem::path& dir) override {
    calls.push_back(Op::kLock);
    if (auto it = fail.find(Op::kLock); it != fail.end()) return it->second;
    return real_nc_files().lock_directory(dir);
  }
  bool is_directory(const std::filesystem::path& dir) override { return real_nc_files().is_directory(dir); }
  Result<std::optional<std::string>> read_program(const std::filesystem::path& path) override {
    calls.push_back(Op::kRead);
    if (auto it = fail.find(Op::kRead); it != fail.end()) return it->second;
    return real_nc_files().read_program(path);
  }
  Status write_program(const std::filesystem::path& path, std::string_view contents,
                       const AtomicWriteObserver& observer) override {
    calls.push_back(Op::kWrite);
    if (auto it = fail.find(Op::kWrite); it != fail.end()) return it->second;
    if (!fail_writes_ending_with.empty() && path.filename().string().ends_with(fail_writes_ending_with)) {
      return Error{ErrorCode::kIo, "No space left on device (scripted)"};
    }
    Status written = real_nc_files().write_program(path, contents, observer);
    const bool flush_fails =
        fail_directory_flush || (!fail_directory_flush_ending_with.empty() &&
                                 path.filename().string().ends_with(fail_directory_flush_ending_with));
    if (written && flush_fails) {
      return Error{ErrorCode::kIo,
                   "renamed into place, but the directory could not be flushed (Input/output error, scripted)"};
    }
    return written;
  }
  Result<int> remove_leftovers(const std::filesystem::path& path) override {
    calls.push_back(Op::kRemoveLeftovers);
    if (auto it = fail.find(Op::kRemoveLeftovers); it != fail.end()) return it->second;
    return real_nc_files().remove_leftovers(path);
  }
};

}  // namespace gaugeloop::testing
