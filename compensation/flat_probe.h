// What the flat gauge probe reads on a lobe: on the design lobe, and on a lobe a wheel path grinds.
#pragma once

#include <optional>
#include <utility>
#include <vector>

#include "compensation/cam_geometry.h"
#include "compensation/periodic_spline.h"
#include "compensation/polar_support.h"
#include "compensation/wheel_path.h"
#include "core/part.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// What a flat probe reads on the design lobe at ANY cam angle, 0 on the base circle, in mm.
// Frame: cam frame, theta = the probe's direction (normal of its face) about the cam axis.
// Two models:
//  - of_lobe: exact. Flat follower: the lift spline itself. Roller and knife edge: the support
//    function of the cam surface (PolarSupport on the pitch curve, less rr), to 1e-9 mm,
//    corners included: where the probe bridges a concave flank onto the base circle the
//    reading has a corner (on examples/exhaust_roller its slope jumps by 0.25 mm/deg at 63
//    deg), which no interpolation of whole-degree readings follows (a spline through them
//    is 5 um out there at 0.05 deg from a knot).
//  - interpolating: the periodic spline through a whole-degree table, for when only the table
//    is known (e.g. a stored analysis). Exact at whole degrees, and between them for a flat
//    follower whose lift table has a knot at every whole degree.
// table() is the reading at whole degrees, bit for bit what at(d) returns (of_lobe) or the
// table given (interpolating). Immutable; safe to share between threads.
class DesignReading {
 public:
  // Errors: as follower_geometry (kInvalidInput) and check_lobe_shape (kRefused).
  static Result<DesignReading> of_lobe(const PeriodicSpline& lift_mm, const Part& part);
  static DesignReading interpolating(const DegreeTable& reading_mm);

  double at(double theta_deg) const;                // mm
  double slope_mm_per_deg(double theta_deg) const;  // d reading / d theta (one side at a corner)

  // Both from one evaluation (one support-function solve for a roller).
  struct Sample {
    double reading_mm = 0.0;
    double slope_mm_per_deg = 0.0;
  };
  Sample sample(double theta_deg) const;
  const DegreeTable& table() const { return table_; }

  // Once-per-part data of_lobe keeps for corrected_lift, which would otherwise find it again
  // for every correction. Where the probe at each whole degree theta rests on a roller or
  // knife-edge lobe: the follower angle beta of that contact on the pitch curve (cam frame,
  // degrees in [0, 360)) and the cosine of the pressure angle there. Empty for a flat
  // follower, for `interpolating`, and for a lobe whose lift reaches below -rb between the
  // shape check's samples (corrected_lift refuses it).
  struct Contact {
    double beta_deg = 0.0;
    double cos_pressure_angle = 1.0;
  };
  const std::vector<Contact>& contacts() const { return contacts_; }
  // The lift and follower of_lobe was given, so a caller can check it is handed the same
  // design; null for `interpolating`.
  const PeriodicSpline* lift() const { return lift_ ? &*lift_ : nullptr; }
  const FollowerGeometry& geometry() const { return geometry_; }

 private:
  explicit DesignReading(PeriodicSpline spline) : spline_(std::move(spline)) {}
  DesignReading(PolarSupport support, double reading_offset_mm)
      : support_(std::move(support)), reading_offset_mm_(reading_offset_mm) {}

  // Exactly one of the two is set: the reading is spline_ (flat lift, or interpolating), or
  // support_ less reading_offset_mm_ (rr + rb).
  std::optional<PeriodicSpline> spline_;
  std::optional<PolarSupport> support_;
  double reading_offset_mm_ = 0.0;
  DegreeTable table_{};
  std::optional<PeriodicSpline> lift_;  // of_lobe only
  FollowerGeometry geometry_{};         // of_lobe only
  std::vector<Contact> contacts_;       // of_lobe, roller and knife edge: one per whole degree
};

// The reading of a flat probe at each whole cam degree theta on the design lobe, in mm,
// 0 on the base circle: DesignReading::of_lobe(lift_mm, part)->table(). Frame: cam frame,
// index = theta, the probe's direction (normal of its face) about the cam axis.
//  - Flat follower: the lift itself, H(theta).
//  - Roller and knife edge: the support function of the cam surface (the pitch curve
//    rho(beta) = rb + rr + H(beta) at polar angle beta, offset inward by rr):
//      reading(theta) = max over beta of rho(beta) cos(beta - theta) - rr - rb,
//    to < 1e-9 mm. A concave flank never touches the probe.
// Errors: as follower_geometry (kInvalidInput) and check_lobe_shape (kRefused).
Result<DegreeTable> flat_probe_reading(const PeriodicSpline& lift_mm, const Part& part);

// The reading of a flat probe at each whole cam degree on the lobe that `path` grinds
// (the envelope of the wheel, radius part.wheel_radius_mm, following it), 0 on the base
// circle of radius part.base_circle_radius_mm. Each wheel position W lies rw outside the lobe
// along the contact normal, so reading(theta) = max over psi of |W(psi)| cos(psi - theta)
// - rw - rb, with |W| = X + rw + rb interpolated periodically between the path's points.
// This closes the round trip of the cam-grinding kinematics: the reading of the ground lobe equals
// flat_probe_reading of the lift the path was computed from.
// Errors: kInvalidInput when the path is malformed (sizes, fewer than 4 points, psi not
// strictly increasing in [0, 360)) or the radii are not positive.
Result<DegreeTable> ground_lobe_reading(const WheelPath& path, const Part& part);

}  // namespace gaugeloop
