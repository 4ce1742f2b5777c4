// Part files: a lobe's description read back, and every refusal naming the file, line and key.
#include "config/part_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "tests/support/refused.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::refused;

namespace fs = std::filesystem;

// A complete flat-follower part; `extra` is appended (line 9 on).
std::string flat_part(const std::string& extra = {}) {
  return "name = \"intake\"\n"
         "lobe = 2\n"
         "lift_table = \"intake.csv\"\n"
         "follower = \"flat\"\n"
         "base_circle_radius_mm = 18.0\n"
         "wheel_radius_mm = 200.0\n"
         "c_offset_deg = 12.5\n"
         "nc_program = \"CAM_INTAKE_L2\"\n" +
         extra;
}

Result<PartFile> parse(const std::string& text) { return parse_part_toml(text, "part.toml", "/parts"); }

TEST(PartFile, ReadsEveryKeyAndTheDefaults) {
  auto pf = parse(flat_part());
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  const Part& p = pf->part;
  EXPECT_EQ(p.name, "intake");
  EXPECT_EQ(p.lobe, 2);
  EXPECT_EQ(p.lift_table, fs::path("/parts/intake.csv")) << "relative to the part file's directory";
  EXPECT_EQ(p.follower, FollowerKind::kFlat);
  EXPECT_EQ(p.base_circle_radius_mm, 18.0);
  EXPECT_EQ(p.wheel_radius_mm, 200.0);
  EXPECT_EQ(p.rotation_sense, 1) << "default";
  EXPECT_EQ(p.c_offset_deg, 12.5);
  EXPECT_EQ(p.probe_offset_deg, 0.0) << "default";
  EXPECT_EQ(pf->nc_program, "CAM_INTAKE_L2");

  auto roller = parse(
      "name = \"ex\"\nlift_table = \"/abs/ex.csv\"\nfollower = \"roller\"\nfollower_radius_mm = 11\n"
      "base_circle_radius_mm = 17\nwheel_radius_mm = 45\nrotation_sense = -1\nprobe_offset_deg = -30\n"
      "nc_program = \"EX\"\n");
  ASSERT_TRUE(roller.ok()) << roller.error().message;
  EXPECT_EQ(roller->part.lobe, 1) << "default";
  EXPECT_EQ(roller->part.lift_table, fs::path("/abs/ex.csv")) << "an absolute path is kept";
  EXPECT_EQ(roller->part.follower, FollowerKind::kRoller);
  EXPECT_EQ(roller->part.follower_radius_mm, 11.0);
  EXPECT_EQ(roller->part.rotation_sense, -1);
  EXPECT_EQ(roller->part.probe_offset_deg, -30.0);

  std::string knife_text = flat_part();
  knife_text.replace(knife_text.find("\"flat\""), 6, "\"knife_edge\"");
  auto knife = parse(knife_text);
  ASSERT_TRUE(knife.ok()) << knife.error().message;
  EXPECT_EQ(knife->part.follower, FollowerKind::kKnifeEdge);
}

// The drawing a part is made to, for its reports: optional, printable, at most 40 characters.
TEST(PartFile, ReadsTheDrawingAndRefusesOneThatCannotBePrinted) {
  Result<PartFile> f = parse(flat_part("drawing_number = \"CS-4711-01\"\ndrawing_revision = \"C\"\n"));
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->part.drawing_number, "CS-4711-01");
  EXPECT_EQ(f->part.drawing_revision, "C");
  f = parse(flat_part());
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->part.drawing_number, "") << "not given";
  for (const std::string& bad :
       {std::string("drawing_number = \"A\\tB\"\n"), "drawing_revision = \"" + std::string(41, 'R') + "\"\n"}) {
    f = parse(flat_part(bad));
    ASSERT_FALSE(f.ok()) << bad;
    EXPECT_NE(f.error().message.find("part.toml:9: key `drawing_"), std::string::npos) << f.error().message;
    EXPECT_NE(f.error().message.find("up to 40 printable characters"), std::string::npos) << f.error().message;
  }
}

