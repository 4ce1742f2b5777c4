// What the flat gauge probe reads on a lobe: on the design lobe, and on a lobe a wheel path grinds.
#pragma once

#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "core/part.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// The reading of a flat probe at each whole cam degree theta on the design lobe, in mm,
// 0 on the base circle. Frame: cam frame, index = theta, the probe's direction (normal of
// its face) about the cam axis.
//  - Flat follower: the lift itself, H(theta).
//  - Roller and knife edge: the support function of the cam surface (the pitch curve
//    rho(beta) = rb + rr + H(beta) at polar angle beta, offset inward by rr):
//      reading(theta) = max over beta of rho(beta) cos(beta - theta) - rr - rb,
//    maximised to < 1e-7 mm. A concave flank never touches the probe.
// Errors: as follower_geometry (kInvalidInput) and check_lobe_shape (kRefused).
Result<DegreeTable> flat_probe_reading(const PeriodicSpline& lift_mm, const Part& part);

// The reading of a flat probe at each whole cam degree on the lobe that `path` grinds
// (the envelope of the wheel, radius part.wheel_radius_mm, following it), 0 on the base
// circle of radius part.base_circle_radius_mm. Each wheel position W lies rw outside the lobe
// along the contact normal, so reading(theta) = max over psi of |W(psi)| cos(psi - theta)
// - rw - rb, with |W| = X + rw + rb interpolated periodically between the path's points.
// This closes the round trip of BRIEF section 3: the reading of the ground lobe equals
// flat_probe_reading of the lift the path was computed from.
// Errors: kInvalidInput when the path is malformed (sizes, fewer than 4 points, psi not
// strictly increasing in [0, 360)) or the radii are not positive.
Result<DegreeTable> ground_lobe_reading(const WheelPath& path, const Part& part);

}  // namespace gaugeloop
