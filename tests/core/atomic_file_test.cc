// Atomic file replacement: contents land whole, failures leave the old file and no debris.
#include "core/atomic_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <vector>

#include "core/part.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class AtomicFileTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = tmp_.path(); }
  testing::TempDir tmp_;  // before everything that lives in it
  fs::path dir_;
};

TEST_F(AtomicFileTest, ReplacesContentsAndLeavesNoTemporaryFile) {
  const fs::path f = dir_ / "CAM.SPF";
  ASSERT_TRUE(write_file_atomically(f, "old\n").ok());
  ASSERT_TRUE(write_file_atomically(f, "new contents\n").ok());
  EXPECT_EQ(slurp(f), "new contents\n");
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++entries;
  EXPECT_EQ(entries, 1);
}

// A secret written 0600 is owner-only from the temporary file on, whatever the umask.
TEST_F(AtomicFileTest, AModeIsGivenFromTheTemporaryFileOn) {
  const fs::path f = dir_ / "token";
  const mode_t umask_was = ::umask(0);
  std::vector<unsigned> seen;
  Status s = write_file_atomically(
      f, "secret\n",
      [&](AtomicWriteStep step) {
        if (step != AtomicWriteStep::kTemporaryWritten) return;
        for (const auto& e : fs::directory_iterator(dir_)) {
          struct stat st {};
          if (::stat(e.path().c_str(), &st) == 0) seen.push_back(st.st_mode & 07777);
        }
      },
      0600);
  ::umask(umask_was);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(seen, std::vector<unsigned>{0600u});
  struct stat st {};
  ASSERT_EQ(::stat(f.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0600u);
  ASSERT_TRUE(write_file_atomically(dir_ / "CAM.SPF", "x").ok());
  ASSERT_EQ(::stat((dir_ / "CAM.SPF").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0644u) << "the default stays what NC programs had";
}

TEST_F(AtomicFileTest, MissingDirectoryFailsWithThePath) {
  const fs::path f = dir_ / "no-such-dir" / "CAM.SPF";
  Status s = write_file_atomically(f, "x");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kIo);
  EXPECT_NE(s.error().message.find("no-such-dir"), std::string::npos);
  EXPECT_FALSE(fs::exists(f));
}

TEST_F(AtomicFileTest, RenameOntoADirectoryFailsAndCleansUp) {
  const fs::path f = dir_ / "CAM.SPF";
  fs::create_directories(f);  // a directory where the file should go: rename must fail
  Status s = write_file_atomically(f, "x");
  ASSERT_FALSE(s.ok());
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_)) ++entries;
  EXPECT_EQ(entries, 1) << "the temporary file must be removed";
}

TEST(CamAngle, MapsMachineAngleToCamFrame) {
  Part p;
  EXPECT_DOUBLE_EQ(cam_angle_at_probe_deg(p, 10.0), 10.0);
  p.rotation_sense = -1;
  EXPECT_DOUBLE_EQ(cam_angle_at_probe_deg(p, 10.0), 350.0);
  p.c_offset_deg = 5.0;
  p.probe_offset_deg = 2.0;
  EXPECT_DOUBLE_EQ(cam_angle_at_probe_deg(p, 10.0), 357.0);  // -(10 - 5 - 2) = -3
  p.rotation_sense = 1;
  EXPECT_DOUBLE_EQ(cam_angle_at_probe_deg(p, 7.0), 0.0);
  EXPECT_LT(cam_angle_at_probe_deg(p, 7.0 - 1e-15), 360.0);
}

}  // namespace
}  // namespace gaugeloop
