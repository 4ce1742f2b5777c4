// A crankshaft pin as the shop describes it: where it sits on the crank, how big it is, the
// wheel that grinds it and how the machine chases it. Plain data: config/ reads it from a
// part file's [pin] section, compensation/ turns it into wheel paths and reads the gauge
// through it, the simulator grinds it.
//
// Frames (docs/crankpins.md has the figure):
//  - Machine frame: the main journals' axis at the origin, X horizontal towards the wheel
//    (the wheel stands on the +X side), Y vertical, up. Increasing C turns the crank
//    counter-clockwise, seen with X to the right and Y up.
//  - Crank angle t = C + pin_angle_deg: the pin centre stands at R (cos t, sin t).
//  - Pin frame: origin at the pin's nominal centre, turning with the crank. A pin-frame
//    angle psi is measured from the crank radius outward (psi = 0 points away from the main
//    axis), counter-clockwise; a machine-frame direction at angle a is pin-frame angle a - t.
//  - Infeed X: the wheel centre stands at X + (r + rw - R) on the machine's X axis, so X = 0
//    when the pin is farthest from the wheel (t = 180) and X = 2R when it is nearest (t = 0).
//    In C-X-Y the wheel centre also moves in Y.
#pragma once

#include <optional>
#include <string_view>

#include "core/tolerance.h"

namespace gaugeloop {

// How the wheel chases the orbiting pin.
enum class PinMode {
  kCX,   // X alone: X(t) = R cos t + sqrt((r + rw)^2 - R^2 sin^2 t) - (r + rw - R)
  kCXY,  // X and Y: wheel centre, grinding point and pin centre on one horizontal line,
         // X = R cos t + R, Y = R sin t
};
std::string_view pin_mode_name(PinMode mode);  // "c-x", "c-x-y"
std::optional<PinMode> pin_mode_from_name(std::string_view name);

// What a pin is judged against ([pin.tolerance] in the part file). Keys of the
// characteristics (stable: stored, exported): roundness (um), diameter_error (um),
// stroke_error (um), index_error (deg).
struct PinTolerances {
  Limits roundness_um;       // peak to valley after the least-squares circle
  Limits diameter_error_um;  // twice the least-squares circle's radius error
  Limits stroke_error_um;    // the circle's centre along the crank radius (the throw's error)
  Limits index_error_deg;    // the circle's centre across it, as an angle about the main axis
};

struct PinGeometry {
  double throw_mm = 45.0;          // R: main axis to pin centre, half the stroke
  double pin_radius_mm = 25.0;     // r
  double wheel_radius_mm = 300.0;  // rw
  double pin_angle_deg = 0.0;      // the pin's angular position: its crank angle at C = 0
  PinMode mode = PinMode::kCX;
  // Where the gauge touches the pin, in pin-frame degrees from the grinding point: 180, the
  // default, is the side of the pin opposite the wheel, on the line through the wheel centre
  // and the pin centre. The gauge rides with the pin and reads the position of the pin's
  // surface along that line: the pin's support function in that direction, less r.
  double gauge_offset_deg = 180.0;
  PinTolerances tolerances;
};

}  // namespace gaugeloop
