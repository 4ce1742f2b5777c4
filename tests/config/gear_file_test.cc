// Gear part files: the example read back, every key, and each refusal naming the file, the line
// and the key; a gear part is not taken for a lobe.
#include "config/gear_file.h"

#include <gtest/gtest.h>

#include <string>

#include "config/part_file.h"
#include "tests/support/refused.h"

namespace gaugeloop {
namespace {

using testing::refused;

// A complete gear part; `gear_extra` goes at the end of [gear] (line 10), `worm` replaces
// [gear.worm]'s keys (from line 12), `stroke` [gear.stroke]'s.
std::string gear_part(const std::string& gear_extra = {},
                      const std::string& worm = "starts = 2\npitch_diameter_mm = 250.0\nhand = \"left\"\n",
                      const std::string& stroke = "z_start_mm = -14.0\nz_end_mm = 16.0\nspline_step_mm = 0.5\n") {
  return "name = \"gear_71\"\n"
         "nc_program = \"GEAR_71\"\n"
         "[gear]\n"
         "normal_module_mm = 2.25\n"
         "teeth = 71\n"
         "pressure_angle_deg = 20.0\n"
         "helix_angle_deg = 21.8\n"
         "hand = \"left\"\n"
         "face_width_mm = 24.0\n" +
         gear_extra + "[gear.worm]\n" + worm + "[gear.stroke]\n" + stroke;
}

Result<GearPartFile> parse_gear(const std::string& text) { return parse_gear_part_toml(text, "gear.toml"); }

TEST(GearPartFile, ReadsEveryKey) {
  Result<GearPartFile> g = parse_gear(gear_part());
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->name, "gear_71");
  EXPECT_EQ(g->nc_program, "GEAR_71");
  EXPECT_EQ(g->part.gear.normal_module_mm, 2.25);
  EXPECT_EQ(g->part.gear.teeth, 71);
  EXPECT_EQ(g->part.gear.pressure_angle_deg, 20.0);
  EXPECT_EQ(g->part.gear.helix_angle_deg, 21.8);
  EXPECT_EQ(g->part.gear.hand, Hand::kLeft);
  EXPECT_EQ(g->part.gear.face_width_mm, 24.0);
  EXPECT_EQ(g->part.worm.starts, 2);
  EXPECT_EQ(g->part.worm.pitch_diameter_mm, 250.0);
  EXPECT_EQ(g->part.worm.hand, Hand::kLeft);
  EXPECT_EQ(g->part.stroke.z_start_mm, -14.0);
  EXPECT_EQ(g->part.stroke.z_end_mm, 16.0);
  EXPECT_EQ(g->part.stroke.spline_step_mm, 0.5);
}

TEST(GearPartFile, TheExampleIsThePapersGear) {
  Result<GearPartFile> g = read_gear_part_file(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/gear_71.toml");
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->part.gear.teeth, 71);
  EXPECT_EQ(g->part.gear.helix_angle_deg, 21.8);
  EXPECT_EQ(g->part.gear.hand, Hand::kRight);
  EXPECT_EQ(g->part.worm.starts, 1);
  EXPECT_EQ(g->tolerance_class, 5);
}

TEST(GearPartFile, TheToleranceClassIsOptionalAndOneToEleven) {
  Result<GearPartFile> none = parse_gear(gear_part());
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->tolerance_class.has_value());
  Result<GearPartFile> six = parse_gear(gear_part("tolerance_class = 6\n"));
  ASSERT_TRUE(six.ok()) << six.error().message;
  EXPECT_EQ(six->tolerance_class, 6);
  EXPECT_TRUE(refused(parse_gear(gear_part("tolerance_class = 12\n")), "gear.tolerance_class"));
  EXPECT_TRUE(refused(parse_gear(gear_part("tolerance_class = 5.5\n")), "gear.tolerance_class"));
}

