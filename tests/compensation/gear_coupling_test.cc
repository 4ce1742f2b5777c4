// The generating gearbox's coupling factors against an independent numeric model of the
// generating motion: the worm's thread and the gear's tooth space as 3D helices, the setting
// angle found by root finding where their tangents are parallel at the grinding point, the
// worm's lead found from its normal pitch, and C(Y, Z, B) solved from the mesh condition in the
// plane tangent to both pitch cylinders; the factors are its finite differences. Nothing here
// uses the closed forms of compensation/gear_coupling.h.
#include "compensation/gear_coupling.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <functional>
#include <string>

namespace gaugeloop {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRad = kPi / 180.0;

using Vec = std::array<double, 3>;
Vec add(Vec a, Vec b) { return {a[0] + b[0], a[1] + b[1], a[2] + b[2]}; }
Vec sub(Vec a, Vec b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
Vec scale(Vec a, double s) { return {a[0] * s, a[1] * s, a[2] * s}; }
double dot(Vec a, Vec b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec cross(Vec a, Vec b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
Vec unit(Vec a) { return scale(a, 1.0 / std::sqrt(dot(a, a))); }

// A root of f in [lo, hi] where f changes sign, to the last bit.
double bisect(const std::function<double(double)>& f, double lo, double hi) {
  double flo = f(lo);
  for (int i = 0; i < 200 && hi - lo > 0.0; ++i) {
    const double mid = 0.5 * (lo + hi);
    if (mid == lo || mid == hi) break;
    const double fm = f(mid);
    if ((fm < 0.0) == (flo < 0.0)) {
      lo = mid;
      flo = fm;
    } else {
      hi = mid;
    }
  }
  return 0.5 * (lo + hi);
}

// The tangent of a curve at parameter u, by a central difference.
Vec tangent(const std::function<Vec(double)>& curve, double u) {
  const double h = 1e-6;
  return unit(sub(curve(u + h), curve(u - h)));
}

// The machine of core/gear.h: gear axis +z through the origin, the worm's centre on +x at the
// stroke's height Z, the grinding point T = (r2, 0, Z) where both pitch cylinders touch.
class GeneratingModel {
 public:
  explicit GeneratingModel(const GearPart& p) : p_(p) {
    const double mn = p.gear.normal_module_mm;
    beta_ = p.gear.helix_angle_deg * kRad;
    hg_ = p.gear.helix_angle_deg == 0.0 ? 0.0 : (p.gear.hand == Hand::kRight ? 1.0 : -1.0);
    hw_ = p.worm.hand == Hand::kRight ? 1.0 : -1.0;
    r0_ = p.worm.pitch_diameter_mm / 2.0;
    // The gear's pitch radius: its teeth, one normal pitch (pi m_n) apart across the helix.
    r2_ = p.gear.teeth * mn / (2.0 * std::cos(beta_));
    // The worm's lead: the one whose threads are one normal pitch apart on its pitch cylinder.
    // A lead L makes threads L / z0 apart along the axis, and across the thread that times the
    // cosine of the thread's angle to the circumference, atan(L / (2 pi r0)).
    const double z0 = p.worm.starts;
    auto normal_pitch_excess = [&](double lead) {
      const double circumference = 2.0 * kPi * r0_;
      return lead / z0 * circumference / std::sqrt(circumference * circumference + lead * lead) - kPi * mn;
    };
    lead_ = bisect(normal_pitch_excess, 1e-9, 1e6);
    // The setting angle: where the thread's tangent at T is parallel to the tooth's.
    setting_rad_ = bisect(
        [&](double eta) {
          eta_ = eta;
          const double u = thread_at_contact(0.0, 0.0, 0.0);
          const Vec tw = tangent([&](double v) { return thread(v, 0.0, 0.0, 0.0); }, u);
          const Vec tg = tangent([&](double z) { return tooth(z, 0.0); }, 0.0);
          return cross(tw, tg)[0];
        },
        -89.0 * kRad, 89.0 * kRad);
    eta_ = setting_rad_;
  }

  double setting_angle_deg() const { return setting_rad_ / kRad; }
  double lead_mm() const { return lead_; }

  // C (deg) that meshes the gear with the worm standing at B (deg), Y, Z (mm), near C = 0.
  double c_deg(double y_mm, double z_mm, double b_deg) const {
    const double u = thread_at_contact(y_mm, z_mm, b_deg);
    const Vec pw = thread(u, y_mm, z_mm, b_deg);  // the thread where it touches the gear's pitch cylinder's line
    const Vec tg = tangent([&](double z) { return tooth(z, 0.0); }, 0.0);
    const Vec n = unit(cross({1.0, 0.0, 0.0}, tg));  // across the tooth, in the tangent plane
    // The tooth space at the thread's height, developed onto the tangent plane: y = r2 * angle.
    auto miss = [&](double c) {
      const Vec g = tooth(pw[2], c);
      const Vec q{r2_, r2_ * std::atan2(g[1], g[0]), pw[2]};
      return dot(sub(pw, q), n);
    };
    return bisect(miss, -20.0, 20.0);
  }

 private:
  // The worm's axis and its frame: w_x from the worm's centre to T, w_y = a x w_x.
  Vec axis() const { return {0.0, std::cos(eta_), std::sin(eta_)}; }
  Vec centre(double z_mm) const { return {r2_ + r0_, 0.0, z_mm}; }

  // Thread 0 of the worm turned by B and shifted by Y along its axis, at body angle u: in the
  // body, a right-hand thread rises by L / 2 pi per radian about the axis.
  Vec thread(double u, double y_mm, double z_mm, double b_deg) const {
    const Vec a = axis();
    const Vec wx{-1.0, 0.0, 0.0};
    const Vec wy = cross(a, wx);
    const double at = u + b_deg * kRad;  // the body turned by B
    Vec p = add(centre(z_mm), scale(a, y_mm + hw_ * lead_ / (2.0 * kPi) * u));
    p = add(p, scale(wx, r0_ * std::cos(at)));
    return add(p, scale(wy, r0_ * std::sin(at)));
  }

  // The body angle at which thread 0 passes the line where the worm's pitch cylinder touches the
  // gear's (the side facing the gear: w_y component 0, w_x component positive).
  double thread_at_contact(double y_mm, double z_mm, double b_deg) const {
    const Vec a = axis();
    const Vec wy = cross(a, {-1.0, 0.0, 0.0});
    const double guess = -b_deg * kRad;
    return bisect([&](double u) { return dot(sub(thread(u, y_mm, z_mm, b_deg), centre(z_mm)), wy); }, guess - 1.0,
                  guess + 1.0);
  }

  // Tooth space 0 of the gear turned by C, at height z: a right-hand helix turns +C as z rises.
  Vec tooth(double z_mm, double c_deg) const {
    const double angle = c_deg * kRad + hg_ * z_mm * std::tan(beta_) / r2_;
    return {r2_ * std::cos(angle), r2_ * std::sin(angle), z_mm};
  }

  GearPart p_;
  double beta_ = 0.0, hg_ = 0.0, hw_ = 0.0, r0_ = 0.0, r2_ = 0.0, lead_ = 0.0;
  double setting_rad_ = 0.0;
  mutable double eta_ = 0.0;
};

// The factors as finite differences of the model's C(Y, Z, B). The relation is linear, so a
// step of 1 mm or 1 deg loses nothing; central differences cancel the constant.
struct NumericFactors {
  double s_yc, s_zc, s_bc;
};
NumericFactors numeric_factors(const GeneratingModel& m) {
  const double h = 1.0;
  return {(m.c_deg(h, 0, 0) - m.c_deg(-h, 0, 0)) / (2 * h), (m.c_deg(0, h, 0) - m.c_deg(0, -h, 0)) / (2 * h),
          (m.c_deg(0, 0, h) - m.c_deg(0, 0, -h)) / (2 * h)};
}

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
