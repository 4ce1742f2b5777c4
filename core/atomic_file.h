// Writing a file so that readers see the old contents or the new, never a mixture; cleaning
// up after a write that was interrupted; and a lock that serialises writers of a directory.
#pragma once

#include <chrono>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

// The steps of an atomic write, in order, for a caller that must act (or a test that must
// crash) between them.
enum class AtomicWriteStep {
  kTemporaryWritten,  // the temporary file holds the contents, not yet flushed
  kFlushed,           // the temporary file is on disk (fsync), not yet renamed
  kRenamed,           // `path` holds the new contents; the directory is flushed (or refused)
};
using AtomicWriteObserver = std::function<void(AtomicWriteStep step)>;

// Writes `contents` to a temporary file beside `path` (named atomic_temporary_prefix(path)
// plus six random characters), fsyncs it, renames it over `path` and fsyncs the directory.
// After a crash at any point `path` holds either its old contents or the new ones; a crash
// before the rename can leave the temporary file (remove_atomic_leftovers). The directory
// must exist. Errors (kIo) name the path and the reason; on an error the temporary file is
// removed. `observer`, if given, is called after each step. The file gets permission bits
// `mode`; the temporary file is made owner-only (0600) and changed to `mode` before it is
// renamed, so a secret written with mode 0600 is never readable by anyone else.
// The directory's fsync: a file system that does not do it on directories (EINVAL, ENOTSUP:
// some network shares) is taken as it is; any other failure (EIO, ENOSPC) is an error after
// kRenamed was reached, saying `path` holds the new contents but the rename may not survive a
// power cut (the old contents may be back after it): the caller must not take the write as
// undone, nor as durable.
Status write_file_atomically(const std::filesystem::path& path, std::string_view contents,
                             const AtomicWriteObserver& observer = {}, unsigned mode = 0644);

// The directory `path` is in: its parent, or "." for a bare file name.
std::filesystem::path directory_of(const std::filesystem::path& path);

// ".<file name>.tmp-": how the temporary files of `path` begin.
std::string atomic_temporary_prefix(const std::filesystem::path& path);

// The temporary files of `path` that an interrupted write_file_atomically left (".<file
// name>.tmp-" and mkstemp's six characters, regular files only), without touching them.
// kIo if the directory cannot be listed.
Result<std::vector<std::filesystem::path>> atomic_leftovers(const std::filesystem::path& path);

// Removes the temporary files of `path` that an interrupted write_file_atomically left.
// Call it only while no other writer of `path` can be running (hold its DirectoryLock).
// Returns how many were removed; kIo if the directory cannot be listed or one not removed.
Result<int> remove_atomic_leftovers(const std::filesystem::path& path);

// An exclusive advisory lock (flock) on a directory, between processes and threads alike:
// writers of files in one directory take it so that one of them at a time writes, and a
// writer may clean up what an interrupted one left. Released when destroyed, and by the
// kernel when the process dies. On a file system that knows no flock (some network shares)
// the lock is granted without locking anything. Movable, not copyable.
class DirectoryLock {
 public:
  // Waits up to `patience` for the lock. kIo if the directory cannot be opened, or if another
  // process holds the lock that long (the message says so and names the directory).
  static Result<DirectoryLock> acquire(const std::filesystem::path& dir,
                                       std::chrono::milliseconds patience = std::chrono::seconds(10));

  DirectoryLock(DirectoryLock&& other) noexcept;
  DirectoryLock& operator=(DirectoryLock&& other) noexcept;
  DirectoryLock(const DirectoryLock&) = delete;
  DirectoryLock& operator=(const DirectoryLock&) = delete;
  ~DirectoryLock();

 private:
  explicit DirectoryLock(int fd) : fd_(fd) {}
  int fd_ = -1;
};

}  // namespace gaugeloop
