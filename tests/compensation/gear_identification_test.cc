// The axes' errors identified from lead traces (and a ballbar): data built here from a machine
// with known terms through the independent generating model's coupling factors, recovered by
// the fit; terms that act alike on the data refused, naming them.
#include "compensation/gear_identification.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "tests/compensation/generating_model.h"
#include "tests/support/angles.h"

namespace gaugeloop {
namespace {

using testing::kPi;

// A machine of known terms: each axis' error as a function of z.
struct KnownMachine {
  std::function<double(double)> y_mm = [](double) { return 0.0; };
  std::function<double(double)> z_mm = [](double) { return 0.0; };
  std::function<double(double)> b_deg = [](double) { return 0.0; };
  std::function<double(double)> c_deg = [](double) { return 0.0; };
};

// SIM1 in force: 0.001 deg and 0.0001 deg per mm, at every mm of the stroke.
std::vector<StrokeSimPoint> sim_in_force() {
  std::vector<StrokeSimPoint> s;
  for (int i = 0; i <= 30; ++i) {
    StrokeSimPoint p;
    p.z_mm = -15.0 + i;
    p.sim_deg = 0.001 + 0.0001 * p.z_mm;
    s.push_back(p);
  }
  return s;
}

// Gaps 1 and 40, both flanks, every 0.5 mm over the face, each with an offset of its own: the
// flank is r_b (SIM1 - dSIM) with dSIM from the generating model's factors.
std::vector<LeadTrace> lead_of(const KnownMachine& m) {
  const GearPart part;
  const testing::NumericFactors k = testing::numeric_factors(testing::GeneratingModel(part));
  const double um_per_deg = base_radius_mm(part.gear) * 1000.0 * kPi / 180.0;
  std::vector<LeadTrace> out;
  double offset = 1.0;
  for (int gap : {1, 40}) {
    for (Flank f : {Flank::kLeft, Flank::kRight}) {
      LeadTrace t;
      t.gap = gap;
      t.flank = f;
      offset *= -1.7;
      for (int i = 0; i <= 48; ++i) {
        const double z = -12.0 + 0.5 * i;
        const double dsim = k.s_yc * m.y_mm(z) + k.s_zc * m.z_mm(z) + k.s_bc * m.b_deg(z) - m.c_deg(z);
        t.z_mm.push_back(z);
        t.deviation_um.push_back(flank_sign(f) * um_per_deg * (0.001 + 0.0001 * z - dsim) + offset);
      }
      out.push_back(t);
    }
  }
  return out;
}

// A ballbar of 100 mm radius every 2 deg: Y and Z at z = r sin(angle), with 3 um and -2 um of
// centring and Y's scale 10 um per metre against Z's.
BallbarCircle ballbar_of(const KnownMachine& m) {
  BallbarCircle b;
  for (int i = 0; i < 180; ++i) {
    const double ang = 2.0 * i * kPi / 180.0;
    const double z = 100.0 * std::sin(ang);
    b.angle_deg.push_back(2.0 * i);
    b.radial_um.push_back(1000.0 * (m.y_mm(z) * std::cos(ang) + m.z_mm(z) * std::sin(ang)) + 3.0 * std::cos(ang) -
                          2.0 * std::sin(ang) + 100.0 * 0.01 * std::cos(ang) * std::cos(ang));
  }
  return b;
}

const IdentifiedTerm& term(const AxisIdentification& id, const std::string& name) {
  for (const IdentifiedTerm& t : id.terms) {
    if (t.term.name() == name) return t;
  }
  ADD_FAILURE() << "no term " << name;
  return id.terms.front();
}

// The numeric model's factors agree with the closed forms to 1e-9 relative: the recovered terms
// agree with the machine's to 1e-6 relative.
constexpr double kRelative = 1e-6;

TEST(GearIdentification, TermsOfDifferentShapesComeBackFromTheLeadAlone) {
  KnownMachine m;
  m.y_mm = [](double z) { return 2e-5 * z * z; };
  m.z_mm = [](double z) { return 0.004 * std::sin(2.0 * kPi * z / 13.0 + 0.7); };
  m.b_deg = [](double z) { return 0.0002 * z; };
  m.c_deg = [](double z) { return 0.003 * std::sin(2.0 * kPi * z / 24.0 - 1.1); };
  Result<std::vector<ErrorTerm>> terms = parse_error_terms("y:bow, z:periodic@13, b:linear, c:periodic@24");
  ASSERT_TRUE(terms.ok()) << terms.error().message;
  const GearPart part;
  Result<AxisIdentification> id =
      identify_axis_errors(gear_coupling(part), base_radius_mm(part.gear), *terms, lead_of(m), sim_in_force(), nullptr);
  ASSERT_TRUE(id.ok()) << id.error().message;
  EXPECT_NEAR(term(*id, "Y bow").value, 2e-5, 2e-5 * kRelative);
  EXPECT_NEAR(term(*id, "Z periodic 13 mm").value, 0.004, 0.004 * kRelative);
  EXPECT_NEAR(term(*id, "Z periodic 13 mm").phase_rad, 0.7, kRelative);
  EXPECT_NEAR(term(*id, "B linear").value, 0.0002, 0.0002 * kRelative);
  EXPECT_NEAR(term(*id, "C periodic 24 mm").value, 0.003, 0.003 * kRelative);
  EXPECT_NEAR(term(*id, "C periodic 24 mm").phase_rad, -1.1, kRelative);
  EXPECT_LT(id->lead_residual_rms_um, 1e-6);
  EXPECT_EQ(id->lead_samples, 4 * 49);
  const AxisErrors at = id->at(10.0);
  EXPECT_NEAR(at.y_mm, m.y_mm(10.0), 1e-9);
  EXPECT_NEAR(at.c_deg, m.c_deg(10.0), 1e-9);
}

TEST(GearIdentification, TermsOfOneShapeOnTwoAxesAreRefusedNamingThem) {
  KnownMachine m;
  m.y_mm = [](double z) { return 1e-4 * z; };
  const GearPart part;
  Result<std::vector<ErrorTerm>> terms = parse_error_terms("y:linear,b:linear,z:bow");
  ASSERT_TRUE(terms.ok());
  Result<AxisIdentification> id =
      identify_axis_errors(gear_coupling(part), base_radius_mm(part.gear), *terms, lead_of(m), sim_in_force(), nullptr);
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kRefused);
  EXPECT_NE(id.error().message.find("Y linear and B linear act alike"), std::string::npos) << id.error().message;
  EXPECT_EQ(id.error().message.find("Z bow"), std::string::npos) << "Z bow is apart: " << id.error().message;
  EXPECT_NE(id.error().message.find("add a ballbar"), std::string::npos) << id.error().message;
}

// Y, Z and B all linear: one shape to the lead; the ballbar sees Y and Z apart, and then the
// lead gives B.
TEST(GearIdentification, ABallbarTellsYAndZApartAndTheLeadThenGivesB) {
  KnownMachine m;
  m.y_mm = [](double z) { return 3e-4 * z; };   // squareness, 0.3 um per mm
  m.z_mm = [](double z) { return 40e-6 * z; };  // 40 ppm
  m.b_deg = [](double z) { return -0.00015 * z; };
  m.c_deg = [](double z) { return 2e-6 * z * z; };
  const GearPart part;
  Result<std::vector<ErrorTerm>> terms = parse_error_terms("y:linear,z:linear,b:linear,c:bow");
  ASSERT_TRUE(terms.ok());
  const std::vector<LeadTrace> lead = lead_of(m);
  Result<AxisIdentification> alone =
      identify_axis_errors(gear_coupling(part), base_radius_mm(part.gear), *terms, lead, sim_in_force(), nullptr);
  ASSERT_FALSE(alone.ok());
  EXPECT_NE(alone.error().message.find("Y linear and Z linear and B linear act alike"), std::string::npos)
      << alone.error().message;
  const BallbarCircle b = ballbar_of(m);
  Result<AxisIdentification> id =
      identify_axis_errors(gear_coupling(part), base_radius_mm(part.gear), *terms, lead, sim_in_force(), &b);
  ASSERT_TRUE(id.ok()) << id.error().message;
  EXPECT_NEAR(term(*id, "Y linear").value, 3e-4, 3e-4 * kRelative);
  EXPECT_NEAR(term(*id, "Z linear").value, 40e-6, 40e-6 * kRelative);
  EXPECT_NEAR(term(*id, "B linear").value, -0.00015, 0.00015 * kRelative);
  EXPECT_NEAR(term(*id, "C bow").value, 2e-6, 2e-6 * kRelative);
  EXPECT_LT(id->ballbar_residual_rms_um, 1e-6);
  EXPECT_EQ(id->ballbar_samples, 180);
}

TEST(GearIdentification, NothingTellsBFromCAndABallbarDoesNotSeeThem) {
  KnownMachine m;
  const GearPart part;
  const BallbarCircle b = ballbar_of(m);
  Result<AxisIdentification> id =
      identify_axis_errors(gear_coupling(part), base_radius_mm(part.gear), *parse_error_terms("b:bow,c:bow,y:bow"),
                           lead_of(m), sim_in_force(), &b);
  ASSERT_FALSE(id.ok());
  EXPECT_NE(id.error().message.find("B bow and C bow act alike"), std::string::npos) << id.error().message;
  EXPECT_NE(id.error().message.find("nothing here tells B from C"), std::string::npos) << id.error().message;
  EXPECT_EQ(id.error().message.find("add a ballbar"), std::string::npos) << id.error().message;
}

TEST(GearIdentification, TermsAreReadWithTheirAxisKindAndPitch) {
  Result<std::vector<ErrorTerm>> t = parse_error_terms("Y:bow,z:periodic@13.6");
  ASSERT_TRUE(t.ok()) << t.error().message;
  ASSERT_EQ(t->size(), 2u);
  EXPECT_EQ((*t)[0].name(), "Y bow");
  EXPECT_EQ((*t)[1].name(), "Z periodic 13.600 mm");
  for (const char* bad : {"x:bow", "y:wobble", "z:periodic@0", "z:periodic@", "bow", ""}) {
    EXPECT_FALSE(parse_error_terms(bad).ok()) << bad;
  }
  const GearPart part;
  Result<AxisIdentification> twice =
      identify_axis_errors(gear_coupling(part), base_radius_mm(part.gear), *parse_error_terms("y:bow,y:bow"),
                           lead_of({}), sim_in_force(), nullptr);
  ASSERT_FALSE(twice.ok());
  EXPECT_NE(twice.error().message.find("Y bow is given twice"), std::string::npos);
}

}  // namespace
}  // namespace gaugeloop
