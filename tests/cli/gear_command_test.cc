// `gaugeloop gear coupling` as a user runs it: the factors of the example gear as text and JSON,
// and a bad gear file refused with exit 2 naming its key.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "compensation/gear_coupling.h"
#include "config/gear_file.h"
#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

const std::string kExample = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/gear_71.toml";

TEST(GearCommand, PrintsTheExampleGearsFactorsAsTextAndJson) {
  Result<GearPartFile> g = read_gear_part_file(kExample);
  ASSERT_TRUE(g.ok()) << g.error().message;
  const GearCoupling k = gear_coupling(g->part);
  testing::CommandResult json = testing::run_command("gear coupling --part " + kExample + " --json");
  ASSERT_EQ(json.exit_code, 0) << json.output;
  const nlohmann::json j = nlohmann::json::parse(json.output);
  EXPECT_DOUBLE_EQ(j["s_bc"].get<double>(), k.s_bc);
  EXPECT_DOUBLE_EQ(j["s_zc_deg_per_mm"].get<double>(), k.s_zc_deg_per_mm);
  EXPECT_DOUBLE_EQ(j["s_yc_deg_per_mm"].get<double>(), k.s_yc_deg_per_mm);
  EXPECT_EQ(j["s_sim_c"].get<double>(), 1.0);
  EXPECT_NEAR(j["s_bc"].get<double>(), -1.0 / 71.0, 1e-15) << "one start past 71 teeth";
  testing::CommandResult text = testing::run_command("gear coupling --part " + kExample);
  ASSERT_EQ(text.exit_code, 0) << text.output;
  EXPECT_NE(text.output.find("S_ZC   -0.266388852882 deg per mm of Z"), std::string::npos) << text.output;
}

TEST(GearCommand, ABadGearFileExits2NamingTheKey) {
  testing::TempDir dir("gear-cmd");
  const auto bad = dir.path() / "bad.toml";
  std::string text = testing::slurp(kExample);
  text.replace(text.find("teeth = 71"), 10, "teeth = 2");
  std::ofstream(bad) << text;
  testing::CommandResult r = testing::run_command("gear coupling --part " + bad.string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("gear.teeth"), std::string::npos) << r.output;
}

TEST(GearCommand, WritesTheStrokeProgramAndPrintsTheCoupling) {
  testing::TempDir dir("gear-stroke-cmd");
  const auto out = dir.path() / "GEAR_71_STROKE.SPF";
  testing::CommandResult r =
      testing::run_command("gear stroke --part " + kExample + " --errors " + std::string(GAUGELOOP_SOURCE_DIR) +
                           "/examples/gear_71_axis_errors.csv --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("31 spline points"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("EGDEF(C,B,1,Z,1,Y,1,SIM1,1)"), std::string::npos) << r.output;
  EXPECT_NE(testing::slurp(out).find("FGROUP(Z)"), std::string::npos);
  const auto bad = dir.path() / "bad.csv";
  std::ofstream(bad) << "z_mm,y_error_um,z_error_um,b_error_deg,c_error_deg\n0,1,1,0,zero\n";
  testing::CommandResult b = testing::run_command("gear stroke --part " + kExample + " --errors " + bad.string() +
                                                  " --out " + (dir.path() / "B.SPF").string());
  EXPECT_EQ(b.exit_code, 2) << b.output;
  EXPECT_NE(b.output.find("bad.csv:2: column c_error_deg"), std::string::npos) << b.output;
  EXPECT_FALSE(std::filesystem::exists(dir.path() / "B.SPF"));
}

}  // namespace
}  // namespace gaugeloop
