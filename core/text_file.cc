// Bounded reads of regular files.
#include "core/text_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

namespace gaugeloop {

Result<std::string> read_regular_file(const std::filesystem::path& path, std::string_view what, std::size_t max_bytes) {
  const std::string name = std::string(what) + " " + path.string();
  // Open first, then look at what was opened: no window for the name to change in between.
  // O_NONBLOCK so that opening a FIFO does not wait for a writer.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  if (fd < 0) {
    const int err = errno;
    if (err == ENOENT) return make_error(ErrorCode::kNotFound, name + ": no such file; check the path");
    return make_error(ErrorCode::kIo, name + ": cannot be opened: " + std::strerror(err));
  }
  struct FdCloser {
    int fd;
    ~FdCloser() { ::close(fd); }
  } closer{fd};
  struct stat st {};
  if (::fstat(fd, &st) != 0) return make_error(ErrorCode::kIo, name + ": cannot be examined: " + std::strerror(errno));
  if (S_ISDIR(st.st_mode)) {
    return make_error(ErrorCode::kInvalidInput, name + " is a directory, not a file; give the file's path");
  }
  if (!S_ISREG(st.st_mode)) {
    return make_error(ErrorCode::kInvalidInput,
                      name + " is not a regular file (a device, a FIFO or a socket); give the path of a file");
  }
  if (static_cast<std::uintmax_t>(st.st_size) > max_bytes) {
    return make_error(ErrorCode::kInvalidInput, name + " is " + std::to_string(st.st_size) + " bytes, more than the " +
                                                    std::to_string(max_bytes) + " a " + std::string(what) +
                                                    " can be; is it the right file?");
  }
  std::string text;
  text.reserve(static_cast<std::size_t>(st.st_size));
  char buf[65536];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      return make_error(ErrorCode::kIo, name + ": cannot be read: " + std::strerror(errno));
    }
    if (n == 0) break;
    text.append(buf, static_cast<std::size_t>(n));
    // A file that grows while it is read is held to the same bound.
    if (text.size() > max_bytes) {
      return make_error(ErrorCode::kInvalidInput, name + " grew past " + std::to_string(max_bytes) +
                                                      " bytes while it was read; is it the right file?");
    }
  }
  return text;
}

std::string_view without_utf8_bom(std::string_view text) {
  constexpr std::string_view kBom = "\xEF\xBB\xBF";
  if (text.substr(0, kBom.size()) == kBom) text.remove_prefix(kBom.size());
  return text;
}

}  // namespace gaugeloop
