// Tests of flat-probe readings: on design lobes of every follower kind, and round trips
// through a wheel path.
#include "compensation/flat_probe.h"

#include <cmath>
#include <filesystem>
#include <set>
#include <string>

#include <gtest/gtest.h>

#include "compensation/wheel_path.h"
#include "test_lobes.h"

namespace gaugeloop {
namespace {

using testing::Disc;
using testing::make_part;

double largest_difference(const DegreeTable& a, const DegreeTable& b) {
  double worst = 0.0;
  for (size_t d = 0; d < a.size(); ++d) worst = std::max(worst, std::abs(a[d] - b[d]));
  return worst;
}

TEST(FlatProbeReading, IsTheLiftForAFlatFollower) {
  const LiftTable table = testing::example_table("intake_flat.csv");
  const PeriodicSpline lift = testing::spline_of(table);
  Result<DegreeTable> reading = flat_probe_reading(lift, testing::intake_flat_part());
  ASSERT_TRUE(reading.ok()) << reading.error().message;
  // The table has a knot at every whole degree: the reading is the table value (1e-12).
  for (size_t d = 0; d < 360; ++d) EXPECT_NEAR((*reading)[d], table.lift_mm[d], 1e-12) << d;
}

TEST(FlatProbeReading, OfAnEccentricDiscIsTheDiscWhateverTheFollower) {
  // A disc read by a flat probe is e (1 + cos theta) whichever follower its lift table was
  // written for. The knife-edge and roller lifts differ from that (e.g. at 90 deg the knife
  // edge lift is sqrt(rc^2 - e^2) - rb = 4.36 mm, the flat one 5 mm), so this checks the
  // support-function computation, not a copy of the lift. Tolerance 1e-8 mm: the maximum is
  // refined to < 1e-9 mm and the 0.1 deg spline reproduces the lift to ~1e-12 mm.
  const Disc disc{20.0, 5.0};
  for (double rr : {0.0, 8.0}) {
    const PeriodicSpline lift = testing::spline_sampled([&](double d) { return disc.roller_lift_mm(d, rr); }, 0.1);
    const FollowerKind kind = rr == 0.0 ? FollowerKind::kKnifeEdge : FollowerKind::kRoller;
    Result<DegreeTable> reading = flat_probe_reading(lift, make_part(kind, disc.base_circle_mm(), rr, 200));
    ASSERT_TRUE(reading.ok()) << reading.error().message;
    for (int d = 0; d < 360; ++d) {
      EXPECT_NEAR((*reading)[static_cast<size_t>(d)], disc.flat_lift_mm(d), 1e-8) << "rr " << rr << " deg " << d;
    }
    EXPECT_GT(std::abs(lift.value(90.0) - disc.flat_lift_mm(90.0)),
              0.1);  // the lift is not the reading
  }
}

TEST(FlatProbeReading, IsZeroOnTheBaseCircleOfTheExhaustRoller) {
  const PeriodicSpline lift = testing::spline_of(testing::example_table("exhaust_roller.csv"));
  Result<DegreeTable> reading = flat_probe_reading(lift, testing::exhaust_roller_part(45.0));
  ASSERT_TRUE(reading.ok()) << reading.error().message;
  // 1e-9 mm: where the lift is 0 the support is the base circle's, up to the refinement.
  for (size_t d = 120; d <= 240; ++d) EXPECT_NEAR((*reading)[d], 0.0, 1e-9) << d;
  EXPECT_NEAR((*reading)[0], 9.5, 1e-9);  // at the nose the roller lift is the reading
}

TEST(FlatProbeReading, RefusesANonConvexFlatLobe) {
  const PeriodicSpline lift =
      testing::spline_sampled([](double d) { return 3.0 * (1.0 + std::cos(3 * d * testing::kRadPerDeg)); }, 0.5);
  Result<DegreeTable> reading = flat_probe_reading(lift, make_part(FollowerKind::kFlat, 10.0, 0, 200));
  ASSERT_FALSE(reading.ok());
  EXPECT_EQ(reading.error().code, ErrorCode::kRefused);
}

// Round trip (the cam-grinding kinematics): grind with the path, read the ground lobe with a flat probe,
// get back the design's reading.
void expect_round_trip(const PeriodicSpline& lift, const Part& part, double step_deg, double tolerance_mm) {
  Result<WheelPath> path = compute_wheel_path(lift, part, step_deg);
  ASSERT_TRUE(path.ok()) << path.error().message;
  Result<DegreeTable> ground = ground_lobe_reading(*path, part);
  ASSERT_TRUE(ground.ok()) << ground.error().message;
  Result<DegreeTable> design = flat_probe_reading(lift, part);
  ASSERT_TRUE(design.ok()) << design.error().message;
  EXPECT_LT(largest_difference(*ground, *design), tolerance_mm);
}

TEST(GroundLobeReading, RoundTripReturnsTheDesignReadingOfEverySampleLobe) {
  // The issue asks for 1e-4 mm on every sample lobe. The path is resampled at 0.1 deg and
  // interpolated again by a spline; the lift spline is only C2 (H''' jumps at its knots), so
  // that costs O(h^3 |jump|). Measured: intake_flat 4.2e-10 mm, intake_flat_half_degree
  // 1.2e-9 mm (twice the knots, twice the jumps), exhaust_roller 1.7e-10 mm (its concave
  // flanks neither the probe nor the envelope shows). Tolerance 1e-8 mm, 10^4 tighter than
  // asked.
  for (const testing::ExampleLobe& lobe : testing::example_lobes()) {
    SCOPED_TRACE(lobe.name);
    expect_round_trip(testing::spline_of(testing::example_table(std::string(lobe.name) + ".csv")), lobe.part, 0.1,
                      1e-8);
  }
}

TEST(ExampleLobes, EveryExampleIsListed) {
  // A new sample lobe in examples/ (a part file beside its lift table, <name>.toml and
  // <name>.csv; a shaft file has no table) must join testing::example_lobes(), so the round
  // trip and the derivative checks cover it.
  std::set<std::string> listed;
  for (const testing::ExampleLobe& lobe : testing::example_lobes()) listed.insert(lobe.name);
  int found = 0;
  for (const auto& entry : std::filesystem::directory_iterator(std::string(GAUGELOOP_SOURCE_DIR) + "/examples")) {
    if (entry.path().extension() != ".toml") continue;
    std::filesystem::path table = entry.path();
    if (!std::filesystem::exists(table.replace_extension(".csv"))) continue;
    ++found;
    EXPECT_TRUE(listed.count(entry.path().stem().string()) == 1)
        << entry.path() << " is not in testing::example_lobes() (tests/compensation/test_lobes.h)";
  }
  EXPECT_EQ(found, static_cast<int>(listed.size()));
}

TEST(GroundLobeReading, RejectsAMalformedPath) {
  WheelPath path;
  path.psi_deg = {0, 90, 180, 270};
  path.x_mm = {0, 0, 0};
  Result<DegreeTable> r = ground_lobe_reading(path, testing::intake_flat_part());
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kInvalidInput);
}

}  // namespace
}  // namespace gaugeloop