TEST(PartFile, RefusesMistakesNamingFileLineAndKey) {
  struct Case {
    std::string text;
    std::string expected;
  };
  const Case cases[] = {
      {flat_part("colour = \"red\"\n"), "part.toml:9: key `colour`: unknown key; known keys: name, lobe,"},
      {"lobe = 1\n", "part.toml: key `name` is missing; it is required"},
      {flat_part("follower_radius_mm = 11\n"),
       "part.toml:9: key `follower_radius_mm`: only a roller follower has a radius"},
      {"name = \"r\"\nlift_table = \"r.csv\"\nfollower = \"roller\"\nbase_circle_radius_mm = 17\n"
       "wheel_radius_mm = 45\nnc_program = \"R\"\n",
       "part.toml: key `follower_radius_mm` is missing"},
      {flat_part("rotation_sense = 0\n"), "part.toml:9: key `rotation_sense`: must be 1 or -1"},
      {flat_part("rotation_sense = 2\n"), "part.toml:9: key `rotation_sense`: 2 is out of range; allowed [-1, 1]"},
      {flat_part("probe_offset_deg = 400\n"), "part.toml:9: key `probe_offset_deg`: 400 is out of range"},
      {flat_part("[extra]\n"), "part.toml:9: key `extra`: unknown key"},
  };
  for (const Case& c : cases) EXPECT_TRUE(refused(parse(c.text), c.expected)) << c.text;

  std::string bad = flat_part();
  bad.replace(bad.find("\"flat\""), 6, "\"flat-faced\"");
  EXPECT_TRUE(refused(parse(bad), "part.toml:4: key `follower`: `flat-faced` is not one of flat, roller, knife_edge"));
  bad = flat_part();
  bad.replace(bad.find("lobe = 2"), 8, "lobe = 65");
  EXPECT_TRUE(refused(parse(bad), "part.toml:2: key `lobe`: 65 is out of range; allowed [1, 64]"));
  bad = flat_part();
  bad.replace(bad.find("18.0"), 4, "0");
  EXPECT_TRUE(refused(parse(bad), "part.toml:5: key `base_circle_radius_mm`: 0 is out of range; allowed (0, 1000]"));
  bad = flat_part();
  bad.replace(bad.find("200.0"), 5, "\"200\"");
  EXPECT_TRUE(refused(parse(bad), "part.toml:6: key `wheel_radius_mm`: expected a number"));
}

TEST(PartFile, ReadsTheSpeedProgramSectionAndRefusesItsMistakes) {
  auto none = parse(flat_part());
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->speed.has_value());
  auto pf = parse(flat_part("[speed]\nlobe_speed_mm_per_min = 2500\nbase_speed_rpm = 90\n"));
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  ASSERT_TRUE(pf->speed.has_value());
  EXPECT_EQ(pf->speed->lobe_speed_mm_per_min, 2500.0);
  EXPECT_EQ(pf->speed->base_speed_rpm, 90.0);
  EXPECT_EQ(pf->speed->lobe_threshold_mm, WorkSpeedSettings{}.lobe_threshold_mm);
  EXPECT_EQ(pf->speed->c_acceleration_max_deg_per_s2, WorkSpeedSettings{}.c_acceleration_max_deg_per_s2);
  EXPECT_TRUE(refused(parse(flat_part("[speed]\nbase_speed_rpm = 90\n")),
                      "part.toml: key `speed.lobe_speed_mm_per_min` is missing"));
  EXPECT_TRUE(refused(parse(flat_part("[speed]\nlobe_speed_mm_per_min = 0\n")),
                      "part.toml:10: key `speed.lobe_speed_mm_per_min`: 0 is out of range; allowed (0, 100000]"));
  EXPECT_TRUE(refused(parse(flat_part("[speed]\nlobe_speed_mm_per_min = 2000\nx_velocity_max_mm_per_s = 9\n")),
                      "part.toml:11: key `speed.x_velocity_max_mm_per_s`: unknown key"));
}

// The paper's program: one grinding-point speed all round, the rise and return slower; the
// lobe hold's keys are refused under it by name, and the other way round.
TEST(PartFile, ReadsTheFlankHoldAndRefusesTheOtherHoldsKeys) {
  auto pf = parse(
      flat_part("[speed]\nhold = \"flanks\"\ngrinding_point_speed_mm_per_min = 8000\nflank_speed_mm_per_min = 2000\n"));
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  ASSERT_TRUE(pf->speed.has_value());
  EXPECT_EQ(pf->speed->hold, SpeedHold::kFlanks);
  EXPECT_EQ(pf->speed->grinding_point_speed_mm_per_min, 8000.0);
  EXPECT_EQ(pf->speed->flank_speed_mm_per_min, 2000.0);
  EXPECT_TRUE(refused(parse(flat_part("[speed]\nhold = \"flanks\"\ngrinding_point_speed_mm_per_min = 8000\n"
                                      "flank_speed_mm_per_min = 2000\nlobe_speed_mm_per_min = 2000\n")),
                      "part.toml:13: key `speed.lobe_speed_mm_per_min`: not used with hold = \"flanks\""));
  EXPECT_TRUE(refused(parse(flat_part("[speed]\nlobe_speed_mm_per_min = 2000\nflank_speed_mm_per_min = 2000\n")),
                      "part.toml:11: key `speed.flank_speed_mm_per_min`: not used with hold = \"lobe\""));
  EXPECT_TRUE(refused(parse(flat_part("[speed]\nhold = \"flanks\"\nflank_speed_mm_per_min = 2000\n")),
                      "key `speed.grinding_point_speed_mm_per_min` is missing"));
  EXPECT_TRUE(refused(parse(flat_part("[speed]\nhold = \"nose\"\n")), "part.toml:10: key `speed.hold`"));
}

