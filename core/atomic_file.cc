// POSIX implementation of the atomic replace: temporary file, fsync, rename, fsync directory.
#include "core/atomic_file.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <string>
#include <thread>

namespace gaugeloop {
namespace {

Error io_error(const std::string& what, const std::filesystem::path& path, int err) {
  return make_error(ErrorCode::kIo, what + " " + path.string() + ": " + std::strerror(err));
}

}  // namespace

std::filesystem::path directory_of(const std::filesystem::path& path) {
  return path.has_parent_path() ? path.parent_path() : std::filesystem::path(".");
}

std::string atomic_temporary_prefix(const std::filesystem::path& path) {
  return "." + path.filename().string() + ".tmp-";
}

Status write_file_atomically(const std::filesystem::path& path, std::string_view contents,
                             const AtomicWriteObserver& observer, unsigned mode) {
  auto reached = [&observer](AtomicWriteStep step) {
    if (observer) observer(step);
  };
  const std::filesystem::path dir = directory_of(path);
  std::string tmpl = (dir / (atomic_temporary_prefix(path) + "XXXXXX")).string();
  int fd = ::mkstemp(tmpl.data());
  if (fd < 0) return io_error("cannot create a temporary file in", dir, errno);
  const std::filesystem::path tmp = tmpl;
  // The temporary file is removed on every failure path below, so nothing half-written remains.
  auto fail = [&](const std::string& what, int err) {
    ::close(fd);
    ::unlink(tmp.c_str());
    return Status(io_error(what, path, err));
  };
  size_t done = 0;
  while (done < contents.size()) {
    ssize_t n = ::write(fd, contents.data() + done, contents.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      return fail("cannot write", errno);
    }
    done += static_cast<size_t>(n);
  }
  if (::fchmod(fd, static_cast<mode_t>(mode & 07777)) != 0) return fail("cannot set permissions of", errno);
  reached(AtomicWriteStep::kTemporaryWritten);
  if (::fsync(fd) != 0) return fail("cannot flush", errno);
  if (::close(fd) != 0) {
    int err = errno;
    ::unlink(tmp.c_str());
    return io_error("cannot close", path, err);
  }
  reached(AtomicWriteStep::kFlushed);
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    int err = errno;
    ::unlink(tmp.c_str());
    return io_error("cannot rename into place", path, err);
  }
  int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  int flush_error = 0;
  if (dfd >= 0) {
    if (::fsync(dfd) != 0) flush_error = errno;
    ::close(dfd);
  } else if (errno != EACCES && errno != EPERM) {
    // A directory we may write but not read (a drop-box share) cannot be flushed, and is taken
    // as it is; any other failure to open it (EIO) leaves the rename not known to be on disk.
    flush_error = errno;
  }
  reached(AtomicWriteStep::kRenamed);
  // Some file systems (network shares among them) do not fsync a directory: as before. Any
  // other failure leaves the rename in place but not known to be on disk.
  if (flush_error != 0 && flush_error != EINVAL && flush_error != ENOTSUP && flush_error != EOPNOTSUPP &&
      flush_error != EBADF) {
    return make_error(ErrorCode::kIo, "renamed into place, but the directory " + dir.string() +
                                          " could not be flushed (" + std::strerror(flush_error) +
                                          "): " + path.string() +
                                          " holds the new contents now, and may hold the old ones again after a "
                                          "power cut");
  }
  return {};
}

Result<std::vector<std::filesystem::path>> atomic_leftovers(const std::filesystem::path& path) {
  const std::filesystem::path dir = directory_of(path);
  const std::string prefix = atomic_temporary_prefix(path);
  std::error_code ec;
  std::filesystem::directory_iterator it(dir, ec);
  if (ec) return io_error("cannot list", dir, ec.value());
  std::vector<std::filesystem::path> out;
  for (; it != std::filesystem::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    // mkstemp's six characters after the prefix, nothing else: a file of ours, not the user's.
    if (name.size() != prefix.size() + 6 || name.compare(0, prefix.size(), prefix) != 0) continue;
    if (!std::filesystem::is_regular_file(it->symlink_status(ec))) continue;
    out.push_back(it->path());
  }
  if (ec) return io_error("cannot list", dir, ec.value());
  return out;
}

Result<int> remove_atomic_leftovers(const std::filesystem::path& path) {
  Result<std::vector<std::filesystem::path>> leftovers = atomic_leftovers(path);
  if (!leftovers) return leftovers.error();
  for (const std::filesystem::path& p : *leftovers) {
    if (::unlink(p.c_str()) != 0) return io_error("cannot remove the leftover temporary file", p, errno);
  }
  return static_cast<int>(leftovers->size());
}

Result<DirectoryLock> DirectoryLock::acquire(const std::filesystem::path& dir, std::chrono::milliseconds patience) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return io_error("cannot open the directory", dir, errno);
  const auto give_up = std::chrono::steady_clock::now() + patience;
  for (;;) {
    if (::flock(fd, LOCK_EX | LOCK_NB) == 0) return DirectoryLock(fd);
    const int err = errno;
    // Some network file systems (a share to the control) know no flock: writers there are not
    // serialised by it, as before, rather than refused.
    if (err == ENOLCK || err == EOPNOTSUPP || err == EINVAL) return DirectoryLock(fd);
    if (err != EWOULDBLOCK && err != EINTR) {
      ::close(fd);
      return io_error("cannot lock the directory", dir, err);
    }
    if (std::chrono::steady_clock::now() >= give_up) {
      ::close(fd);
      return make_error(ErrorCode::kIo, "directory " + dir.string() + " stayed locked by another gaugeloop for " +
                                            std::to_string(patience.count()) +
                                            " ms (a push in progress, or a process stopped while pushing); "
                                            "try again, or find the process with `fuser -v " +
                                            dir.string() + "`");
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
}

DirectoryLock::DirectoryLock(DirectoryLock&& other) noexcept : fd_(other.fd_) { other.fd_ = -1; }

DirectoryLock& DirectoryLock::operator=(DirectoryLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = other.fd_;
    other.fd_ = -1;
  }
  return *this;
}

DirectoryLock::~DirectoryLock() {
  if (fd_ >= 0) ::close(fd_);  // closing the last descriptor releases the flock
}

}  // namespace gaugeloop
