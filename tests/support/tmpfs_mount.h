// A small tmpfs of its own for a test, to fill a file system for real: needs root (CI runs
// as root); elsewhere the test skips with the reason.
#pragma once

#include <sys/mount.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

#include "tests/support/temp_dir.h"

namespace gaugeloop::testing {

class TmpfsMount {
 public:
  // Mounts a tmpfs of `size_kb` at a new directory under the temporary directory.
  explicit TmpfsMount(int size_kb) : base_("tmpfs"), dir_(base_.path()) {
    if (::geteuid() != 0) {
      why_not_ = "mounting a tmpfs needs root";
      return;
    }
    const std::string options = "size=" + std::to_string(size_kb) + "k";
    if (::mount("tmpfs", dir_.c_str(), "tmpfs", 0, options.c_str()) != 0) {
      why_not_ = std::string("mount tmpfs failed: ") + std::strerror(errno);
      return;
    }
    mounted_ = true;
  }
  ~TmpfsMount() {
    if (mounted_) ::umount2(dir_.c_str(), MNT_DETACH);  // before base_ removes the directory
  }
  TmpfsMount(const TmpfsMount&) = delete;
  TmpfsMount& operator=(const TmpfsMount&) = delete;

  bool mounted() const { return mounted_; }
  const std::string& why_not() const { return why_not_; }
  const std::filesystem::path& dir() const { return dir_; }

  // Free bytes for an unprivileged writer... and for root alike: tmpfs reserves nothing.
  std::uintmax_t free_bytes() const {
    struct statvfs st {};
    ::statvfs(dir_.c_str(), &st);
    return static_cast<std::uintmax_t>(st.f_bavail) * st.f_frsize;
  }

 private:
  TempDir base_;
  std::filesystem::path dir_;
  bool mounted_ = false;
  std::string why_not_;
};

}  // namespace gaugeloop::testing
