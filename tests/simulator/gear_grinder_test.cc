// The virtual gear grinder: the mesh error it grinds is SIM1 less dSIM of its axes' errors, with
// the coupling factors of the independent generating model; SIM1 moves linearly between the
// stroke's spline points; the checker's flanks have opposite signs and each trace is aligned on
// its tooth; a stroke edited by hand is refused as the control's reader refuses it.
#include "simulator/gear_grinder.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>

#include "tests/compensation/generating_model.h"
#include "tests/support/angles.h"
#include "tests/support/temp_dir.h"

namespace gaugeloop {
namespace {

using testing::kPi;

// A stroke program file from `points`, on a fine SIM1 grid.
std::string stroke_file(const testing::TempDir& dir, const std::vector<StrokeProgramPoint>& points) {
  StrokeProgramFormat f;
  f.sim_increments_per_deg = 1e9;
  Result<std::string> text = render_stroke_program("GEAR", {}, points, 300.0, f);
  EXPECT_TRUE(text.ok()) << text.error().message;
  const std::string path = (dir.path() / "GEAR.SPF").string();
  std::ofstream(path, std::ios::binary) << *text;
  return path;
}

TEST(GearGrinder, GrindsTheMeshErrorOfItsAxesLessSim1) {
  const GearPart part;
  const GearMachineErrors m = seeded_gear_machine(7);
  testing::TempDir dir("gear-grinder");
  const std::vector<StrokeProgramPoint> stroke{{-15.0, 0.001}, {0.0, -0.002}, {15.0, 0.0005}};
  Result<GroundGear> gear = grind_gear(part, m, stroke_file(dir, stroke));
  ASSERT_TRUE(gear.ok()) << gear.error().message;
  const testing::NumericFactors k = testing::numeric_factors(testing::GeneratingModel(part));
  for (double z : {-14.0, -7.5, 0.0, 3.25, 12.0}) {
    for (int gap : {1, 40}) {
      const AxisErrors e = m.at(z, gap);
      const double sim = z <= 0.0 ? 0.001 + (z + 15.0) / 15.0 * (-0.003) : -0.002 + z / 15.0 * 0.0025;
      // C stands ahead of where the worm needs it by SIM1 and its own error, behind by what the
      // leading axes' errors ask of it.
      const double expected = sim + e.c_deg - (k.s_yc * e.y_mm + k.s_zc * e.z_mm + k.s_bc * e.b_deg);
      EXPECT_NEAR(gear->mesh_error_deg(z, gap), expected, 1e-9) << "Z " << z << " gap " << gap;
    }
  }
  // The fast terms meet each gap at another phase: two gaps differ at the same Z.
  EXPECT_GT(std::abs(gear->mesh_error_deg(3.25, 1) - gear->mesh_error_deg(3.25, 40)), 1e-6);
}

TEST(GearGrinder, TheCheckerSeesTheFlanksOppositeAndAlignsEachTrace) {
  GearPart part;
  GearMachineErrors m;  // no error but C's, growing 0.0001 deg per mm, and 0.005 deg of lag
  m.c_deg.linear_per_mm = 0.0001;
  m.c_deg.offset = 0.005;
  m.checker_noise_um = 0.0;
  testing::TempDir dir("gear-checker");
  Result<GroundGear> gear = grind_gear(part, m, stroke_file(dir, {{-15.0, 0.0}, {15.0, 0.0}}));
  ASSERT_TRUE(gear.ok()) << gear.error().message;
  const std::vector<LeadTrace> traces = measure_lead(*gear, {1, 20}, 0.5, 0);
  ASSERT_EQ(traces.size(), 4u);
  const double um_per_deg = base_radius_mm(part.gear) * 1000.0 * kPi / 180.0;
  for (const LeadTrace& t : traces) {
    ASSERT_EQ(t.z_mm.size(), 49u) << "-12 .. 12 every 0.5 mm";
    for (std::size_t i = 0; i < t.z_mm.size(); ++i) {
      // The lag is a constant rotation: aligned away. The rest is r_b x the mesh, + on the left flank.
      EXPECT_NEAR(t.deviation_um[i], flank_sign(t.flank) * um_per_deg * 0.0001 * t.z_mm[i], 1e-9);
    }
  }
  EXPECT_EQ(traces[0].flank, Flank::kLeft);
  EXPECT_GT(traces[0].deviation_um.back(), 1.6) << "0.0012 deg at 12 mm: 1.68 um on the left flank (r_b 80.09 mm)";
}

// The profile at the face's middle: the worm's once-per-turn error of B goes round once per
// transverse base pitch of roll (one start), through the gearbox's S_BC into C; the slow errors
// and SIM1 turn the whole profile at that height, which the checker's alignment takes out.
TEST(GearGrinder, TheProfileSeesTheWormsOncePerTurnErrorAndNotTheStroke) {
  GearPart part;
  GearMachineErrors m;
  m.b_deg.fast = 0.015;
  m.checker_noise_um = 0.0;
  testing::TempDir dir("gear-profile");
  Result<GroundGear> gear = grind_gear(part, m, stroke_file(dir, {{-15.0, 0.0}, {15.0, 0.0}}));
  ASSERT_TRUE(gear.ok()) << gear.error().message;
  const ProfileRange r = profile_range(part.gear);
  // r_p 86.027 mm, r_b 80.096 mm: roll sqrt(83.777^2 - r_b^2) at r_p - m, sqrt(88.277^2 - r_b^2) at the tip.
  EXPECT_NEAR(r.start_roll_mm, 24.57, 0.01);
  EXPECT_NEAR(r.tip_roll_mm, 37.12, 0.01);
  const std::vector<ProfileTrace> traces = measure_profile(*gear, {1, 20}, 0.1, 0);
  ASSERT_EQ(traces.size(), 4u);
  const testing::NumericFactors k = testing::numeric_factors(testing::GeneratingModel(part));
  // Over 1.6 worm turns of roll the band is the sine's: 2 r_b |S_BC| B's amplitude (rad), less
  // what the 0.1 mm sampling (0.089 rad of the worm a step) misses of each peak: under 0.1 %.
  const double expected_um = 2.0 * base_radius_mm(part.gear) * 1000.0 * std::abs(k.s_bc) * 0.015 * kPi / 180.0;
  for (const ProfileTrace& t : traces) {
    Result<ProfileFigures> f = profile_figures(t, part.gear);
    ASSERT_TRUE(f.ok()) << f.error().message;
    EXPECT_NEAR(f->total_um, expected_um, 0.003 * expected_um) << "gap " << t.gap;
  }
  // The stroke's slow errors and another SIM1 leave the profile as it was.
  GearMachineErrors slow = m;
  slow.y_mm.bow_per_mm2 = 1e-4;
  slow.c_deg.offset = 0.003;
  slow.z_mm.slow = 0.004;
  Result<GroundGear> other = grind_gear(part, slow, stroke_file(dir, {{-15.0, 0.002}, {15.0, -0.001}}));
  ASSERT_TRUE(other.ok());
  const std::vector<ProfileTrace> again = measure_profile(*other, {1, 20}, 0.1, 0);
  for (std::size_t i = 0; i < traces.size(); ++i) {
    for (std::size_t j = 0; j < traces[i].deviation_um.size(); ++j) {
      EXPECT_NEAR(again[i].deviation_um[j], traces[i].deviation_um[j], 1e-9);
    }
  }
}

TEST(GearGrinder, AStrokeEditedByHandIsNotGround) {
  testing::TempDir dir("gear-edited");
  const std::string path = stroke_file(dir, {{-15.0, 0.0}, {15.0, 0.001}});
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  text.replace(text.find("SIM1=0.001"), 10, "SIM1=0.002");
  std::ofstream(path, std::ios::binary) << text;
  Result<GroundGear> gear = grind_gear(GearPart{}, seeded_gear_machine(1), path);
  ASSERT_FALSE(gear.ok());
  EXPECT_EQ(gear.error().code, ErrorCode::kRefused);
  EXPECT_NE(gear.error().message.find("edited by hand"), std::string::npos) << gear.error().message;
}

TEST(GearGrinder, TheSameSeedIsTheSameMachine) {
  const GearMachineErrors a = seeded_gear_machine(3);
  const GearMachineErrors b = seeded_gear_machine(3);
  const GearMachineErrors c = seeded_gear_machine(4);
  EXPECT_EQ(a.at(5.0, 1).y_mm, b.at(5.0, 1).y_mm);
  EXPECT_NE(a.at(5.0, 1).y_mm, c.at(5.0, 1).y_mm);
}

}  // namespace
}  // namespace gaugeloop
