// The roughness model against the variable-speed camshaft paper's two figures.
#include "simulator/surface_roughness.h"

#include <gtest/gtest.h>

#include <cmath>

namespace gaugeloop {
namespace {

TEST(SurfaceRoughness, TheCalibrationReproducesThePapersFlankSlowDown) {
  const GrindingConditions c;
  const RoughnessModel m = paper_roughness_model(c);
  EXPECT_NEAR(roughness_ra_um(m, equivalent_chip_thickness_um(8000.0, c)), 3.2, 1e-12);
  EXPECT_NEAR(roughness_ra_um(m, equivalent_chip_thickness_um(2000.0, c)), 0.775, 1e-12);
  EXPECT_NEAR(m.exponent, std::log(3.2 / 0.775) / std::log(4.0), 1e-12);
  // Another wheel speed halves h_eq at the same grinding-point speed, and the calibration follows it.
  GrindingConditions faster_wheel = c;
  faster_wheel.wheel_speed_m_per_s *= 2.0;
  const RoughnessModel m2 = paper_roughness_model(faster_wheel);
  EXPECT_NEAR(roughness_ra_um(m2, equivalent_chip_thickness_um(2000.0, faster_wheel)), 0.775, 1e-12);
}

TEST(SurfaceRoughness, HEqIsDepthTimesWorkSpeedOverWheelSpeed) {
  // 20 um * (6000 mm/min = 100 mm/s) / (25 m/s = 25000 mm/s) = 0.08 um.
  EXPECT_NEAR(equivalent_chip_thickness_um(6000.0, GrindingConditions{20.0, 25.0}), 0.08, 1e-15);
}

TEST(SurfaceRoughness, TheFlankFigureIsTheLargestBetweenBaseCircleAndNose) {
  MachinePath path;
  std::vector<double> speed;
  for (int k = 0; k < 10; ++k) {
    path.c_deg.push_back(k * 36.0);
    path.x_mm.push_back(k == 0 ? 10.0 : k < 4 ? 5.0 : 0.0);  // nose, flank, base circle
    speed.push_back(k == 0 ? 20000.0 : k == 2 ? 8000.0 : k < 4 ? 4000.0 : 16000.0);
  }
  const SurfaceFinish f = surface_finish(path, speed, paper_roughness_model());
  ASSERT_EQ(f.ra_um.size(), 10u);
  EXPECT_NEAR(f.flank_ra_um, 3.2, 1e-12);
  EXPECT_DOUBLE_EQ(f.flank_at_c_deg, 72.0);
  EXPECT_GT(f.ra_um[0], f.flank_ra_um);  // the nose is not a flank
}

}  // namespace
}  // namespace gaugeloop
