// Lead traces: the ISO 1328-1 figures on traces whose figures are known in closed form, the
// tolerance classes at their boundaries, and the mesh error identified from traces built from a
// known mesh error (with each trace's own offset, as a checker's alignment leaves it).
#include "compensation/gear_lead.h"
#include "tests/support/angles.h"

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

namespace gaugeloop {
namespace {

using testing::kPi;

GearGeometry example_gear() { return GearGeometry{}; }  // module 2.25, 71 teeth, 20 deg, 21.8 deg, 24 mm

// A trace across the example's face (-12 .. 12 mm every 0.5) of deviation f(z).
template <class F>
LeadTrace trace_of(F f, int gap = 1, Flank flank = Flank::kLeft) {
  LeadTrace t;
  t.gap = gap;
  t.flank = flank;
  for (int i = 0; i <= 48; ++i) {
    const double z = -12.0 + 0.5 * i;
    t.z_mm.push_back(z);
    t.deviation_um.push_back(f(z));
  }
  return t;
}

TEST(GearLead, TheBaseRadiusOfTheExampleGear) {
  // d2 = 71 x 2.25 / cos(21.8 deg) = 172.0543 mm; alpha_t = atan(tan 20 / cos 21.8) = 21.405382 deg.
  EXPECT_NEAR(base_radius_mm(example_gear()), 172.054323 / 2.0 * std::cos(21.405382 * kPi / 180.0), 1e-5);
}

// The evaluation range is the face less min(5 % of 24, 2.25) = 1.2 mm at each end: -10.8 .. 10.8.
TEST(GearLead, FiguresOfASlopeAndABowInTheEvaluationRange) {
  // Points outside the range carry 100 um: they must not count.
  auto outside = [](double z, double v) { return std::abs(z) > 10.8 + 1e-9 ? 100.0 : v; };
  Result<LeadFigures> slope = lead_figures(trace_of([&](double z) { return outside(z, 0.1 * z); }), example_gear());
  ASSERT_TRUE(slope.ok()) << slope.error().message;
  EXPECT_NEAR(slope->from_mm, -10.8, 1e-12);
  EXPECT_NEAR(slope->to_mm, 10.8, 1e-12);
  EXPECT_EQ(slope->points, 43);  // -10.5 .. 10.5 every 0.5 (10.8 falls between points)
  EXPECT_NEAR(slope->total_um, 0.1 * 21.0, 1e-9);
  EXPECT_NEAR(slope->form_um, 0.0, 1e-9);
  EXPECT_NEAR(slope->slope_um, 0.1 * 21.6, 1e-9) << "the mean helix's rise over the whole range";

  Result<LeadFigures> bow = lead_figures(trace_of([&](double z) { return outside(z, 0.02 * z * z); }), example_gear());
  ASSERT_TRUE(bow.ok()) << bow.error().message;
  EXPECT_NEAR(bow->total_um, 0.02 * 10.5 * 10.5, 1e-9);
  EXPECT_NEAR(bow->form_um, 0.02 * 10.5 * 10.5, 1e-9) << "symmetric: the mean helix is flat";
  EXPECT_NEAR(bow->slope_um, 0.0, 1e-9);
}

TEST(GearLead, ATraceTooShortOrGoingBackIsRefused) {
  LeadTrace t = trace_of([](double) { return 0.0; });
  t.z_mm = {-1.0, 0.0};
  t.deviation_um = {0.0, 0.0};
  Result<LeadFigures> few = lead_figures(t, example_gear());
  ASSERT_FALSE(few.ok());
  EXPECT_NE(few.error().message.find("2 points in the evaluation range"), std::string::npos) << few.error().message;
  LeadTrace back = trace_of([](double) { return 0.0; }, 20, Flank::kRight);
  back.z_mm[5] = back.z_mm[4];
  Result<LeadFigures> b = lead_figures(back, example_gear());
  ASSERT_FALSE(b.ok());
  EXPECT_NE(b.error().message.find("gap 20, right flank: Z -10.000 mm does not increase (point 6)"), std::string::npos)
      << b.error().message;
}

// F_betaT(class 5) = 0.1 sqrt(172.054) + 0.63 sqrt(24) + 4.2 = 8.598 um; sqrt(2) per class.
TEST(GearLead, TheToleranceClassOfATotalHelixDeviation) {
  const double d = 172.054323;
  const double b = 24.0;
  const double class5 = 0.1 * std::sqrt(d) + 0.63 * std::sqrt(b) + 4.2;
  EXPECT_NEAR(helix_tolerance_um(5, d, b), class5, 1e-12);
  EXPECT_NEAR(helix_tolerance_um(7, d, b), 2.0 * class5, 1e-12);
  EXPECT_EQ(helix_tolerance_class(class5 - 1e-6, d, b), 5);
  EXPECT_EQ(helix_tolerance_class(class5 + 1e-6, d, b), 6);
  EXPECT_EQ(helix_tolerance_class(0.1, d, b), 1);
  EXPECT_EQ(helix_tolerance_class(1000.0, d, b), 12);
}

TEST(GearLead, TheToleranceClassOfATotalProfileDeviation) {
  // The example gear: normal module 2.25 mm, d = 172.05 mm; ISO 1328-1's F_alphaT of class 5
  // written out apart, doubling every two classes.
  const double m = 2.25;
  const double d = 172.054323;
  const double class5 = 3.2 * std::sqrt(m) + 0.22 * std::sqrt(d) + 0.7;
  EXPECT_NEAR(class5, 8.386, 1e-3);
  EXPECT_NEAR(profile_tolerance_um(5, m, d), class5, 1e-12);
  EXPECT_NEAR(profile_tolerance_um(3, m, d), class5 / 2.0, 1e-12);
  EXPECT_EQ(profile_tolerance_class(class5 - 1e-6, m, d), 5);
  EXPECT_EQ(profile_tolerance_class(class5 + 1e-6, m, d), 6);
  EXPECT_EQ(profile_tolerance_class(0.1, m, d), 1);
  EXPECT_EQ(profile_tolerance_class(1000.0, m, d), 12);
}

// Traces of two gaps, both flanks, from a mesh error linear between the spline points (-15 ..
// 15 every mm) with an offset each: the identification gives the mesh error back, less its mean
// over the points the face reaches, and holds the points beyond the face.
TEST(GearLead, TheMeshErrorComesBackFromTracesWithTheirOwnOffsets) {
  std::vector<double> spline;
  std::vector<double> mesh;
  for (int k = 0; k <= 30; ++k) {
    spline.push_back(-15.0 + k);
    mesh.push_back(0.002 * std::sin(0.7 * k) + 0.0005 * k - 0.004);
  }
  auto mesh_at = [&](double z) {
    const int k = std::min(29, static_cast<int>(std::floor(z + 15.0)));
    const double t = z + 15.0 - k;
    return mesh[k] + t * (mesh[k + 1] - mesh[k]);
  };
  const double r_b = base_radius_mm(example_gear());
  const double um_per_deg = r_b * 1000.0 * kPi / 180.0;
  std::vector<LeadTrace> traces;
  double offset = 3.0;
  for (int gap : {1, 20}) {
    for (Flank f : {Flank::kLeft, Flank::kRight}) {
      offset = -offset * 1.5;
      traces.push_back(trace_of([&](double z) { return flank_sign(f) * um_per_deg * mesh_at(z) + offset; }, gap, f));
    }
  }
  Result<MeshIdentification> m = identify_mesh_error(traces, spline, r_b);
  ASSERT_TRUE(m.ok()) << m.error().message;
  // The face (-12 .. 12) reaches the spline points -12 .. 12.
  double mean = 0.0;
  for (int k = 3; k <= 27; ++k) mean += mesh[k];
  mean /= 25.0;
  for (int k = 0; k <= 30; ++k) {
    EXPECT_EQ(m->observed[k], k >= 3 && k <= 27) << "Z " << spline[k];
    const int held = std::clamp(k, 3, 27);
    EXPECT_NEAR(m->mesh_deg[k], mesh[held] - mean, 1e-10) << "Z " << spline[k];
  }
  EXPECT_EQ(m->traces, 4);
  EXPECT_EQ(m->samples, 4 * 49);
  EXPECT_EQ(m->unknowns, 25 + 4);
  EXPECT_EQ(m->rank, m->unknowns - 1) << "only the mean trades off against the offsets";
  EXPECT_LT(m->residual_rms_um, 1e-9);
}

// What the spline points cannot follow stays in the residual: a 0.4 mm ripple of 0.5 um.
TEST(GearLead, ARippleFasterThanTheSplinePointsIsTheResidual) {
  std::vector<double> spline;
  for (int k = 0; k <= 30; ++k) spline.push_back(-15.0 + k);
  const double r_b = base_radius_mm(example_gear());
  std::vector<LeadTrace> traces;
  for (Flank f : {Flank::kLeft, Flank::kRight}) {
    traces.push_back(trace_of(
        [&](double z) { return 0.5 * std::sin(2.0 * kPi * z / 0.4 + 0.3) + 0.3 * (f == Flank::kLeft); }, 1, f));
  }
  Result<MeshIdentification> m = identify_mesh_error(traces, spline, r_b);
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_GT(m->residual_rms_um, 0.2);
  EXPECT_LT(m->residual_rms_um, 0.5 / std::sqrt(2.0) + 1e-9);
}

TEST(GearLead, NothingToIdentifyFromIsRefused) {
  const std::vector<double> spline{-15.0, 0.0, 15.0};
  EXPECT_FALSE(identify_mesh_error({}, spline, 80.0).ok());
  LeadTrace off = trace_of([](double) { return 0.0; });
  for (double& z : off.z_mm) z += 100.0;
  Result<MeshIdentification> m = identify_mesh_error({off}, spline, 80.0);
  ASSERT_FALSE(m.ok());
  EXPECT_NE(m.error().message.find("gap 1, left flank: no point on the stroke"), std::string::npos)
      << m.error().message;
  EXPECT_FALSE(identify_mesh_error({trace_of([](double) { return 0.0; })}, {0.0}, 80.0).ok());
}

}  // namespace
}  // namespace gaugeloop
