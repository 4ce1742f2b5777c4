// Curve-table blocks and template rendering.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "nc_out/curve_table.h"
#include "nc_out/nc_template.h"

namespace gaugeloop {
namespace {

std::vector<CurvePoint> square_table() {
  return {{0.0, 0.0}, {90.0, 1.23456}, {180.0, -0.00001}, {270.0, 2.5}, {360.0, 0.0}};
}

TEST(CurveTable, RendersOneBlockPerPointWithG1First) {
  const std::string blocks = render_curve_blocks(square_table());
  EXPECT_EQ(blocks, "G1 C0.000 X0.0000\nC90.000 X1.2346\nC180.000 X0.0000\nC270.000 X2.5000\nC360.000 X0.0000");
}

TEST(CurveTable, AcceptsAClosedPeriodicTable) { EXPECT_TRUE(validate_curve_points(square_table()).ok()); }

TEST(CurveTable, RefusesNaNNamingThePoint) {
  auto pts = square_table();
  pts[2].x_mm = std::numeric_limits<double>::quiet_NaN();
  Status s = validate_curve_points(pts);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_NE(s.error().message.find("point 2 (C180.000)"), std::string::npos) << s.error().message;
}

TEST(CurveTable, RefusesAnOpenPeriod) {
  auto pts = square_table();
  pts.back().x_mm = 0.1;
  EXPECT_FALSE(validate_curve_points(pts).ok());
  pts = square_table();
  pts.back().c_deg = 359.0;
  EXPECT_FALSE(validate_curve_points(pts).ok());
}

TEST(NcTemplate, ReplacesPlaceholdersAndLeavesTheRest) {
  auto r = render_nc_template("; {{ program_name }} run {{run_id}}\nCTABDEF(X,C,{{n}},1)\n", "t.spf",
                              {{"program_name", "CAM_L1"}, {"run_id", "7"}, {"n", "1"}});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(*r, "; CAM_L1 run 7\nCTABDEF(X,C,1,1)\n");
}

TEST(NcTemplate, RefusesAnUnknownPlaceholderWithItsLine) {
  auto r = render_nc_template("; header\n\nX{{x_offset}}\n", "cam.spf", {{"run_id", "7"}});
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("cam.spf:3: unknown placeholder {{x_offset}}"), std::string::npos)
      << r.error().message;
  EXPECT_NE(r.error().message.find("run_id"), std::string::npos) << "lists the known placeholders";
}

TEST(NcTemplate, RefusesAnUnclosedPlaceholder) {
  auto r = render_nc_template("a\n{{run_id\n}}", "cam.spf", {{"run_id", "7"}});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("cam.spf:2"), std::string::npos) << r.error().message;
}

TEST(NcTemplate, RefusesASectionWithItsLine) {
  auto r = render_nc_template("; a\n{{#runs}}\nX1\n{{/runs}}\n", "cam.spf", {{"runs", "1"}});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("cam.spf:2: {{#runs}} is a Mustache section"), std::string::npos)
      << r.error().message;
}

TEST(NcTemplate, RefusesAnUnclosedTripleBrace) {
  auto r = render_nc_template("X{{{run_id}}\n", "cam.spf", {{"run_id", "7"}});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("cam.spf:1: `{{{` is not closed"), std::string::npos) << r.error().message;
}

TEST(NcTemplate, InsertsValuesVerbatimInEveryVariableForm) {
  // Mustache would HTML-escape {{name}}; NC text is not HTML. A value holding braces is
  // inserted as it is, never rendered again.
  auto r = render_nc_template("{{a}}|{{{a}}}|{{& a }}|{{b}}\n", "t.spf", {{"a", "<R1> & \"x\""}, {"b", "{{a}}"}});
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_EQ(*r, "<R1> & \"x\"|<R1> & \"x\"|<R1> & \"x\"|{{a}}\n");
}

TEST(NcTemplate, RefusesABadName) {
  auto r = render_nc_template("{{run id}}", "t.spf", {{"run id", "7"}});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.error().message.find("t.spf:1: `run id` is not a placeholder name"), std::string::npos)
      << r.error().message;
}

TEST(NcTemplate, KeepsTextWithoutPlaceholdersByteForByte) {
  const std::string text = "; no tags } here }}\r\nG1 C0 X0\r\n";
  auto r = render_nc_template(text, "t.spf", {});
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(*r, text);
}

}  // namespace
}  // namespace gaugeloop
