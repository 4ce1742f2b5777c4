// The work speed on the control: a speed program written as FLIN feed blocks in C, rendered
// from the shipped template, read back, and what the control will run checked against it.
#include "nc_out/speed_table.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

#include "nc_out/main_program.h"

#include "infeed_values.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

using testing::shipped;

std::map<std::string, std::string> speed_values() {
  return {{"program_name", "CAM_INTAKE_L1"},
          {"part", "intake_flat"},
          {"lobe", "1"},
          {"version", "0.1.0"},
          {"run_id", "42"},
          {"origin", "run 42"},
          {"created_utc", "2026-12-01T10:00:00Z"}};
}

WorkSpeedProgram constant_program(double rpm, double step_deg = 1.0) {
  WorkSpeedProgram p;
  p.c_step_deg = step_deg;
  p.speed_rpm.assign(static_cast<size_t>(std::lround(360.0 / step_deg)), rpm);
  return p;
}

// Base circle at 24 rpm, both flanks (C 60..120 and 240..300) slowed to 6 rpm, with cosine
// ramps of 30 deg into and out of each: the paper's flank slow-down, a quarter of the speed.
WorkSpeedProgram slow_flank_program() {
  WorkSpeedProgram p = constant_program(24.0, 0.5);
  auto slow_share = [](double c) {  // 0 on the base circle, 1 on a flank
    auto window = [&](double from, double to) {
      const double ramp = 30.0;
      if (c <= from - ramp || c >= to + ramp) return 0.0;
      if (c >= from && c <= to) return 1.0;
      const double d = c < from ? from - c : c - to;
      return 0.5 * (1.0 + std::cos(std::numbers::pi * d / ramp));
    };
    return std::max(window(60.0, 120.0), window(240.0, 300.0));
  };
  for (size_t k = 0; k < p.speed_rpm.size(); ++k) {
    p.speed_rpm[k] = 24.0 - 18.0 * slow_share(static_cast<double>(k) * p.c_step_deg);
  }
  return p;
}

TEST(SpeedTable, AConstantProgramGivesAConstantFeed) {
  Result<SpeedProfile> profile = write_speed_profile(constant_program(60.0));
  ASSERT_TRUE(profile.ok()) << profile.error().message;
  ASSERT_EQ(profile->block_count(), 12);  // the widest block, 30 deg, keeps any bound
  for (const SpeedBlock& b : profile->blocks) EXPECT_DOUBLE_EQ(b.feed_deg_per_min, 21600.0);
  EXPECT_DOUBLE_EQ(profile->blocks.back().c_end_deg, 360.0);
  EXPECT_NEAR(profile->error.max_speed_error_percent, 0.0, 1e-12);
  EXPECT_NEAR(profile->error.max_timing_error_deg, 0.0, 1e-9);
  EXPECT_NEAR(profile->error.turn_time_s, 1.0, 1e-12);  // one turn at 60 rpm
  const std::string blocks = render_speed_blocks(profile->blocks);
  EXPECT_THAT(blocks, HasSubstr("G1 G64 G94 FLIN C=IC(30.000) X=IC(R1*30.000/360) F21600.0\n"
                                "C=IC(30.000) X=IC(R1*30.000/360) F21600.0\n"));
}

TEST(SpeedTable, ASlowFlankReadsBackWithinTheBound) {
  const WorkSpeedProgram program = slow_flank_program();
  SpeedProfileSettings settings;
  settings.bound_percent = 1.0;
  Result<SpeedProfile> profile = write_speed_profile(program, settings);
  ASSERT_TRUE(profile.ok()) << profile.error().message;
  EXPECT_LT(profile->block_count(), 120) << "far fewer blocks than the program's 720 steps";
  EXPECT_GT(profile->block_count(), 12) << "more than a constant speed needs";

  Result<std::string> text =
      render_speed_program(shipped("cam_speed.spf"), "cam_speed.spf", speed_values(), *profile, {42, 3});
  ASSERT_TRUE(text.ok()) << text.error().message;
  EXPECT_EQ(text->find("{{"), std::string::npos) << *text;

  Result<SpeedProfileError> back = check_speed_program(*text, "CAM_INTAKE_L1_SPEED.SPF", program, 1.0);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_LE(back->max_speed_error_percent, 1.0);
  EXPECT_GT(back->max_speed_error_percent, 0.0);
  // The flanks at a quarter of the speed: a turn takes far longer than the 2.5 s at 24 rpm,
  // and what is written keeps the program's turn time and C's timing within the bound.
  EXPECT_GT(back->program_turn_time_s, 3.75);
  EXPECT_NEAR(back->turn_time_s, back->program_turn_time_s, 0.01 * back->program_turn_time_s);
  EXPECT_LT(std::abs(back->max_timing_error_deg), 1.0);
  EXPECT_GT(back->shortest_block_s, settings.min_block_time_s);

  Result<ParsedSpeedProgram> parsed = parse_speed_program(*text, "CAM_INTAKE_L1_SPEED.SPF");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_EQ(parsed->header.at("block_count"), std::to_string(profile->block_count()));
  EXPECT_EQ(parsed->header.at("speed_form"), "feed_flin");
  EXPECT_EQ(parsed->header.at("table_version"), "3");
  EXPECT_NE(parsed->header.at("speed_error_percent"), "");
}

