// What a wheel leaves of a pin: the envelope of the wheel along its path, seen in the pin
// frame. Frames: core/pin.h; docs/crankpins.md.
#pragma once

#include <vector>

#include "core/pin.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// The pin ground by a wheel of radius rw whose path is X(C), Y(C) on the uniform grid
// C = k * c_step_deg over one turn (x_mm and y_mm of 360 / c_step_deg rows each; y_mm all 0
// in C-X). In the pin frame the wheel centre orbits the pin; the pin left is the region
// inside that orbit eroded by rw, so its support function in pin-frame direction psi is
//   h(psi) = max over the path of (wheel centre . u(psi)) - rw,
// the maximum refined between rows (parabola through the three rows around it), so a 0.1 deg
// grid gives h to better than 1e-6 mm. Returns h(psi) - r at every whole pin degree psi: the
// radius error a gauge on that side would read, mm (0 everywhere for the design path).
// Errors: kInvalidInput for a step not dividing 360, vectors of the wrong size or non-finite
// values; as validate(PinGeometry).
Result<DegreeTable> ground_pin_radius_error_mm(const PinGeometry& pin, double c_step_deg,
                                               const std::vector<double>& x_mm, const std::vector<double>& y_mm);

// The same at any pin-frame angle (for the gauge, which reads between whole degrees in C-X).
// `psi_deg` any finite angles; returns one value per angle.
Result<std::vector<double>> ground_pin_radius_error_at_mm(const PinGeometry& pin, double c_step_deg,
                                                          const std::vector<double>& x_mm,
                                                          const std::vector<double>& y_mm,
                                                          const std::vector<double>& psi_deg);

}  // namespace gaugeloop
