// Tests of the support function against a brute-force maximum, on curves with concave parts.
#include "compensation/polar_support.h"

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_lobes.h"

namespace gaugeloop {
namespace {

using testing::kRadPerDeg;

// h(theta) by brute force: every 0.01 deg of the curve, then golden section around every
// local maximum within 1e-4 mm of the best sample (sampling under-reads a maximum by at most
// r dphi^2 / 2 = 5e-7 mm, so near-ties across a bridge are all refined). Slow, obviously right.
// `contact_deg`, when given, receives where the maximum is.
double brute_force_support(const std::function<double(double)>& r, double theta_deg, double* contact_deg = nullptr) {
  constexpr int kSamples = 36000;
  constexpr double kStep = 360.0 / kSamples;
  const auto g = [&](double phi) { return r(phi) * std::cos((phi - theta_deg) * kRadPerDeg); };
  std::vector<double> f(kSamples);
  double best = -1e300;
  for (size_t i = 0; i < f.size(); ++i) {
    f[i] = g(static_cast<double>(i) * kStep);
    best = std::max(best, f[i]);
  }
  double refined = best;
  double contact = 0.0;
  for (size_t i = 0; i < f.size(); ++i) {
    if (f[i] < best - 1e-4 || f[i] < f[(i + f.size() - 1) % f.size()] || f[i] < f[(i + 1) % f.size()]) continue;
    double lo = (static_cast<double>(i) - 1.0) * kStep;
    double hi = (static_cast<double>(i) + 1.0) * kStep;
    for (int iter = 0; iter < 80; ++iter) {
      const double a = lo + (hi - lo) * 0.382;
      const double b = lo + (hi - lo) * 0.618;
      if (g(a) < g(b)) {
        lo = a;
      } else {
        hi = b;
      }
    }
    const double phi = 0.5 * (lo + hi);
    if (g(phi) >= refined) {
      refined = g(phi);
      contact = phi;
    }
  }
  if (contact_deg != nullptr) *contact_deg = contact;
  return refined;
}

// Every 2.9 deg round the turn, plus `extra_theta_deg` (the awkward places: corners of h,
// checked for the value only, since h has no slope there).
void expect_matches_brute_force(const PeriodicSpline& radius, double offset_mm,
                                const std::vector<double>& extra_theta_deg, const std::string& what) {
  const PolarSupport support(radius, offset_mm);
  const auto r = [&](double phi) { return offset_mm + radius.value(phi); };
  std::vector<double> thetas;
  for (double theta = 0.0; theta < 360.0; theta += 2.9) thetas.push_back(theta);
  const size_t regular = thetas.size();
  thetas.insert(thetas.end(), extra_theta_deg.begin(), extra_theta_deg.end());
  double worst = 0.0;
  double worst_slope = 0.0;
  for (size_t i = 0; i < thetas.size(); ++i) {
    const double theta = thetas[i];
    const PolarSupport::Point p = support.at(theta);
    worst = std::max(worst, std::abs(p.support_mm - brute_force_support(r, theta)));
    if (i >= regular) continue;
    // dh/dtheta per radian is the contact's tangential offset (envelope theorem); central
    // difference over 1e-4 deg.
    const double h = 1e-4;
    const double diff = (support.at(theta + h).support_mm - support.at(theta - h).support_mm) / (2 * h * kRadPerDeg);
    worst_slope = std::max(worst_slope, std::abs(p.tangential_mm - diff));
    // The contact lies on the curve, at the support value.
    EXPECT_NEAR(r(p.phi_deg) * std::cos((p.phi_deg - theta) * kRadPerDeg), p.support_mm, 1e-12) << what << theta;
  }
  // Both maximise the same function; the refinements agree far below 1e-12 mm. Tolerance
  // 1e-9 mm, the accuracy promised.
  EXPECT_LT(worst, 1e-9) << what;
  // The difference quotient: rounding 1e-16 * 30 mm / 1.7e-6 rad = 2e-9 mm, truncation far
  // less, unless it straddles a corner (no regular angle is within 1e-4 deg of one).
  // Tolerance 1e-6 mm.
  EXPECT_LT(worst_slope, 1e-6) << what;
}

TEST(PolarSupport, MatchesABruteForceMaximumOnTheExhaustRollerPitchCurve) {
  // The exhaust lobe's pitch curve (rb + rr + H) has concave flanks a probe bridges; the
  // reading's corners, where the probe leaves the flank for the base circle, lie near 63 and
  // 297 deg. Probe either side of them.
  const PeriodicSpline lift = testing::spline_of(testing::example_table("exhaust_roller.csv"));
  expect_matches_brute_force(lift, 17.0 + 11.0, {62.9, 63.1, 63.3, 296.7, 296.9, 297.1},
                             "exhaust pitch curve at theta ");
}

TEST(PolarSupport, MatchesABruteForceMaximumOnADeeplyConcaveCurve) {
  // r = 10 + 3 cos(3 phi): three lobes with deep concave valleys, bridged by long hull edges
  // whose normals (60, 180, 300 deg) are where two lobe tips tie. Probe just either side.
  const PeriodicSpline three_lobes =
      testing::spline_sampled([](double d) { return 3.0 * std::cos(3 * d * kRadPerDeg); }, 0.5);
  expect_matches_brute_force(three_lobes, 10.0, {59.99, 60.0, 60.01, 179.999, 180.001, 300.0}, "three lobes at theta ");
}

TEST(PolarSupport, TakesTheRightEndOfABridgeAtANearTie) {
  // An asymmetric three-lobe curve: near the normal of the bridge between two lobe tips the
  // probe rests on one tip or the other, and close enough to that normal (here 1e-6 deg and
  // less) the two differ by less than the hull samples under-read a tip (up to r dphi^2 / 2 =
  // 1e-4 mm at 0.25 deg). Only refining both ends gets the right one.
  const auto radius = [](double d) {
    return 3.0 * std::cos(3 * d * kRadPerDeg) + 0.5 * std::cos((2 * d + 17) * kRadPerDeg);
  };
  const PeriodicSpline lobes = testing::spline_sampled(radius, 0.5);
  const auto r = [&](double phi) { return 10.0 + lobes.value(phi); };
  // The bridge normal between the tips near 0 and near 120 deg, by bisection on which tip the
  // brute force rests on.
  const auto on_first_tip = [&](double theta) {
    double contact = 0.0;
    brute_force_support(r, theta, &contact);
    return std::remainder(contact, 360.0) < 60.0;
  };
  double lo = 40.0;
  double hi = 80.0;
  ASSERT_TRUE(on_first_tip(lo));
  ASSERT_FALSE(on_first_tip(hi));
  for (int i = 0; i < 40; ++i) (on_first_tip(0.5 * (lo + hi)) ? lo : hi) = 0.5 * (lo + hi);
  const double tie = 0.5 * (lo + hi);
  const PolarSupport support(lobes, 10.0);
  for (double offset : {-1e-6, -1e-7, -1e-8, 1e-8, 1e-7, 1e-6}) {
    EXPECT_NEAR(support.at(tie + offset).support_mm, brute_force_support(r, tie + offset), 1e-9) << offset;
  }
}

TEST(PolarSupport, OfACircleAboutTheAxisIsItsRadius) {
  const PeriodicSpline zero = testing::spline_sampled([](double) { return 0.0; }, 10.0);
  const PolarSupport support(zero, 25.0);
  for (double theta = -720.0; theta < 720.0; theta += 17.3) {
    const PolarSupport::Point p = support.at(theta);
    EXPECT_NEAR(p.support_mm, 25.0, 1e-12) << theta;
    EXPECT_NEAR(p.tangential_mm, 0.0, 1e-9) << theta;
  }
}

}  // namespace
}  // namespace gaugeloop
