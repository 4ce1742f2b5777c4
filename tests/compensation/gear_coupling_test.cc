// The generating gearbox's coupling factors against an independent numeric model of the
// generating motion: the worm's thread and the gear's tooth space as 3D helices, the setting
// angle found by root finding where their tangents are parallel at the grinding point, the
// worm's lead found from its normal pitch, and C(Y, Z, B) solved from the mesh condition in the
// plane tangent to both pitch cylinders; the factors are its finite differences. Nothing here
// uses the closed forms of compensation/gear_coupling.h.
#include "compensation/gear_coupling.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <string>

#include "tests/compensation/generating_model.h"

namespace gaugeloop {
namespace {

using testing::GeneratingModel;
using testing::numeric_factors;
using testing::NumericFactors;

// The generating paper's gear: module 2.25, 71 teeth, 20 deg, helix 21.8 deg, face 24 mm; the
// worm (not given there) one start on 275 mm.
GearPart paper_gear(Hand gear_hand, Hand worm_hand, double helix_deg = 21.8) {
  GearPart p;
  p.gear.normal_module_mm = 2.25;
  p.gear.teeth = 71;
  p.gear.pressure_angle_deg = 20.0;
  p.gear.helix_angle_deg = helix_deg;
  p.gear.hand = gear_hand;
  p.gear.face_width_mm = 24.0;
  p.worm.starts = 1;
  p.worm.pitch_diameter_mm = 275.0;
  p.worm.hand = worm_hand;
  return p;
}

// 1e-9 relative: the model's bisections end at the last bit and the differences are of a
// linear relation, so what is left is rounding, some 1e-13.
void expect_relative(double closed, double numeric, const char* what) {
  EXPECT_NEAR(closed, numeric, 1e-9 * std::max(std::abs(closed), 1e-300)) << what;
}

TEST(GearCoupling, TheFactorsAgreeWithTheNumericModelForBothHandsAndASpurGear) {
  struct Case {
    const char* what;
    GearPart part;
  };
  const Case cases[] = {
      {"right gear, right worm", paper_gear(Hand::kRight, Hand::kRight)},
      {"right gear, left worm", paper_gear(Hand::kRight, Hand::kLeft)},
      {"left gear, right worm", paper_gear(Hand::kLeft, Hand::kRight)},
      {"left gear, left worm", paper_gear(Hand::kLeft, Hand::kLeft)},
      {"spur gear, right worm", paper_gear(Hand::kRight, Hand::kRight, 0.0)},
      {"spur gear, left worm of 3 starts",
       [] {
         GearPart p = paper_gear(Hand::kRight, Hand::kLeft, 0.0);
         p.worm.starts = 3;
         return p;
       }()},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    ASSERT_TRUE(validate(c.part).ok()) << validate(c.part).error().message;
    const GearCoupling k = gear_coupling(c.part);
    const GeneratingModel model(c.part);
    const NumericFactors n = numeric_factors(model);
    expect_relative(k.s_yc_deg_per_mm, n.s_yc, "S_YC");
    expect_relative(k.s_bc, n.s_bc, "S_BC");
    if (c.part.gear.helix_angle_deg == 0.0) {
      EXPECT_EQ(k.s_zc_deg_per_mm, 0.0);
      EXPECT_LT(std::abs(n.s_zc), 1e-12) << "a spur gear needs no turn for the stroke";
    } else {
      expect_relative(k.s_zc_deg_per_mm, n.s_zc, "S_ZC");
    }
    expect_relative(k.setting_angle_deg, model.setting_angle_deg(), "setting angle");
    expect_relative(k.worm_lead_mm, model.lead_mm(), "worm lead");
    EXPECT_EQ(k.s_sim_c, 1.0);
  }
}

// The hands flip what they should and nothing else: the stroke's turn with the gear's hand,
// the worm's rotation with the worm's, the shift with neither.
TEST(GearCoupling, EachHandFlipsItsOwnFactor) {
  const GearCoupling rr = gear_coupling(paper_gear(Hand::kRight, Hand::kRight));
  const GearCoupling lr = gear_coupling(paper_gear(Hand::kLeft, Hand::kRight));
  const GearCoupling rl = gear_coupling(paper_gear(Hand::kRight, Hand::kLeft));
  EXPECT_EQ(lr.s_zc_deg_per_mm, -rr.s_zc_deg_per_mm);
  EXPECT_EQ(lr.s_bc, rr.s_bc);
  EXPECT_EQ(rl.s_bc, -rr.s_bc);
  EXPECT_EQ(rl.s_zc_deg_per_mm, rr.s_zc_deg_per_mm);
  EXPECT_EQ(rl.s_yc_deg_per_mm, rr.s_yc_deg_per_mm);
  // The worm's generating ratio: one start past 71 teeth.
  EXPECT_DOUBLE_EQ(std::abs(rr.s_bc), 1.0 / 71.0);
  // Same hands: the worm is set at the helix angle less its lead angle; opposite: plus.
  EXPECT_NEAR(std::abs(rr.setting_angle_deg), 21.8 - rr.lead_angle_deg, 1e-12);
  EXPECT_NEAR(std::abs(rl.setting_angle_deg), 21.8 + rl.lead_angle_deg, 1e-12);
}

// dSIM puts the gear back in mesh: the model's C for where the axes really stand, less where C
// really stands, is the SIM1 move, for errors on every axis at once.
TEST(GearCoupling, TheEquivalentSimMoveIsWhatTheModelsMeshNeeds) {
  const GearPart part = paper_gear(Hand::kRight, Hand::kLeft);
  const GearCoupling k = gear_coupling(part);
  const GeneratingModel model(part);
  const double y = 3.0, z = -7.5, b = 12.0;  // commanded
  const AxisErrors e{0.012, -0.020, 0.004, 0.0015};
  const double c_commanded = model.c_deg(y, z, b);  // what the gearbox gives C for the commanded axes
  const double c_needed = model.c_deg(y + e.y_mm, z + e.z_mm, b + e.b_deg);
  const double c_stands = c_commanded + e.c_deg;
  EXPECT_NEAR(equivalent_sim_deg(k, e), c_needed - c_stands, 1e-12);
  EXPECT_EQ(equivalent_sim_deg(k, AxisErrors{}), 0.0);
}

TEST(GearCoupling, ABadGearPartIsRefusedNamingTheKey) {
  struct Bad {
    std::function<void(GearPart&)> change;
    const char* key;
  };
  const Bad bad[] = {
      {[](GearPart& p) { p.gear.normal_module_mm = 0.0; }, "[gear] normal_module_mm"},
      {[](GearPart& p) { p.gear.teeth = 3; }, "[gear] teeth = 3"},
      {[](GearPart& p) { p.gear.pressure_angle_deg = 60.0; }, "[gear] pressure_angle_deg"},
      {[](GearPart& p) { p.gear.helix_angle_deg = -5.0; }, "[gear] helix_angle_deg"},
      {[](GearPart& p) { p.gear.helix_angle_deg = NAN; }, "[gear] helix_angle_deg"},
      {[](GearPart& p) { p.gear.face_width_mm = 0.0; }, "[gear] face_width_mm"},
      {[](GearPart& p) { p.worm.starts = 0; }, "[gear.worm] starts"},
      {[](GearPart& p) { p.worm.pitch_diameter_mm = 3.0; }, "[gear.worm] pitch_diameter_mm"},
      {[](GearPart& p) {
         p.worm.pitch_diameter_mm = 12.0;
         p.worm.starts = 10;
       },
       "lead more than 45 deg"},
      {[](GearPart& p) { p.worm.lead_angle_deg = 1.0; }, "[gear.worm] lead_angle_deg"},
      {[](GearPart& p) { p.stroke.z_end_mm = p.stroke.z_start_mm; }, "[gear.stroke] z_end_mm"},
      {[](GearPart& p) { p.stroke.spline_step_mm = 0.0; }, "[gear.stroke] spline_step_mm"},
      {[](GearPart& p) { p.stroke.spline_step_mm = 1e-6; }, "at most 100,000 points"},
  };
  for (const Bad& b : bad) {
    GearPart p = paper_gear(Hand::kRight, Hand::kRight);
    b.change(p);
    Status s = validate(p);
    ASSERT_FALSE(s.ok()) << b.key;
    EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(s.error().message.find(b.key), std::string::npos) << s.error().message;
  }
  GearPart given = paper_gear(Hand::kRight, Hand::kRight);
  given.worm.lead_angle_deg = worm_lead_angle_deg(given.worm, 2.25) + 0.005;
  EXPECT_TRUE(validate(given).ok()) << "a lead angle given to 0.01 deg is the worm's";
}

}  // namespace
}  // namespace gaugeloop
