// Periodic C2 cubic spline over one turn of the cam, the smooth lift model the kinematics need.
#pragma once

#include <cstddef>
#include <vector>

#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// Interpolating cubic spline s(angle) with period 360 deg: s, s' and s'' are continuous
// everywhere, including across 360 -> 0. Knots may be non-uniform.
//
// Frame: whatever frame the knots are given in (cam frame for lifts); angles in degrees.
// Units: values keep the unit they were fitted with (mm for lifts, um for corrections).
// Derivatives are per RADIAN of angle (d/dbeta, beta in rad), as the kinematics need.
// Evaluation accepts any finite angle and wraps it into one turn; a non-finite angle
// gives NaN. Immutable after fit; safe to share between threads.
class PeriodicSpline {
 public:
  static constexpr double kPeriodDeg = 360.0;

  // Fits knots (angle_deg[i], value[i]). Requirements: same sizes, at least 4 points,
  // angles strictly increasing within [0, 360), everything finite. Otherwise kInvalidInput
  // naming the offending index. O(n): cyclic tridiagonal system solved by Sherman-Morrison.
  static Result<PeriodicSpline> fit(const std::vector<double>& angle_deg, const std::vector<double>& value);

  // Fits one value per whole degree (knots at 0, 1, ..., 359). Values must be finite.
  static PeriodicSpline fit(const DegreeTable& value);

  double value(double angle_deg) const;
  double d1(double angle_deg) const;  // per rad
  double d2(double angle_deg) const;  // per rad^2

  // All three at once, for one interval search: what the kinematics call in their loops.
  struct Point {
    double value = 0.0;
    double d1 = 0.0;  // per rad
    double d2 = 0.0;  // per rad^2
  };
  Point evaluate(double angle_deg) const;

  // Piece i, from knot i over width_deg (the last wraps across 360):
  // s(knot_deg + t) = a + b t + c t^2 + d t^3 for t in [0, width_deg], t in DEGREES (so the
  // per-radian derivatives carry factors of 180/pi). For exact checks on a whole interval.
  struct Piece {
    double knot_deg = 0.0;
    double width_deg = 0.0;
    double a = 0.0;
    double b = 0.0;
    double c = 0.0;
    double d = 0.0;
  };
  // Indices are std::ptrdiff_t, the type Eigen::Index is: the fit solves with Eigen, but Eigen
  // stays out of this header, which most of the product includes (docs/building.md).
  Piece piece(std::ptrdiff_t i) const;

  // The knots as fitted, strictly increasing in [0, 360), and the values there.
  const std::vector<double>& knots_deg() const { return knot_deg_; }
  const std::vector<double>& knot_values() const { return a_; }
  std::ptrdiff_t size() const { return static_cast<std::ptrdiff_t>(knot_deg_.size()); }

 private:
  PeriodicSpline(std::vector<double> knot_deg, std::vector<double> value);

  // Interval index i and offset t = angle - knot i in degrees, t in [0, h_i) (to rounding).
  // O(1) on uniform knots, a binary search otherwise.
  void locate(double angle_deg, std::ptrdiff_t& i, double& t) const;

  // On interval i: s(t) = a_i + b_i t + c_i t^2 + d_i t^3, t in degrees from knot i.
  std::vector<double> knot_deg_;
  std::vector<double> a_;
  std::vector<double> b_;
  std::vector<double> c_;
  std::vector<double> d_;
  double uniform_step_deg_ = 0.0;  // the knot spacing when all are equal (1e-12 deg), else 0
};

}  // namespace gaugeloop
