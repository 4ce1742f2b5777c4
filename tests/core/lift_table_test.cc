// Lift table parsing: accepted shapes and every refusal, with its line number.
#include "core/lift_table.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace gaugeloop {
namespace {

std::string uniform_table(double step, double skip_from = -1, double skip_to = -1) {
  std::string s = "angle_deg,lift_mm\n";
  for (double a = 0; a < 360.0 - 1e-9; a += step) {
    if (a > skip_from && a < skip_to) continue;
    s += std::to_string(a) + "," + std::to_string(a < 90 ? 1.0 : 0.0) + "\n";
  }
  return s;
}

TEST(LiftTable, ParsesUniformTableWithHeader) {
  auto t = parse_lift_table_csv(uniform_table(1.0), "t.csv");
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_EQ(t->angle_deg.size(), 360u);
  EXPECT_DOUBLE_EQ(t->angle_deg[359], 359.0);
  EXPECT_DOUBLE_EQ(t->lift_mm[0], 1.0);
}

TEST(LiftTable, ParsesNonUniformTableWithCommentsAndCrLf) {
  auto t = parse_lift_table_csv(
      "# lobe\r\nangle_deg,lift_mm\r\n0,1\r\n1.5,2\r\n\r\n4,3\r\n90,0\r\n180,0\r\n270,0\r\n358,0.5\r\n", "t.csv",
      {.max_gap_deg = 90.0});
  ASSERT_TRUE(t.ok()) << t.error().message;
  EXPECT_EQ(t->angle_deg.size(), 7u);
  EXPECT_DOUBLE_EQ(t->angle_deg[1], 1.5);
}

TEST(LiftTable, ReadsTheSampleParts) {
  for (const char* name : {"intake_flat.csv", "intake_flat_half_degree.csv", "exhaust_roller.csv"}) {
    auto t = read_lift_table_csv(std::filesystem::path(GAUGELOOP_SOURCE_DIR) / "examples" / name);
    ASSERT_TRUE(t.ok()) << t.error().message;
    EXPECT_GE(t->angle_deg.size(), 360u);
  }
}

struct BadTable {
  const char* text;
  const char* expected;  // a fragment the message must contain
};

class LiftTableRefusal : public ::testing::TestWithParam<BadTable> {};

TEST_P(LiftTableRefusal, NamesTheLineAndTheProblem) {
  auto t = parse_lift_table_csv(GetParam().text, "lobe.csv", {.max_gap_deg = 100.0});
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(t.error().message.find(GetParam().expected), std::string::npos) << t.error().message;
}

INSTANTIATE_TEST_SUITE_P(
    Cases, LiftTableRefusal,
    ::testing::Values(BadTable{"angle_deg,lift_mm\n0,1\n90,1\n90,2\n180,0\n270,0\n", "lobe.csv:4: duplicate angle 90"},
                      BadTable{"0,1\n90,1\n80,2\n180,0\n270,0\n", "lobe.csv:3: angle 80 deg comes after 90"},
                      BadTable{"0,1\n90,nan\n180,0\n270,0\n", "lobe.csv:2: NaN"},
                      BadTable{"0,1\n90,abc\n180,0\n270,0\n", "lobe.csv:2: lift `abc` is not a number"},
                      BadTable{"0,1\n90,1,3\n180,0\n270,0\n", "lobe.csv:2: expected two columns"},
                      BadTable{"0,1\n90,1\n200,0\n270,0\n", "lobe.csv:3: gap of 110 deg"},
                      BadTable{"0,1\n90,1\n180,0\n250,0\n", "does not cover the turn"},
                      BadTable{"0,1\n360,1\n", "lobe.csv:2: angle 360 deg is outside one turn"},
                      BadTable{"angle_deg,lift_mm\n0,1\n", "needs at least 4 points"}));

TEST(LiftTable, MissingFileIsNotFoundAndNamesThePath) {
  auto t = read_lift_table_csv("/nonexistent/dir/lobe.csv");
  ASSERT_FALSE(t.ok());
  EXPECT_EQ(t.error().code, ErrorCode::kNotFound);
  EXPECT_NE(t.error().message.find("/nonexistent/dir/lobe.csv"), std::string::npos);
}

}  // namespace
}  // namespace gaugeloop
