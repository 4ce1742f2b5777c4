// `gaugeloop nc new` as a user types it: the preview writes nothing to the control, the
// program is written and shown in the history, and a second one is refused with its exit
// status until --replace.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using testing::CommandResult;
using testing::run_command;

std::string part(const std::string& example) { return std::string(GAUGELOOP_SOURCE_DIR) + "/examples/" + example; }

TEST(NcNewCommand, APreviewWritesNothingButItsCsvAndPicture) {
  testing::TempDir dir("nc-new-cmd");
  const fs::path csv = dir.path() / "profile.csv";
  const fs::path png = dir.path() / "preview.png";
  const CommandResult r =
      run_command("nc new --preview --part " + part("intake_flat.toml") + " --data-dir " + (dir.path() / "d").string() +
                  " --csv " + csv.string() + " --plot " + png.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("<- chosen"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("spline 5 deg"), std::string::npos) << "every table weighed is listed\n" << r.output;
  EXPECT_NE(r.output.find("nothing written"), std::string::npos) << r.output;
  EXPECT_FALSE(fs::exists(dir.path() / "d" / "nc" / "CAM_INTAKE_L1.SPF"));
  EXPECT_FALSE(fs::exists(dir.path() / "d" / "gaugeloop.sqlite"));
  const std::string text = testing::slurp(csv);
  EXPECT_EQ(text.rfind("c_deg,x_mm,dx_mm_per_deg,d2x_mm_per_deg2,c_speed_rpm,grinding_point_speed_mm_per_min,"
                       "x_nc_mm,command_error_um\n",
                       0),
            0u)
      << text.substr(0, 200);
  std::size_t rows = 0;
  for (char c : text) rows += c == '\n';
  EXPECT_EQ(rows, 361u) << "a header and one row per degree";
  EXPECT_EQ(testing::slurp(png).substr(1, 3), "PNG");
}

TEST(NcNewCommand, WritesVersionOneThenRefusesASecondUntilReplaced) {
  testing::TempDir dir("nc-new-cmd");
  const std::string data = " --data-dir " + dir.path().string();
  CommandResult r = run_command("nc new --part " + part("crankpin_cxy.toml") + data + " --by anna");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("version 1 of"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("CRANK_PIN1_XY_Y.SPF"), std::string::npos) << r.output;
  r = run_command("nc history" + data);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("new program from"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("by anna"), std::string::npos) << r.output;
  r = run_command("nc check" + data);
  EXPECT_EQ(r.exit_code, 0) << "the program on the control is the one pushed\n" << r.output;
  r = run_command("nc new --part " + part("crankpin_cxy.toml") + data);
  EXPECT_EQ(r.exit_code, 2) << "refused: the program has a history\n" << r.output;
  EXPECT_NE(r.output.find("--replace"), std::string::npos) << r.output;
  r = run_command("nc new --replace --part " + part("crankpin_cxy.toml") + data);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("version 2 of"), std::string::npos) << r.output;
}

}  // namespace
}  // namespace gaugeloop
