// Periodic C2 cubic spline over one turn of the cam, the smooth lift model the kinematics need.
#pragma once

#include <vector>

#include <Eigen/Core>

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

  // The knots as fitted, strictly increasing in [0, 360), and the values there.
  const Eigen::VectorXd& knots_deg() const { return knot_deg_; }
  const Eigen::VectorXd& knot_values() const { return a_; }
  Eigen::Index size() const { return knot_deg_.size(); }

 private:
  PeriodicSpline(Eigen::VectorXd knot_deg, Eigen::VectorXd value);

  // Interval index i and offset t = angle - knot i in degrees, t in [0, h_i).
  void locate(double angle_deg, Eigen::Index& i, double& t) const;

  // On interval i: s(t) = a_i + b_i t + c_i t^2 + d_i t^3, t in degrees from knot i.
  Eigen::VectorXd knot_deg_;
  Eigen::VectorXd a_;
  Eigen::VectorXd b_;
  Eigen::VectorXd c_;
  Eigen::VectorXd d_;
};

}  // namespace gaugeloop
