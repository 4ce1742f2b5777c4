// Flat-probe readings as support functions of the design lobe or of the ground lobe.
#include "compensation/flat_probe.h"

#include <cmath>
#include <numbers>
#include <string>
#include <utility>

#include "compensation/cam_geometry.h"
#include "compensation/message_text.h"
#include "compensation/polar_support.h"
#include "core/angles.h"

namespace gaugeloop {
namespace {}  // namespace

Result<DesignReading> DesignReading::of_lobe(const PeriodicSpline& lift_mm, const Part& part) {
  Result<FollowerGeometry> geometry = follower_geometry(part);
  if (!geometry.ok()) return geometry.error();
  const FollowerGeometry& g = geometry.value();
  if (Status shape = check_lobe_shape(lift_mm, g); !shape.ok()) return shape.error();
  // A flat follower's lift is already the support function minus rb (the lobe is convex).
  // Otherwise: support of the inward offset by rr = support of the pitch curve - rr.
  DesignReading reading = (g.kind == FollowerKind::kFlat)
                              ? DesignReading(lift_mm)
                              : DesignReading(PolarSupport(lift_mm, g.base_circle_radius_mm + g.roller_radius_mm),
                                              g.roller_radius_mm + g.base_circle_radius_mm);
  reading.lift_ = lift_mm;
  reading.geometry_ = g;
  if (g.kind == FollowerKind::kFlat) {
    for (int d = 0; d < kDegreesPerRevolution; ++d) reading.table_[static_cast<size_t>(d)] = reading.at(d);
    return reading;
  }
  // One support solve per degree gives the reading (bit for bit what at(d) returns) and the
  // contact; the contacts are corrected_lift's only where the support function can be taken
  // (rb + H > 0 exactly, piece by piece), as it checks itself.
  const double pitch_offset_mm = g.base_circle_radius_mm + g.roller_radius_mm;
  const bool round_axis = flat_lobe_minima(lift_mm, g.base_circle_radius_mm).support_mm > 0.0;
  if (round_axis) reading.contacts_.resize(static_cast<size_t>(kDegreesPerRevolution));
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    const size_t i = static_cast<size_t>(d);
    const PolarSupport::Point p = reading.support_->at(d);
    reading.table_[i] = p.support_mm - reading.reading_offset_mm_;
    if (round_axis) {
      const double alpha = std::atan(lift_mm.d1(p.phi_deg) / (pitch_offset_mm + lift_mm.value(p.phi_deg)));
      reading.contacts_[i] = {p.phi_deg, std::cos(alpha)};
    }
  }
  return reading;
}

DesignReading DesignReading::interpolating(const DegreeTable& reading_mm) {
  DesignReading reading(PeriodicSpline::fit(reading_mm));
  reading.table_ = reading_mm;
  return reading;
}

double DesignReading::at(double theta_deg) const {
  if (spline_) return spline_->value(theta_deg);
  return support_->at(theta_deg).support_mm - reading_offset_mm_;
}

double DesignReading::slope_mm_per_deg(double theta_deg) const {
  if (spline_) return spline_->d1(theta_deg) * kRadPerDeg;
  return support_->at(theta_deg).tangential_mm * kRadPerDeg;
}

DesignReading::Sample DesignReading::sample(double theta_deg) const {
  if (spline_) {
    const PeriodicSpline::Point p = spline_->evaluate(theta_deg);
    return {p.value, p.d1 * kRadPerDeg};
  }
  const PolarSupport::Point p = support_->at(theta_deg);
  return {p.support_mm - reading_offset_mm_, p.tangential_mm * kRadPerDeg};
}

Result<DegreeTable> flat_probe_reading(const PeriodicSpline& lift_mm, const Part& part) {
  Result<DesignReading> reading = DesignReading::of_lobe(lift_mm, part);
  if (!reading.ok()) return reading.error();
  return reading->table();
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
