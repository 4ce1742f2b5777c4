// A ballbar test's figures and the slides' fit: what it refuses and why.
#include "compensation/ballbar.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "core/angles.h"

namespace gaugeloop {
namespace {

using ::testing::HasSubstr;

// A circle both ways, every degree, radial = f(angle rad, direction).
template <typename F>
BallbarTest circle_of(F&& f) {
  BallbarTest t;
  for (int k = 0; k < 360; ++k) {
    const double a = k * kPi / 180.0;
    t.ccw.angle_deg.push_back(k);
    t.ccw.radial_um.push_back(f(a, 1.0));
    t.cw.angle_deg.push_back(k);
    t.cw.radial_um.push_back(f(a, -1.0));
  }
  return t;
}

TEST(Ballbar, RoundnessIsTheBandAboutTheLeastSquaresCentrePositionErrorAboutTheSetUp) {
  // An ellipse of +-5 um at 45 deg and a set-up 10 um off in Y: roundness 10 um exactly
  // (sampled at whole degrees, 45 and 135 among them); the band as measured is wider.
  const BallbarTest t = circle_of([](double a, double) { return 5.0 * std::sin(2.0 * a) + 10.0 * std::cos(a); });
  Result<BallbarFigures> f = ballbar_figures(t);
  ASSERT_TRUE(f.ok());
  EXPECT_NEAR(f->roundness_um, 10.0, 1e-9);
  EXPECT_NEAR(f->centre_y_um, 10.0, 1e-9);
  EXPECT_NEAR(f->centre_z_um, 0.0, 1e-9);
  EXPECT_GT(f->position_error_um, 20.0);
  EXPECT_EQ(f->samples, 720);
}

TEST(Ballbar, AFitRecoversTermsBuiltFromTheirOwnGeometry) {
  // Squareness 200 um/m and a servo mismatch of 0.1 ms at 1000 mm/min: the first stays with the
  // direction, the second turns over with it.
  const double v = 1000.0 / 60.0;  // mm/s
  const BallbarTest t = circle_of([&](double a, double d) {
    const double z = 100.0 * std::sin(a);
    // Y lags its command by 0.05 ms of its velocity (-d v sin a), Z by 0.15 ms (d v cos a).
    const double ey = 200e-6 * z + d * v * std::sin(a) * 0.05e-3;
    const double ez = -d * v * std::cos(a) * 0.15e-3;
    return 1000.0 * (ey * std::cos(a) + ez * std::sin(a));
  });
  Result<SlideIdentification> id = identify_slides(t, {});
  ASSERT_TRUE(id.ok()) << id.error().message;
  EXPECT_NEAR(id->squareness * 1e6, 200.0, 1e-6);
  EXPECT_NEAR(id->servo_mismatch_ms, 0.1, 1e-9);
  EXPECT_NEAR(id->scale_mismatch, 0.0, 1e-12);
  EXPECT_LT(id->residual_rms_um, 1e-9);
}

TEST(Ballbar, OneDirectionCannotTellSquarenessFromServoMismatch) {
  BallbarTest t = circle_of([](double a, double) { return 3.0 * std::sin(2.0 * a); });
  t.cw = {};
  Result<SlideIdentification> id = identify_slides(t, {});
  ASSERT_FALSE(id.ok());
  EXPECT_EQ(id.error().code, ErrorCode::kRefused);
  EXPECT_THAT(id.error().message, HasSubstr("the squareness and the servo mismatch act alike"));
  EXPECT_THAT(id.error().message, HasSubstr("both ways"));
  EXPECT_THAT(id.error().message, HasSubstr("Nothing was written"));
}

TEST(Ballbar, BadTestsAndTablesAreRefusedNamingWhat) {
  BallbarTest t = circle_of([](double, double) { return 0.0; });
  t.ccw.radial_um.pop_back();
  Result<BallbarFigures> f = ballbar_figures(t);
  ASSERT_FALSE(f.ok());
  EXPECT_THAT(f.error().message, HasSubstr("counter-clockwise circle has 360 angles and 359"));
  t = circle_of([](double, double) { return 0.0; });
  t.cw.radial_um[7] = std::nan("");
  EXPECT_THAT(ballbar_figures(t).error().message, HasSubstr("clockwise circle's point 8 is not a finite number"));
  t = circle_of([](double, double) { return 0.0; });
  EXPECT_THAT(identify_slides(t, {-1.0, 0.0}).error().message, HasSubstr("lead must be positive"));
  Result<SlideIdentification> id = identify_slides(t, {});
  ASSERT_TRUE(id.ok());
  EXPECT_EQ(slide_tables(*id, 100.0, 0.0).error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(slide_tables(*id, 100.0, 0.001).error().code, ErrorCode::kInvalidInput);  // 200,001 points
  Result<std::vector<SlideCompensationTable>> tables = slide_tables(*id, 100.0, 2.0);
  ASSERT_TRUE(tables.ok());
  ASSERT_EQ(tables->size(), 4u);
  EXPECT_EQ(tables->front().error_mm.size(), 101u);
  EXPECT_DOUBLE_EQ(tables->front().min_mm, -100.0);
}

}  // namespace
}  // namespace gaugeloop
