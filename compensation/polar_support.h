// The support function of a closed curve given in polar form: what a flat probe reads.
#pragma once

#include <vector>

#include "compensation/periodic_spline.h"

namespace gaugeloop {

// Curve r(phi) = radius_offset_mm + radius_mm(phi), phi the polar angle in degrees about the
// cam axis, r > 0 (star-shaped about the axis). Its support function in direction theta is
//   h(theta) = max over phi of r(phi) cos(phi - theta),
// the distance from the axis to the tangent line with outward normal theta: what a flat
// probe reads in that direction. Concave parts never touch that line.
//
// Accuracy: the maximum is sampled densely (spacing `max_spacing_deg`), then every local
// maximum that could be the global one is refined by golden section to below 1e-9 mm.
class PolarSupport {
 public:
  PolarSupport(PeriodicSpline radius_mm, double radius_offset_mm, double max_spacing_deg = 0.05);

  struct Point {
    double support_mm = 0.0;  // h(theta)
    double phi_deg = 0.0;     // polar angle where the maximum is attained, in [0, 360)
  };

  // h(theta) and where it is attained; theta in degrees, any value (wrapped).
  Point at(double theta_deg) const;

 private:
  double radius(double phi_deg) const { return offset_mm_ + radius_mm_.value(phi_deg); }

  PeriodicSpline radius_mm_;
  double offset_mm_;
  std::vector<double> phi_deg_;  // dense grid over one turn
  std::vector<double> x_mm_;     // r cos(phi) on the grid
  std::vector<double> y_mm_;     // r sin(phi) on the grid
};

}  // namespace gaugeloop