TEST(GearPartFile, EachRefusalNamesTheFileLineAndKey) {
  EXPECT_TRUE(refused(parse_gear(gear_part("teeth_count = 3\n")), "gear.toml:10: key `gear.teeth_count`"));
  EXPECT_TRUE(
      refused(parse_gear(gear_part("", "starts = 1\npitch_diameter_mm = 275.0\nhand = \"up\"\n")), "gear.worm.hand"));
  EXPECT_TRUE(refused(parse_gear(gear_part("", "starts = 0\npitch_diameter_mm = 275.0\n")), "gear.worm.starts"));
  // The worm's lead angle, given, must be the one its starts and diameter make: named with its line.
  EXPECT_TRUE(refused(parse_gear(gear_part("", "starts = 1\npitch_diameter_mm = 275.0\nlead_angle_deg = 2.0\n")),
                      "gear.toml:13: [gear.worm] lead_angle_deg = 2"));
  EXPECT_TRUE(refused(parse_gear(gear_part("", "starts = 1\npitch_diameter_mm = 275.0\nlead_angle_deg = 2.0\n")),
                      "disagrees with the 0.4688 deg"));
  EXPECT_TRUE(refused(
      parse_gear(gear_part("", "starts = 1\npitch_diameter_mm = 275.0\n", "z_start_mm = 5.0\nz_end_mm = -5.0\n")),
      "gear.toml:15: [gear.stroke] z_end_mm = -5"));
  EXPECT_TRUE(refused(parse_gear("name = \"g\"\nnc_program = \"G\"\n[gear]\nnormal_module_mm = 2.0\n"), "gear.teeth"));
  EXPECT_TRUE(refused(parse_gear("name = \"g\"\nnc_program = \"G\"\n"), "no [gear] section"));
  std::string no_worm = gear_part();
  no_worm = no_worm.substr(0, no_worm.find("[gear.worm]")) + "[gear.stroke]\nz_start_mm = 0.0\nz_end_mm = 5.0\n";
  EXPECT_TRUE(refused(parse_gear(no_worm), "no [gear.worm] section"));
  std::string bad_program = gear_part();
  bad_program.replace(bad_program.find("\"GEAR_71\""), 9, "\"7GEAR\"");
  EXPECT_TRUE(refused(parse_gear(bad_program), "gear.toml:2: key `nc_program`"));
}

// Measure, demo and nc new read part files as lobes or pins: a gear file is refused there,
// saying where gears are served, never read as a lobe with defaults.
TEST(GearPartFile, APartFileReaderRefusesAGearSayingWhere) {
  EXPECT_TRUE(refused(parse_part_toml(gear_part(), "gear.toml", "/parts"), "gaugeloop gear coupling --part gear.toml"));
}

TEST(LeadTracesCsv, TracesInAnyColumnOrderInterleavedOrOneAfterTheOther) {
  Result<std::vector<LeadTrace>> t = parse_lead_traces_csv(
      "# checker export\nflank,gap,deviation_um,z_mm\nleft,1,0.5,-10\nR,1,-0.5,-10\nleft,1,0.7,0\n"
      "right,1,-0.7,0\nL,20,0.1,-10\nL,20,0.2,10\n",
      "lead.csv");
  ASSERT_TRUE(t.ok()) << t.error().message;
  ASSERT_EQ(t->size(), 3u);
  EXPECT_EQ((*t)[0].gap, 1);
  EXPECT_EQ((*t)[0].flank, Flank::kLeft);
  EXPECT_EQ((*t)[0].z_mm, (std::vector<double>{-10.0, 0.0}));
  EXPECT_EQ((*t)[0].deviation_um, (std::vector<double>{0.5, 0.7}));
  EXPECT_EQ((*t)[1].flank, Flank::kRight);
  EXPECT_EQ((*t)[1].deviation_um, (std::vector<double>{-0.5, -0.7}));
  EXPECT_EQ((*t)[2].gap, 20);
  EXPECT_EQ((*t)[2].z_mm, (std::vector<double>{-10.0, 10.0}));
}

