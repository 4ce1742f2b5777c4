// Crankpin kinematics in closed form: where the wheel stands for a round pin at any C, which
// point of the pin it grinds, and in which direction the grinding normal points.
// Frames and the infeed's zero: core/pin.h. The derivation is in docs/crankpins.md.
#pragma once

#include "core/pin.h"
#include "core/result.h"

namespace gaugeloop {

// Checks a pin: radii and throw positive and finite, R < r + rw (the wheel reaches the pin
// at every crank angle), the angles finite. kInvalidInput naming the key, its value and the
// range allowed.
Status validate(const PinGeometry& pin);

// The crank angle t = C + pin_angle_deg, in degrees (not reduced).
double crank_angle_deg(const PinGeometry& pin, double c_deg);

// The wheel grinding a round pin of the design at machine angle C.
struct PinPose {
  double x_mm = 0.0;  // infeed X (core/pin.h: 0 with the pin farthest from the wheel)
  double y_mm = 0.0;  // Y: R sin t in C-X-Y, 0 in C-X
  // Machine-frame angle of the grinding normal, from the pin centre to the wheel centre:
  // phi = -asin(R sin t / (r + rw)) in C-X, 0 in C-X-Y (the three stay on one horizontal line).
  double normal_deg = 0.0;
  // Pin-frame angle of the grinding point, normal_deg - t, in [0, 360).
  double contact_psi_deg = 0.0;
  // d(contact_psi)/dC, degrees per degree: negative, the grinding point runs round the pin
  // against the crank. C-X: dphi/dt - 1 with dphi/dt = -R cos t / ((r + rw) cos phi), so it
  // runs from -(r + rw + R)/(r + rw) (t = 0) to -(r + rw - R)/(r + rw) (t = 180); C-X-Y: -1.
  double dpsi_dc = -1.0;
};

// Exact for the design (a round pin of radius r). Call validate first.
PinPose design_pin_pose(const PinGeometry& pin, double c_deg);

// The pin-frame angle the gauge reads at machine angle C: the grinding point's plus
// gauge_offset_deg, in [0, 360).
double gauge_psi_deg(const PinGeometry& pin, double c_deg);

// The grinding-point speed over the pin's surface with C at `speed_rpm`, mm/min:
// r |dpsi/dC| 2 pi |n|. In C-X it varies over a turn by (r + rw + R) / (r + rw - R); in C-X-Y
// it is constant.
double pin_grinding_point_speed_mm_per_min(const PinGeometry& pin, double c_deg, double speed_rpm);

}  // namespace gaugeloop
