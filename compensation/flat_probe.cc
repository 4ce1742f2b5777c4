// Flat-probe readings as support functions of the design lobe or of the ground lobe.
#include "compensation/flat_probe.h"

#include <cmath>
#include <string>

#include "compensation/cam_geometry.h"
#include "compensation/message_text.h"
#include "compensation/polar_support.h"

namespace gaugeloop {

Result<DegreeTable> flat_probe_reading(const PeriodicSpline& lift_mm, const Part& part) {
  Result<FollowerGeometry> geometry = follower_geometry(part);
  if (!geometry.ok()) return geometry.error();
  const FollowerGeometry& g = geometry.value();
  if (Status shape = check_lobe_shape(lift_mm, g); !shape.ok()) return shape.error();

  DegreeTable reading{};
  if (g.kind == FollowerKind::kFlat) {
    // A flat follower's lift is already the support function minus rb (the lobe is convex).
    for (int d = 0; d < kDegreesPerRevolution; ++d) reading[static_cast<size_t>(d)] = lift_mm.value(d);
    return reading;
  }
  const double rb = g.base_circle_radius_mm;
  const double rr = g.roller_radius_mm;
  // Support of the inward offset by rr = support of the pitch curve - rr.
  const PolarSupport pitch(lift_mm, rb + rr);
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    reading[static_cast<size_t>(d)] = pitch.at(d).support_mm - rr - rb;
  }
  return reading;
}

Result<DegreeTable> ground_lobe_reading(const WheelPath& path, const Part& part) {
  if (path.psi_deg.size() != path.x_mm.size()) {
    return make_error(ErrorCode::kInvalidInput, "ground lobe reading: the wheel path has " +
                                                    std::to_string(path.psi_deg.size()) + " angles but " +
                                                    std::to_string(path.x_mm.size()) + " infeeds");
  }
  Result<PeriodicSpline> infeed = PeriodicSpline::fit(path.psi_deg, path.x_mm);
  if (!infeed.ok()) {
    return make_error(ErrorCode::kInvalidInput, "ground lobe reading: wheel path: " + infeed.error().message);
  }
  Result<FollowerGeometry> geometry = follower_geometry(part);
  if (!geometry.ok()) return geometry.error();
  const double rb = geometry->base_circle_radius_mm;
  const double rw = part.wheel_radius_mm;
  if (!std::isfinite(rw) || rw <= 0.0) {
    return make_error(ErrorCode::kInvalidInput, "part '" + part.name + "': wheel radius " + format_fixed(rw, 3) +
                                                    " mm is not a positive number; set wheel_radius_mm");
  }
  const PolarSupport wheel_centre(std::move(infeed).value(), rw + rb);
  DegreeTable reading{};
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    reading[static_cast<size_t>(d)] = wheel_centre.at(d).support_mm - rw - rb;
  }
  return reading;
}

}  // namespace gaugeloop