// [grinding]: the allowance and the passes, and each mistake named by file, line and key.
TEST(PartFile, ReadsTheAllowanceAndRefusesABadOne) {
  auto none = parse(flat_part());
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->grinding.stock_mm, GrindingCycle{}.stock_mm) << "the defaults without [grinding]";
  auto pf = parse(flat_part(
      "[grinding]\nstock_mm = 0.3\nair_gap_mm = 0.1\nroughing_infeed_mm_per_turn = 0.03\nfinishing_stock_mm = 0.04\n"
      "finishing_infeed_mm_per_turn = 0.004\nspark_out_turns = 3\n"));
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  EXPECT_EQ(pf->grinding.stock_mm, 0.3);
  EXPECT_EQ(pf->grinding.air_gap_mm, 0.1);
  EXPECT_EQ(pf->grinding.roughing_infeed_mm_per_turn, 0.03);
  EXPECT_EQ(pf->grinding.finishing_stock_mm, 0.04);
  EXPECT_EQ(pf->grinding.finishing_infeed_mm_per_turn, 0.004);
  EXPECT_EQ(pf->grinding.spark_out_turns, 3);
  EXPECT_TRUE(refused(parse(flat_part("[grinding]\nstock_mm = 0.1\nfinishing_stock_mm = 0.2\n")),
                      "part.toml:11: key `grinding.finishing_stock_mm`: finishing_stock_mm 0.2 mm is more than "
                      "stock_mm 0.1 mm"));
  EXPECT_TRUE(refused(parse(flat_part("[grinding]\nstock_mm = -0.1\n")),
                      "part.toml:10: key `grinding.stock_mm`: -0.1 is out of range"));
  EXPECT_TRUE(refused(parse(flat_part("[grinding]\nroughing_infeed_mm_per_turn = 0\n")),
                      "part.toml:10: key `grinding.roughing_infeed_mm_per_turn`: 0 is out of range"));
  EXPECT_TRUE(refused(parse(flat_part("[grinding]\nspark_out_turns = 1.5\n")), "key `grinding.spark_out_turns`"));
  EXPECT_TRUE(
      refused(parse(flat_part("[grinding]\nstock = 0.1\n")), "part.toml:10: key `grinding.stock`: unknown key"));
  EXPECT_TRUE(
      refused(parse(flat_part("[grinding]\nstock_mm = 5\nroughing_infeed_mm_per_turn = 0.001\n")), "more than 1000"));
}

TEST(PartFile, ReadsTheCorrectionLayerAndRefusesABadDesignTableNumber) {
  auto none = parse(flat_part());
  ASSERT_TRUE(none.ok());
  EXPECT_EQ(none->layer_design_table_number, 0) << "without [correction_layer]: the whole table";
  auto by_default = parse(flat_part("[correction_layer]\n"));
  ASSERT_TRUE(by_default.ok()) << by_default.error().message;
  EXPECT_EQ(by_default->layer_design_table_number, 5);
  auto pf = parse(flat_part("[correction_layer]\ndesign_table_number = 40\n"));
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  EXPECT_EQ(pf->layer_design_table_number, 40);
  EXPECT_TRUE(refused(parse(flat_part("[correction_layer]\ndesign_table_number = 1000\n")),
                      "part.toml:10: key `correction_layer.design_table_number`: 1000 is out of range"));
  EXPECT_TRUE(refused(parse(flat_part("[correction_layer]\naxis = \"SIM2\"\n")),
                      "part.toml:10: key `correction_layer.axis`: unknown key"));
}

TEST(PartFile, RefusesAnInvalidNcProgramName) {
  for (const char* name : {"1CAM", "CAM-1", "", "A234567890123456789012345"}) {
    std::string text = flat_part();
    text.replace(text.find("\"CAM_INTAKE_L2\""), 15, "\"" + std::string(name) + "\"");
    EXPECT_TRUE(refused(parse(text), "part.toml:8: key `nc_program`: `" + std::string(name) +
                                         "` is not a valid NC program name; use up to 24 letters"));
  }
  std::string longest = flat_part();
  longest.replace(longest.find("\"CAM_INTAKE_L2\""), 15, "\"A23456789012345678901234\"");
  EXPECT_TRUE(parse(longest).ok()) << "24 characters are allowed";
}

TEST(PartFile, ReadsAFileWithAByteOrderMarkAndNamesAMissingOne) {
  testing::TempDir dir;
  const fs::path file = dir.write("sub/intake.toml", "\xEF\xBB\xBF" + flat_part());
  auto pf = read_part_file(file);
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  EXPECT_EQ(pf->part.lift_table, dir.path() / "sub" / "intake.csv");

  auto missing = read_part_file(dir.path() / "absent.toml");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kNotFound);
  EXPECT_NE(missing.error().message.find("part file " + (dir.path() / "absent.toml").string() + ": no such file"),
            std::string::npos)
      << missing.error().message;

  const fs::path bad = dir.write("bad.toml", flat_part("lobe = 3\n"));
  auto twice = read_part_file(bad);
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.error().message.find(bad.string() + ":9"), std::string::npos) << twice.error().message;
}

}  // namespace
}  // namespace gaugeloop
