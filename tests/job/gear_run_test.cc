// A measured gear judged: every trace's figures, the gear's summary and its verdict against the
// drawing's class, with the class's tolerance computed here from ISO 1328-1's formula apart.
#include "job/gear_run.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "config/gear_file.h"

namespace gaugeloop {
namespace {

const std::string kGearPart = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/gear_71.toml";

// A straight trace rising `um_per_mm` across the face, every 0.5 mm from -12 to 12.
LeadTrace rising(int gap, Flank flank, double um_per_mm) {
  LeadTrace t;
  t.gap = gap;
  t.flank = flank;
  for (int i = 0; i <= 48; ++i) {
    t.z_mm.push_back(-12.0 + 0.5 * i);
    t.deviation_um.push_back(um_per_mm * t.z_mm.back());
  }
  return t;
}

// F_betaT of class 5 for the example gear: d = 71 x 2.25 / cos 21.8 deg, b = 24 mm.
double class5_tolerance_um() {
  const double d = 71 * 2.25 / std::cos(21.8 * M_PI / 180.0);
  return 0.1 * std::sqrt(d) + 0.63 * std::sqrt(24.0) + 4.2;
}

GearRunOrigin origin_of(const GearPartFile& gf) {
  GearRunOrigin o;
  o.part_name = gf.name;
  o.required_class = gf.tolerance_class;
  o.machine = "gear-grinder-2";
  o.source = "lead.csv";
  o.nc_file = "/data/nc/GEAR_71.SPF";
  o.ground_with_version = 4;
  o.started_utc = "2026-12-04T10:00:00Z";
  return o;
}

TEST(JudgeGear, AGearIsInWhenItsWorstFlankIsWithinTheClassAndOutJustBeyond) {
  Result<GearPartFile> gf = read_gear_part_file(kGearPart);
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  ASSERT_EQ(gf->tolerance_class, 5);
  // The evaluation range is -10.8 .. 10.8 mm and its outermost points 21 mm apart (-10.5 ..
  // 10.5): F_beta, the band enclosing the points, is the rise over 21 mm; f_H_beta, the mean
  // line's rise over the range, over 21.6 mm.
  const double limit = class5_tolerance_um();
  for (const double worst : {0.99 * limit, 1.01 * limit}) {
    const std::vector<LeadTrace> traces = {rising(1, Flank::kLeft, 1.0 / 21.0), rising(1, Flank::kRight, -2.0 / 21.0),
                                           rising(40, Flank::kLeft, worst / 21.0)};
    Result<GearRunRecord> r = judge_gear(gf->part, traces, origin_of(*gf));
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_NEAR(r->total_max_um, worst, 1e-9);
    EXPECT_NEAR(r->total_mean_um, (1.0 + 2.0 + worst) / 3.0, 1e-9);
    EXPECT_NEAR(r->slope_mean_abs_um, r->total_mean_um * 21.6 / 21.0, 1e-9);  // straight: all slope, no form
    EXPECT_NEAR(r->form_mean_um, 0.0, 1e-9);
    EXPECT_EQ(r->verdict, worst < limit ? Verdict::kIn : Verdict::kOut) << worst;
    EXPECT_NEAR(*r->total_tolerance_um, limit, 1e-9);
    EXPECT_EQ(r->tolerance_class, worst < limit ? 5 : 6);
    ASSERT_EQ(r->traces.size(), 3u);
    EXPECT_EQ(r->traces[1].flank, "right");
    EXPECT_NEAR(r->traces[1].slope_um, -2.0 * 21.6 / 21.0, 1e-9);
    EXPECT_EQ(r->traces[2].gap, 40);
    EXPECT_EQ(r->traces[2].z_mm.size(), 49u);
    EXPECT_EQ(r->ground_with_version, 4);
    EXPECT_EQ(r->nc_file, "/data/nc/GEAR_71.SPF");
    EXPECT_EQ(r->started_utc, "2026-12-04T10:00:00Z");
  }
}

// A straight profile rising `um_per_mm` over the example gear's roll lengths.
ProfileTrace rising_profile(int gap, Flank flank, double um_per_mm, const GearPart& part) {
  const ProfileRange range = profile_range(part.gear);
  ProfileTrace t;
  t.gap = gap;
  t.flank = flank;
  for (int i = 0; i <= 40; ++i) {
    t.roll_mm.push_back(range.start_roll_mm + (range.tip_roll_mm - range.start_roll_mm) * i / 40.0);
    t.deviation_um.push_back(um_per_mm * (t.roll_mm.back() - range.start_roll_mm));
  }
  return t;
}

TEST(JudgeGear, TheProfilesAreKeptAndAGearIsOutWhenAProfileIsBeyondTheClassesFAlphaT) {
  Result<GearPartFile> gf = read_gear_part_file(kGearPart);
  ASSERT_TRUE(gf.ok()) << gf.error().message;
  // F_alphaT of class 5 from ISO 1328-1's formula, written out apart: m_n 2.25 mm, d as above.
  const double d = 71 * 2.25 / std::cos(21.8 * M_PI / 180.0);
  const double f_alpha_t = 3.2 * std::sqrt(2.25) + 0.22 * std::sqrt(d) + 0.7;
  const std::vector<LeadTrace> leads = {rising(1, Flank::kLeft, 0.05), rising(1, Flank::kRight, -0.05)};
  const ProfileRange range = profile_range(gf->part.gear);
  // A straight profile's F_alpha is its rise over the evaluation range's outermost points.
  for (const double over : {0.9, 1.1}) {
    Result<ProfileFigures> unit = profile_figures(rising_profile(1, Flank::kLeft, 1.0, gf->part), gf->part.gear);
    ASSERT_TRUE(unit.ok()) << unit.error().message;
    const double slope = over * f_alpha_t / unit->total_um;
    const std::vector<ProfileTrace> profiles = {rising_profile(1, Flank::kLeft, slope, gf->part),
                                                rising_profile(1, Flank::kRight, 0.1 * slope, gf->part)};
    Result<GearRunRecord> r = judge_gear(gf->part, leads, origin_of(*gf), profiles);
    ASSERT_TRUE(r.ok()) << r.error().message;
    ASSERT_EQ(r->profiles.size(), 2u);
    EXPECT_NEAR(r->profiles[0].total_um, over * f_alpha_t, 1e-9);
    EXPECT_EQ(r->profiles[0].tolerance_class, over < 1.0 ? 5 : 6);
    EXPECT_EQ(r->profiles[1].flank, "right");
    EXPECT_NEAR(r->profiles[0].to_roll_mm, range.evaluation_end_roll_mm, 0.1);
    EXPECT_EQ(r->profiles[0].roll_mm.size(), 41u);
    ASSERT_TRUE(r->profile_tolerance_um.has_value());
    EXPECT_NEAR(*r->profile_tolerance_um, f_alpha_t, 1e-9);
    // The leads alone are well within F_betaT: the profile decides.
    EXPECT_EQ(r->verdict, over < 1.0 ? Verdict::kIn : Verdict::kOut) << over;
  }
  // Leads only: no profile, no F_alphaT, judged on the leads.
  Result<GearRunRecord> leads_only = judge_gear(gf->part, leads, origin_of(*gf));
  ASSERT_TRUE(leads_only.ok());
  EXPECT_TRUE(leads_only->profiles.empty());
  EXPECT_FALSE(leads_only->profile_tolerance_um.has_value());
  EXPECT_EQ(leads_only->verdict, Verdict::kIn);
  // A profile that cannot be evaluated is refused naming it.
  ProfileTrace short_one = rising_profile(7, Flank::kRight, 1.0, gf->part);
  short_one.roll_mm.resize(2);
  short_one.deviation_um.resize(2);
  Result<GearRunRecord> refused = judge_gear(gf->part, leads, origin_of(*gf), {short_one});
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("profile of gap 7, right flank"), std::string::npos)
      << refused.error().message;
}

TEST(JudgeGear, WithoutAClassNothingIsJudged) {
  Result<GearPartFile> gf = read_gear_part_file(kGearPart);
  ASSERT_TRUE(gf.ok());
  GearRunOrigin o = origin_of(*gf);
  o.required_class.reset();
  Result<GearRunRecord> r = judge_gear(gf->part, {rising(1, Flank::kLeft, 1.0)}, o);
  ASSERT_TRUE(r.ok());
  EXPECT_EQ(r->verdict, Verdict::kNotJudged);
}

TEST(JudgeGear, ATraceTooShortIsRefusedNamingItsGapAndFlank) {
  Result<GearPartFile> gf = read_gear_part_file(kGearPart);
  ASSERT_TRUE(gf.ok());
  LeadTrace short_one = rising(20, Flank::kRight, 0.1);
  short_one.z_mm.resize(2);
  short_one.deviation_um.resize(2);
  Result<GearRunRecord> r = judge_gear(gf->part, {rising(1, Flank::kLeft, 0.1), short_one}, origin_of(*gf));
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(r.error().message.find("gap 20, right flank"), std::string::npos) << r.error().message;
  Result<GearRunRecord> none = judge_gear(gf->part, {}, origin_of(*gf));
  ASSERT_FALSE(none.ok());
  EXPECT_NE(none.error().message.find("no lead trace"), std::string::npos);
}

}  // namespace
}  // namespace gaugeloop
