// The gear's stroke program as text: written on the control's grid, read back, the gearbox's
// coupling lines, and what the reader refuses (a hand edit, a word it cannot model, Z going back).
#include "nc_out/stroke_program.h"

#include <gtest/gtest.h>

#include <string>

namespace gaugeloop {
namespace {

std::string program(const StrokeProgramFormat& f = {}) {
  Result<std::string> t = render_stroke_program("GEAR_71", {{"part", "gear_71"}},
                                                {{-1.0, 0.00123456}, {0.0, -0.0004}, {1.00004, 0.0}}, 300.0, f);
  EXPECT_TRUE(t.ok()) << t.error().message;
  return t.ok() ? *t : std::string();
}

TEST(StrokeProgram, ReadsBackOnTheControlsGrid) {
  const std::string text = program();
  EXPECT_NE(text.find("FGROUP(Z)\nG1 G90 Z-1.0000 SIM1=0.001 F300.0\nZ0.0000 SIM1=0.000\nZ1.0000 SIM1=0.000\nM17\n"),
            std::string::npos)
      << text;
  Result<ParsedStrokeProgram> p = parse_stroke_program(text, "S.SPF");
  ASSERT_TRUE(p.ok()) << p.error().message;
  ASSERT_EQ(p->points.size(), 3u);
  EXPECT_EQ(p->points[0].z_mm, -1.0);
  EXPECT_EQ(p->points[0].sim_deg, 0.001) << "SIM1 on the default 1000 increments per degree";
  EXPECT_EQ(p->header.at("part"), "gear_71");
  EXPECT_EQ(p->header.at("point_count"), "3");
  StrokeProgramFormat fine;
  fine.sim_increments_per_deg = 1e6;
  Result<ParsedStrokeProgram> f = parse_stroke_program(program(fine), "S.SPF");
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_EQ(f->points[0].sim_deg, 0.001235);
  EXPECT_EQ(f->points[1].sim_deg, -0.0004);
}

TEST(StrokeProgram, SaysItIsAStrokeAndACurveTableIsNot) {
  EXPECT_TRUE(is_stroke_program(program()));
  EXPECT_TRUE(is_stroke_program("; G\r\n; gaugeloop kind: gear stroke\r\nFGROUP(Z)\r\n")) << "a Windows share's lines";
  EXPECT_FALSE(is_stroke_program("; CAM\n; gaugeloop table_version: 1\nCTABDEF(X,C,1,1)\nCTABEND\nM17\n"));
  // The kind is read from the header only: the words in the body or another kind do not count.
  EXPECT_FALSE(is_stroke_program("; G\nFGROUP(Z)\n; gaugeloop kind: gear stroke\n"));
  EXPECT_FALSE(is_stroke_program("; gaugeloop kind: curve table\n"));
}

TEST(StrokeProgram, TheGearboxCouplesFourLeadingAxes) {
  GearboxFactors g{-1, 71, -0.266388852882, 0.717294043564};
  EXPECT_EQ(render_gearbox_coupling(g),
            "EGDEF(C,B,1,Z,1,Y,1,SIM1,1)\n"
            "EGON(C,\"FINE\",B,-1,71,Z,-0.266388852882,1,Y,0.717294043564,1,SIM1,1,1)");
}

TEST(StrokeProgram, RefusesAHandEditAndWhatItCannotModel) {
  std::string edited = program();
  edited.replace(edited.find("Z0.0000 SIM1=0.000"), 18, "Z0.0000 SIM1=0.002");
  Result<ParsedStrokeProgram> e = parse_stroke_program(edited, "S.SPF");
  ASSERT_FALSE(e.ok());
  EXPECT_EQ(e.error().code, ErrorCode::kRefused);
  EXPECT_NE(e.error().message.find("edited by hand"), std::string::npos) << e.error().message;

  std::string foreign = program();
  foreign.replace(foreign.find("Z0.0000 SIM1=0.000"), 18, "Z0.0000 X5");
  Result<ParsedStrokeProgram> f = parse_stroke_program(foreign, "S.SPF");
  ASSERT_FALSE(f.ok());
  EXPECT_NE(f.error().message.find("S.SPF:9: `X5`"), std::string::npos) << f.error().message;

  std::string back = program();
  back.replace(back.find("Z1.0000"), 7, "Z-2.000");
  Result<ParsedStrokeProgram> b = parse_stroke_program(back, "S.SPF");
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("does not increase"), std::string::npos) << b.error().message;

  Result<std::string> one = render_stroke_program("G", {}, {{0.0, 0.0}}, 300.0);
  EXPECT_FALSE(one.ok());
  Result<std::string> no_feed = render_stroke_program("G", {}, {{0.0, 0.0}, {1.0, 0.0}}, 0.0);
  EXPECT_FALSE(no_feed.ok());
}

}  // namespace
}  // namespace gaugeloop
