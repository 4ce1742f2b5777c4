// The support function of a closed curve given in polar form: what a flat probe reads.
#pragma once

#include <vector>

#include "compensation/periodic_spline.h"

namespace gaugeloop {

// Curve r(phi) = radius_offset_mm + radius_mm(phi), phi the polar angle in degrees about the
// cam axis, r > 0 (star-shaped about the axis). Its support function in direction theta is
//   h(theta) = max over phi of r(phi) cos(phi - theta),
// the distance from the axis to the tangent line with outward normal theta: what a flat
// probe reads in that direction. Concave parts never touch that line: where the probe
// bridges one, h has a corner (its slope jumps by the length of the bridge).
//
// Method: the curve is sampled (spacing `max_spacing_deg`, at least 2 samples per knot
// interval) and the convex hull of the samples is kept, with the outward normal angle of each
// hull edge. A query finds, by binary search on those angles, the hull vertex the probe rests
// on, then refines the contact on the curve itself by Newton within one sample either side
// of it, started where the hull's edge normals place the contact (safeguarded by bisection
// when plain Newton does not settle inside that bracket), and likewise for a hull neighbour that is not the next sample
// (the other end of a bridge, a near-tie). The samples only bracket: the accuracy comes from the Newton refinement on
// the curve, h to below 1e-9 mm and the contact angle to 1e-10 deg, provided r(phi) cos(phi - theta) has one maximum
// within a sample either side of the best sample (true of a cam curve at 0.25 deg;
// tests/compensation/polar_support_test.cc checks it against a brute-force maximum). A query costs O(log n);
// construction O(n). Immutable; safe to share between threads.
class PolarSupport {
 public:
  PolarSupport(PeriodicSpline radius_mm, double radius_offset_mm, double max_spacing_deg = 0.25);

  struct Point {
    double support_mm = 0.0;     // h(theta)
    double phi_deg = 0.0;        // polar angle where the maximum is attained, in [0, 360)
    double tangential_mm = 0.0;  // r(phi) sin(phi - theta): where the contact sits along the
                                 // probe face, and dh/dtheta per RADIAN (envelope theorem)
  };

  // h(theta) and where it is attained; theta in degrees, any finite value (wrapped).
  Point at(double theta_deg) const;

 private:
  double radius(double phi_deg) const { return offset_mm_ + radius_mm_.value(phi_deg); }

  // The maximum of r(phi) cos(phi - theta) for phi in [lo, hi] (degrees, unwrapped), Newton
  // starting from start_deg in (lo, hi).
  Point refine(double theta_deg, double lo_deg, double hi_deg, double start_deg) const;
  // The Point for a contact at phi_deg (unwrapped).
  Point contact_point(double theta_deg, double phi_deg) const;

  PeriodicSpline radius_mm_;
  double offset_mm_;
  std::vector<double> phi_deg_;  // dense grid over one turn
  std::vector<double> x_mm_;     // r cos(phi) on the grid
  std::vector<double> y_mm_;     // r sin(phi) on the grid
  // Convex hull of the grid points, counter-clockwise: hull_[i] indexes the grid; edge i runs
  // from hull_[i] to hull_[i + 1 mod m] with outward normal angle normal_deg_[i], increasing
  // from normal_deg_[0] through less than normal_deg_[0] + 360.
  std::vector<size_t> hull_;
  std::vector<double> normal_deg_;
};

}  // namespace gaugeloop
