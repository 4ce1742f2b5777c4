// The main program's passes from blank to size: they add up to the start offset on the
// control's grid, keep the infeed per turn asked for, and read back from their own text; the
// speed subprogram feeds its share of R1 in every block.
#include <gtest/gtest.h>

#include <cmath>
#include <regex>
#include <sstream>
#include <string>

#include "nc_out/infeed.h"
#include "nc_out/speed_table.h"

namespace gaugeloop {
namespace {

// Sums of the passes' blocks as the text says them: C turned, X fed.
struct BlockSums {
  double c_deg = 0.0;
  double x_mm = 0.0;
  int blocks = 0;
  double feed = 0.0;
};
BlockSums sums_of(const std::string& text) {
  BlockSums s;
  const std::regex block(R"(^G1 G91 C([0-9.]+)(?: X(-?[0-9.]+))? F([0-9.]+))");
  std::istringstream in(text);
  std::string line;
  while (std::getline(in, line)) {
    std::smatch m;
    if (!std::regex_search(line, m, block)) continue;
    s.c_deg += std::stod(m[1]);
    if (m[2].matched) s.x_mm += std::stod(m[2]);
    s.feed = std::stod(m[3]);
    ++s.blocks;
  }
  return s;
}

TEST(Infeed, ThePassesAddUpToTheStartOffsetAndKeepTheInfeedPerTurn) {
  GrindingCycle c;
  c.stock_mm = 0.3;
  c.air_gap_mm = 0.05;
  c.roughing_infeed_mm_per_turn = 0.03;
  c.finishing_stock_mm = 0.025;
  c.finishing_infeed_mm_per_turn = 0.004;
  c.spark_out_turns = 3;
  Result<InfeedPlan> p = plan_infeed(c);
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_DOUBLE_EQ(p->start_offset_mm, 0.35);
  ASSERT_EQ(p->passes.size(), 3u);
  double fed = 0.0;
  for (const InfeedPass& pass : p->passes) fed += pass.infeed_mm;
  EXPECT_NEAR(fed, p->start_offset_mm, 1e-12);
  // Roughing 0.325 mm at most 0.03 a turn: 11 turns (10 would take 0.0325 a turn).
  EXPECT_EQ(p->passes[0].name, "roughing");
  EXPECT_EQ(p->passes[0].turns, 11);
  EXPECT_LE(p->passes[0].infeed_mm / p->passes[0].turns, c.roughing_infeed_mm_per_turn);
  EXPECT_GT(p->passes[0].infeed_mm / (p->passes[0].turns - 1), c.roughing_infeed_mm_per_turn);
  // Finishing 0.025 at 0.004: 7 turns.
  EXPECT_EQ(p->passes[1].turns, 7);
  EXPECT_EQ(p->passes[2].name, "spark-out");
  EXPECT_EQ(p->passes[2].turns, 3);
  EXPECT_EQ(p->passes[2].infeed_mm, 0.0);
  EXPECT_EQ(p->turns(), 21);
}

TEST(Infeed, TheBlocksFeedTheWholeOffsetTowardsThePartAtTheWorkSpeed) {
  GrindingCycle c;
  CurveTableFormat f;
  f.x_increments_per_mm = 1000.0;  // X written with 3 decimals
  Result<InfeedPlan> p = plan_infeed(c, f);
  ASSERT_TRUE(p.ok());
  const std::string text = render_infeed_blocks(*p, 45.0, f);
  EXPECT_EQ(text.rfind("FGROUP(C)", 0), 0u) << text;
  EXPECT_NE(text.find("\nFGROUP()"), std::string::npos) << text;
  const BlockSums s = sums_of(text);
  EXPECT_EQ(s.blocks, 3);
  EXPECT_NEAR(s.x_mm, -p->start_offset_mm, 1e-12) << "the wheel ends on the table: final size";
  EXPECT_NEAR(s.c_deg, 360.0 * p->turns(), 1e-9);
  EXPECT_DOUBLE_EQ(s.feed, 360.0 * 45.0);
  EXPECT_NE(text.find("X-0.230 "), std::string::npos) << "on the control's grid\n" << text;
}

TEST(Infeed, AWrongCycleIsRefusedNamingTheKey) {
  struct Case {
    GrindingCycle c;
    const char* key;
  };
  GrindingCycle finishing_over;
  finishing_over.finishing_stock_mm = 0.5;
  GrindingCycle no_infeed;
  no_infeed.roughing_infeed_mm_per_turn = 0.0;
  GrindingCycle spark;
  spark.spark_out_turns = 101;
  GrindingCycle negative;
  negative.stock_mm = -0.1;
  for (const Case& k : {Case{finishing_over, "finishing_stock_mm"}, Case{no_infeed, "roughing_infeed_mm_per_turn"},
                        Case{spark, "spark_out_turns"}, Case{negative, "stock_mm"}}) {
    Result<InfeedPlan> p = plan_infeed(k.c);
    ASSERT_FALSE(p.ok()) << k.key;
    EXPECT_EQ(p.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(p.error().message.find(std::string("[grinding] ") + k.key), std::string::npos) << p.error().message;
  }
  GrindingCycle slow;
  slow.stock_mm = 5.0;
  slow.roughing_infeed_mm_per_turn = 0.001;
  Result<InfeedPlan> p = plan_infeed(slow);
  ASSERT_FALSE(p.ok());
  EXPECT_NE(p.error().message.find("more than 1000"), std::string::npos) << p.error().message;
}

TEST(Infeed, TheCycleTravelsInTheTablesHeaderAndReadsBack) {
  CycleOnControl c;
  c.cycle.stock_mm = 0.15;
  c.cycle.spark_out_turns = 4;
  c.work_speed_rpm = 45.0;
  c.format.x_increments_per_mm = 1000.0;
  Result<CycleOnControl> back = read_grinding_cycle_text(grinding_cycle_text(c));
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_DOUBLE_EQ(back->cycle.stock_mm, 0.15);
  EXPECT_EQ(back->cycle.spark_out_turns, 4);
  EXPECT_DOUBLE_EQ(back->work_speed_rpm, 45.0);
  EXPECT_DOUBLE_EQ(back->format.x_increments_per_mm, 1000.0);
  const std::string cut = grinding_cycle_text(c).substr(0, 40);
  EXPECT_FALSE(read_grinding_cycle_text(cut).ok());
  EXPECT_FALSE(read_grinding_cycle_text("stock_mm lots").ok());
}

TEST(Infeed, UnderASpeedProgramEachPassSetsR1AndCallsTheSubprogramItsTurns) {
  Result<InfeedPlan> p = plan_infeed(GrindingCycle{});
  ASSERT_TRUE(p.ok());
  const std::string text = render_speed_infeed_blocks(*p, "CAM_SPEED");
  std::istringstream in(text);
  std::string line;
  double fed = 0.0;
  double r1 = 0.0;
  int turns = 0;
  const std::regex set(R"(^R1=(-?[0-9.]+))");
  const std::regex call(R"(^CAM_SPEED P([0-9]+))");
  while (std::getline(in, line)) {
    std::smatch m;
    if (std::regex_search(line, m, set)) r1 = std::stod(m[1]);
    if (std::regex_search(line, m, call)) {
      fed += r1 * std::stoi(m[1]);
      turns += std::stoi(m[1]);
    }
  }
  EXPECT_NEAR(fed, -p->start_offset_mm, 1e-7);
  EXPECT_EQ(turns, p->turns());
  EXPECT_EQ(text.substr(text.rfind('\n') + 1), "R1=0") << "R1 is left at no infeed";
}

TEST(SpeedInfeed, EveryBlockFeedsItsOwnShareOfR1) {
  const std::vector<SpeedBlock> blocks{{120.0, 21600.0}, {240.0, 10800.0}, {360.0, 21600.0}};
  const std::string body = render_speed_blocks(blocks);
  EXPECT_NE(body.find("C=IC(120.000) X=IC(R1*120.000/360) F21600.0"), std::string::npos) << body;
  Result<ParsedSpeedProgram> p = parse_speed_program(body + "\nM17\n", "CAM_SPEED.SPF");
  ASSERT_TRUE(p.ok()) << p.error().message;
  EXPECT_TRUE(p->overlaid_infeed);
  Result<ParsedSpeedProgram> wrong = parse_speed_program(
      "G1 G64 G94 FLIN C=IC(120.000) X=IC(R1*120.000/360) F21600.0\nC=IC(240.000) X=IC(R1*120.000/360) F21600.0\nM17\n",
      "CAM_SPEED.SPF");
  ASSERT_FALSE(wrong.ok());
  EXPECT_NE(wrong.error().message.find("CAM_SPEED.SPF:2"), std::string::npos) << wrong.error().message;
  Result<ParsedSpeedProgram> mixed = parse_speed_program(
      "G1 G64 G94 FLIN C=IC(120.000) X=IC(R1*120.000/360) F21600.0\nC=IC(240.000) F21600.0\nM17\n", "CAM_SPEED.SPF");
  ASSERT_FALSE(mixed.ok());
  EXPECT_NE(mixed.error().message.find("some speed blocks feed X by R1"), std::string::npos) << mixed.error().message;
}

}  // namespace
}  // namespace gaugeloop