TEST(SpeedTable, ATighterBoundTakesMoreBlocks) {
  const WorkSpeedProgram program = slow_flank_program();
  SpeedProfileSettings loose;
  loose.bound_percent = 2.0;
  SpeedProfileSettings tight;
  tight.bound_percent = 0.5;
  Result<SpeedProfile> a = write_speed_profile(program, loose);
  Result<SpeedProfile> b = write_speed_profile(program, tight);
  ASSERT_TRUE(a.ok()) << a.error().message;
  ASSERT_TRUE(b.ok()) << b.error().message;
  EXPECT_LT(a->block_count(), b->block_count());
  EXPECT_LE(b->error.max_speed_error_percent, 0.5);
}

TEST(SpeedTable, ABlockAtOneSpeedOverTheFlankIsCaughtOnReadBack) {
  const WorkSpeedProgram program = slow_flank_program();
  // As if written for constant speed: C at 24 rpm all the way round.
  SpeedProfile flat;
  for (int k = 1; k <= 12; ++k) flat.blocks.push_back({30.0 * k, 8640.0});
  flat.writer = "by hand";
  flat.error = *speed_profile_error(constant_program(24.0, 0.5), flat.blocks);
  Result<std::string> text = render_speed_program(shipped("cam_speed.spf"), "cam_speed.spf", speed_values(), flat, {});
  ASSERT_TRUE(text.ok()) << text.error().message;
  Result<SpeedProfileError> back = check_speed_program(*text, "CAM_SPEED.SPF", program, 1.0);
  ASSERT_FALSE(back.ok());
  EXPECT_EQ(back.error().code, ErrorCode::kRefused);
  EXPECT_THAT(back.error().message, HasSubstr("300.000 %"));  // 24 rpm where the program says 6
  EXPECT_THAT(back.error().message, HasSubstr("CAM_SPEED.SPF"));
}

TEST(SpeedTable, BadProgramsAreRefusedNamingTheDegree) {
  WorkSpeedProgram p = constant_program(60.0);
  p.speed_rpm[90] = -5.0;
  Result<SpeedProfile> r = write_speed_profile(p);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(r.error().message, HasSubstr("C90.000"));

  p = constant_program(60.0, 0.5);
  p.speed_rpm[3] = std::nan("");
  r = write_speed_profile(p);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("C1.500"));

  p = constant_program(60.0, 1.0);
  p.c_step_deg = 0.7;
  r = write_speed_profile(p);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("does not divide 360"));

  p = constant_program(60.0, 1.0);
  p.speed_rpm.pop_back();
  r = write_speed_profile(p);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("expected 360"));
}

TEST(SpeedTable, ASpeedStepFasterThanTheBlockRateIsRefusedNamingWhere) {
  WorkSpeedProgram p = constant_program(60.0);
  for (size_t k = 100; k < 200; ++k) p.speed_rpm[k] = 6.0;  // a step from 60 to 6 rpm at C100
  SpeedProfileSettings settings;
  settings.min_block_time_s = 0.012;
  Result<SpeedProfile> r = write_speed_profile(p, settings);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kRefused);
  EXPECT_THAT(r.error().message, HasSubstr("C99.000"));
  EXPECT_THAT(r.error().message, HasSubstr("shortest block time 12.0 ms"));
  settings.min_block_time_s = 0.0;  // a control that can take any block rate
  EXPECT_TRUE(write_speed_profile(p, settings).ok());
}