TEST(LeadTracesCsv, WhatIsWrongIsNamedByLineAndColumn) {
  const std::string head = "gap,flank,z_mm,deviation_um\n";
  struct Case {
    std::string text;
    std::string message;
  };
  for (const Case& c : std::vector<Case>{
           {head + "1,left,0,0.1\n1,middle,1,0.2\n", "lead.csv:3: column flank: `middle`; expected left or right"},
           {head + "0,left,0,0.1\n", "lead.csv:2: column gap: `0` is not a tooth gap number"},
           {head + "1,left,0,x\n", "lead.csv:2: column deviation_um: `x` is not a number"},
           {head + "1,left,0,0.1\n1,right,0,0.1\n1,left,0,0.2\n",
            "lead.csv:4: gap 1, left flank: Z 0 mm does not increase after line 2"},
           {"gap,flank,z_mm\n", "lead.csv:1: the header must name all 4 columns gap, flank, z_mm, deviation_um"},
           {"gap,flank,z_mm,deviation_um,temp\n", "lead.csv:1: unknown column `temp`"},
           {head, "lead.csv: no lead trace"},
           {"", "lead.csv: empty"},
       }) {
    Result<std::vector<LeadTrace>> t = parse_lead_traces_csv(c.text, "lead.csv");
    ASSERT_FALSE(t.ok()) << c.text;
    EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(t.error().message.find(c.message), std::string::npos) << t.error().message;
  }
}

TEST(BallbarCsv, AngleAndRadialErrorPerPointOrTheLineThatIsWrong) {
  Result<BallbarCircle> b = parse_ballbar_csv("# QC10 export\nradial_um,angle_deg\n1.5,0\n-0.5,90\n", "bb.csv", 100.0);
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_EQ(b->radius_mm, 100.0);
  EXPECT_EQ(b->angle_deg, (std::vector<double>{0.0, 90.0}));
  EXPECT_EQ(b->radial_um, (std::vector<double>{1.5, -0.5}));
  Result<BallbarCircle> bad = parse_ballbar_csv("angle_deg,radial_um\n0,1\n90,one\n", "bb.csv", 100.0);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("bb.csv:3: column radial_um: `one` is not a number"), std::string::npos)
      << bad.error().message;
}

TEST(BallbarCsv, ATestBothWaysWithItsRadiusAndFeedReadsBackAsWritten) {
  BallbarTest t;
  t.radius_mm = 150.0;
  t.feed_mm_per_min = 2000.0;
  t.ccw.angle_deg = {0.0, 0.25};
  t.ccw.radial_um = {1.25, -0.5};
  t.cw.angle_deg = {0.0};
  t.cw.radial_um = {2.0};
  const std::string text = ballbar_test_csv(t, "a QC10 test");
  Result<BallbarTest> back = parse_ballbar_test_csv(text, "bb.csv", 100.0, 1000.0);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->radius_mm, 150.0);
  EXPECT_EQ(back->feed_mm_per_min, 2000.0);
  EXPECT_EQ(back->ccw.radius_mm, 150.0);
  EXPECT_EQ(back->ccw.angle_deg, t.ccw.angle_deg);
  EXPECT_EQ(back->ccw.radial_um, t.ccw.radial_um);
  EXPECT_EQ(back->cw.radial_um, t.cw.radial_um);
  Result<BallbarTest> bad =
      parse_ballbar_test_csv("direction,angle_deg,radial_um\nccw,0,1\nup,90,1\n", "bb.csv", 100, 1000);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("bb.csv:3: column direction: `up`; expected ccw or cw"), std::string::npos)
      << bad.error().message;
  bad = parse_ballbar_test_csv("# radius_mm: -5\ndirection,angle_deg,radial_um\n", "bb.csv", 100, 1000);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error().message.find("bb.csv:1: `# radius_mm: -5`: expected a positive number"), std::string::npos)
      << bad.error().message;
}

}  // namespace
}  // namespace gaugeloop
