// Lobes with known answers and the example parts, shared by the compensation tests.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "compensation/periodic_spline.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "core/run.h"
#include "tests/support/angles.h"

namespace gaugeloop::testing {

// Knots at 0, step, 2 step, ... < 360 with values f(angle in degrees).
inline PeriodicSpline spline_sampled(const std::function<double(double)>& f_of_deg, double step_deg) {
  const int n = static_cast<int>(std::lround(360.0 / step_deg));
  std::vector<double> angle(static_cast<size_t>(n));
  std::vector<double> value(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    angle[static_cast<size_t>(i)] = 360.0 * i / n;
    value[static_cast<size_t>(i)] = f_of_deg(angle[static_cast<size_t>(i)]);
  }
  Result<PeriodicSpline> s = PeriodicSpline::fit(angle, value);
  EXPECT_TRUE(s.ok());
  return std::move(s).value();
}

// Eccentric disc of radius rc whose centre is e from the axis towards the nose (cam angle 0).
struct Disc {
  double rc_mm = 20.0;
  double e_mm = 5.0;
  double base_circle_mm() const { return rc_mm - e_mm; }
  // What a flat follower (and any flat probe) reads: the support function minus rb.
  double flat_lift_mm(double deg) const { return e_mm * (1.0 + std::cos(deg * kRadPerDeg)); }
  // Lift of a roller of radius rr (0: knife edge): the polar radius of the pitch circle
  // (radius rc + rr, same centre) minus rb + rr.
  double roller_lift_mm(double deg, double rr_mm) const {
    const double s = e_mm * std::sin(deg * kRadPerDeg);
    const double r = rc_mm + rr_mm;
    return e_mm * std::cos(deg * kRadPerDeg) + std::sqrt(r * r - s * s) - (base_circle_mm() + rr_mm);
  }
  // the cam-grinding kinematics: the exact infeed for wheel radius rw at wheel angle psi.
  double exact_infeed_mm(double psi_deg, double rw_mm) const {
    const double s = e_mm * std::sin(psi_deg * kRadPerDeg);
    return e_mm * std::cos(psi_deg * kRadPerDeg) + std::sqrt((rc_mm + rw_mm) * (rc_mm + rw_mm) - s * s) - rw_mm -
           base_circle_mm();
  }
  // Its derivatives along psi, differentiated by hand, per DEGREE of psi. With
  // S = sqrt(R^2 - e^2 sin^2 psi), R = rc + rw: X' = -e sin psi - e^2 sin psi cos psi / S and
  // X'' = -e cos psi - e^2 cos 2psi / S - e^4 sin^2 psi cos^2 psi / S^3 (per rad, per rad^2).
  double exact_infeed_d1_mm_per_deg(double psi_deg, double rw_mm) const {
    const double sn = std::sin(psi_deg * kRadPerDeg);
    const double cs = std::cos(psi_deg * kRadPerDeg);
    const double r = rc_mm + rw_mm;
    const double big_s = std::sqrt(r * r - e_mm * e_mm * sn * sn);
    return (-e_mm * sn - e_mm * e_mm * sn * cs / big_s) * kRadPerDeg;
  }
  double exact_infeed_d2_mm_per_deg2(double psi_deg, double rw_mm) const {
    const double sn = std::sin(psi_deg * kRadPerDeg);
    const double cs = std::cos(psi_deg * kRadPerDeg);
    const double r = rc_mm + rw_mm;
    const double big_s = std::sqrt(r * r - e_mm * e_mm * sn * sn);
    const double e2 = e_mm * e_mm;
    return (-e_mm * cs - e2 * (cs * cs - sn * sn) / big_s - e2 * e2 * sn * sn * cs * cs / (big_s * big_s * big_s)) *
           kRadPerDeg * kRadPerDeg;
  }
};

inline Part make_part(FollowerKind kind, double rb_mm, double rr_mm, double rw_mm) {
  Part p;
  p.name = "test";
  p.follower = kind;
  p.base_circle_radius_mm = rb_mm;
  p.follower_radius_mm = rr_mm;
  p.wheel_radius_mm = rw_mm;
  return p;
}

inline LiftTable example_table(const std::string& file) {
  Result<LiftTable> t = read_lift_table_csv(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/" + file);
  EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
  return std::move(t).value();
}

inline PeriodicSpline spline_of(const LiftTable& t) {
  Result<PeriodicSpline> s = PeriodicSpline::fit(t.angle_deg, t.lift_mm);
  EXPECT_TRUE(s.ok());
  return std::move(s).value();
}

// The example parts (examples/*.csv): intake with a flat follower, exhaust with a roller.
inline Part intake_flat_part() { return make_part(FollowerKind::kFlat, 18.0, 0.0, 200.0); }
inline Part exhaust_roller_part(double rw_mm) { return make_part(FollowerKind::kRoller, 17.0, 11.0, rw_mm); }

// The design table turned by `phi_deg` in the cam frame: lift(theta) = design(theta - phi).
// A periodic spline through the turned knots is the design spline turned, exactly.
inline LiftTable rotated_table(const LiftTable& design, double phi_deg) {
  std::vector<std::pair<double, double>> knots;
  for (size_t i = 0; i < design.angle_deg.size(); ++i) {
    double a = std::fmod(design.angle_deg[i] + phi_deg, 360.0);
    if (a < 0.0) a += 360.0;
    knots.emplace_back(a, design.lift_mm[i]);
  }
  std::sort(knots.begin(), knots.end());
  LiftTable out;
  out.source = design.source + " turned";
  for (const auto& [a, h] : knots) {
    out.angle_deg.push_back(a);
    out.lift_mm.push_back(h);
  }
  return out;
}

// Every sample lobe in examples/ with the part its .toml describes (the tests do not read
// TOML: compensation/ does not depend on app/). ExampleLobes.EveryExampleIsListed keeps this
// list complete.
struct ExampleLobe {
  const char* name;  // examples/<name>.csv and <name>.toml
  Part part;
};

inline std::vector<ExampleLobe> example_lobes() {
  return {{"intake_flat", intake_flat_part()},
          {"intake_flat_half_degree", intake_flat_part()},
          {"exhaust_roller", exhaust_roller_part(45.0)}};
}

// A measured run of a lobe whose flat-probe reading at whole cam degrees is `reading_mm`:
// 3 revolutions at machine degrees C, each sample reading[beta] + a gauge offset + Gaussian
// noise of `noise_um` RMS, beta = cam_angle_at_probe_deg(part, C) (whole degrees: the part's
// c_offset_deg and probe_offset_deg must be whole).
inline MeasuredRun measured_run(const Part& part, const DegreeTable& reading_mm, double noise_um, unsigned seed) {
  constexpr double kGaugeOffsetMm = 0.4127;  // an arbitrary un-zeroed gauge reading
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_um / 1000.0);
  MeasuredRun run;
  for (int r = 0; r < 3; ++r) {
    RevolutionSamples rev;
    rev.revolution = 10 + r;
    for (int c = 0; c < 360; ++c) {
      const long beta = std::lround(cam_angle_at_probe_deg(part, c)) % 360;
      rev.lift_mm[static_cast<size_t>(c)] = reading_mm[static_cast<size_t>(beta)] + kGaugeOffsetMm + noise(rng);
    }
    run.revolutions.push_back(rev);
  }
  return run;
}

// A smooth periodic error: harmonics 2..5 with fixed phases, scaled to `peak_um` largest |value|.
inline DegreeTable harmonic_error_um(double peak_um) {
  DegreeTable e{};
  double largest = 0.0;
  for (int d = 0; d < 360; ++d) {
    const double t = d * kRadPerDeg;
    const double v =
        std::cos(2 * t + 0.3) + 0.7 * std::sin(3 * t + 1.1) + 0.5 * std::cos(4 * t - 0.4) + 0.4 * std::sin(5 * t + 2.0);
    e[static_cast<size_t>(d)] = v;
    largest = std::max(largest, std::abs(v));
  }
  for (double& v : e) v *= peak_um / largest;
  return e;
}

}  // namespace gaugeloop::testing
