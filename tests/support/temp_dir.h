// The one temporary directory of the tests: fresh and empty for each test, named after it,
// made with mkdtemp (never shared with a parallel run or a leftover of an earlier one), and
// removed with everything in it when the test ends.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace gaugeloop::testing {

class TempDir {
 public:
  // <tmp>/gaugeloop-<suite>-<test>-XXXXXX for the running test; `label` for one made outside
  // a test (or a second one in a test).
  TempDir() : TempDir(running_test_label()) {}
  explicit TempDir(std::string_view label) {
    std::string pattern = (std::filesystem::temp_directory_path() / ("gaugeloop-" + safe(label) + "-XXXXXX")).string();
    const char* made = ::mkdtemp(pattern.data());
    EXPECT_NE(made, nullptr) << "mkdtemp failed for " << pattern;
    path_ = made != nullptr ? std::filesystem::path(made) : std::filesystem::path();
  }
  ~TempDir() {
    if (path_.empty()) return;
    std::error_code ec;
    // A test may have made parts read-only; give them back before removing.
    std::filesystem::permissions(path_, std::filesystem::perms::owner_all, std::filesystem::perm_options::add, ec);
    for (const auto& entry : std::filesystem::recursive_directory_iterator(path_, ec)) {
      std::filesystem::permissions(entry.path(), std::filesystem::perms::owner_all, std::filesystem::perm_options::add,
                                   ec);
    }
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::filesystem::path& p) const { return path_ / p; }

  // Writes `text` to `relative` under the directory (its parent directories made) and
  // returns the full path.
  std::filesystem::path write(const std::filesystem::path& relative, const std::string& text) const {
    const std::filesystem::path to = path_ / relative;
    std::filesystem::create_directories(to.parent_path());
    std::ofstream(to, std::ios::binary) << text;
    return to;
  }

  // Lets other users traverse and read the directory (mkdtemp makes it private), for checks
  // run as an unprivileged user.
  void share() const { ::chmod(path_.c_str(), 0755); }

 private:
  static std::string running_test_label() {
    const ::testing::TestInfo* t = ::testing::UnitTest::GetInstance()->current_test_info();
    return t == nullptr ? std::string("test") : std::string(t->test_suite_name()) + "-" + t->name();
  }
  // Parameterised tests have '/' in their names.
  static std::string safe(std::string_view label) {
    std::string s(label);
    for (char& c : s) {
      if (c == '/' || c == ' ') c = '_';
    }
    return s;
  }

  std::filesystem::path path_;
};

}  // namespace gaugeloop::testing
