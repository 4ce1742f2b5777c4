// A fresh directory for one test's files, and writing a text file into it (config and report tests).
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace gaugeloop::testing {

// A directory made by mkdtemp under the system temp dir, removed with everything in it when
// the object goes.
class ScratchDir {
 public:
  ScratchDir() {
    const std::string pattern = (std::filesystem::temp_directory_path() / "gaugeloop-test-XXXXXX").string();
    std::vector<char> buffer(pattern.begin(), pattern.end());
    buffer.push_back('\0');
    const char* made = ::mkdtemp(buffer.data());
    EXPECT_NE(made, nullptr) << "mkdtemp failed for " << pattern;
    if (made != nullptr) path_ = made;
  }
  ~ScratchDir() {
    std::error_code ec;
    if (!path_.empty()) std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }

  // Writes `text` to `relative` under the directory (its parent directories made) and
  // returns the full path.
  std::filesystem::path write(const std::filesystem::path& relative, const std::string& text) const {
    const std::filesystem::path to = path_ / relative;
    std::filesystem::create_directories(to.parent_path());
    std::ofstream(to, std::ios::binary) << text;
    return to;
  }

 private:
  std::filesystem::path path_;
};

}  // namespace gaugeloop::testing