TEST(SpeedTable, AHandEditIsRefusedOnReadBack) {
  Result<SpeedProfile> profile = write_speed_profile(slow_flank_program());
  ASSERT_TRUE(profile.ok());
  Result<std::string> text =
      render_speed_program(shipped("cam_speed.spf"), "cam_speed.spf", speed_values(), *profile, {42, 1});
  ASSERT_TRUE(text.ok());
  std::string edited = *text;
  const size_t at = edited.find("F8640.0");
  ASSERT_NE(at, std::string::npos);
  edited.replace(at, 7, "F9000.0");
  Result<ParsedSpeedProgram> parsed = parse_speed_program(edited, "CAM_SPEED.SPF");
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  Status s = verify_speed_checksum(*parsed, "CAM_SPEED.SPF");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kRefused);
  EXPECT_THAT(s.error().message, HasSubstr("edited by hand"));
}

TEST(SpeedTable, ReadBackRefusesWhatItCannotModelWithTheLine) {
  const std::string text =
      "; gaugeloop body_checksum_fnv1a64: 0\n"
      "G1 G64 G94 FLIN C=IC(180.000) F21600.0\n"
      "G91 C=IC(180.000) F21600.0\n"
      "M17\n";
  Result<ParsedSpeedProgram> r = parse_speed_program(text, "CAM_SPEED.SPF");
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("CAM_SPEED.SPF:3"));
  EXPECT_THAT(r.error().message, HasSubstr("'G91'"));

  Result<ParsedSpeedProgram> short_turn =
      parse_speed_program("G1 G64 G94 FLIN C=IC(180.000) F21600.0\nC=IC(179.000) F21600.0\nM17\n", "CAM_SPEED.SPF");
  ASSERT_FALSE(short_turn.ok());
  EXPECT_THAT(short_turn.error().message, HasSubstr("359.0000 deg"));

  Result<ParsedSpeedProgram> no_flin = parse_speed_program("G1 G94 C=IC(360.000) F21600.0\nM17\n", "CAM_SPEED.SPF");
  ASSERT_FALSE(no_flin.ok());
  EXPECT_THAT(no_flin.error().message, HasSubstr("G1 G64 G94 FLIN"));
}

TEST(SpeedTable, ATemplateThatBreaksTheBlocksIsRefused) {
  Result<SpeedProfile> profile = write_speed_profile(constant_program(60.0));
  ASSERT_TRUE(profile.ok());
  const std::string bad = "{{speed_header}}\nG91\n{{speed_blocks}}\nM17\n";
  Result<std::string> r = render_speed_program(bad, "my_speed.spf", speed_values(), *profile, {});
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.error().message, HasSubstr("my_speed.spf"));
  EXPECT_THAT(r.error().message, HasSubstr("does not read back"));
}

TEST(SpeedTable, TheShippedSpeedMainProgramCallsTheSpeedSubprogramAndCouplesTheTable) {
  std::map<std::string, std::string> values = speed_values();
  values["table_version"] = "4";
  values["table_number"] = "2";
  values["point_count"] = "91";
  values["interpolation"] = "cspline";
  values["table_start_c_deg"] = "180.000";
  testing::add_infeed_values(values);
  Result<std::string> main = render_main_program(shipped("cam_main_speed.mpf"), "cam_main_speed.mpf", values);
  ASSERT_TRUE(main.ok()) << main.error().message;
  EXPECT_EQ(main->find("{{"), std::string::npos) << *main;
  EXPECT_EQ(*coupled_table_number(*main, "CAM_INTAKE_L1_MAIN.MPF"), 2);
  EXPECT_EQ(speed_program_name("CAM_INTAKE_L1"), "CAM_INTAKE_L1_SPEED");
  EXPECT_TRUE(check_main_calls_speed_program(*main, "CAM_INTAKE_L1_MAIN.MPF", "CAM_INTAKE_L1_SPEED").ok());

  // The constant-speed main program does not call it: refused when a speed program is on.
  Result<std::string> plain = render_main_program(shipped("cam_main.mpf"), "cam_main.mpf", values);
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  Status s = check_main_calls_speed_program(*plain, "CAM_INTAKE_L1_MAIN.MPF", "CAM_INTAKE_L1_SPEED");
  ASSERT_FALSE(s.ok());
  EXPECT_THAT(s.error().message, HasSubstr("CAM_INTAKE_L1_SPEED"));
}

}  // namespace
}  // namespace gaugeloop
