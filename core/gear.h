// A helical (or spur) gear ground by a worm wheel on a generating grinder, as the shop
// describes it: the gear, the threaded wheel (the worm) and the stroke. Plain data: config/
// reads it from a part file's [gear] section, compensation/ derives the electronic gearbox's
// coupling factors from it (docs/gears.md has the derivation and the figure of the axes).
//
// Machine frame and axis senses (docs/gears.md):
//  - Z along the gear's axis, up; the worm's centre moves up with +Z (the stroke).
//  - C the work spindle turning the gear, positive counter-clockwise seen from +Z.
//  - X from the gear's axis towards the worm's centre (the infeed; not coupled).
//  - B the worm's rotation about its own axis, positive counter-clockwise seen from the axis'
//    positive end; Y the shift along the worm's axis (tilted by the setting angle in the
//    plane tangent to the gear's pitch cylinder at the grinding point).
//  - A right-hand gear's tooth climbs counter-clockwise (+C) as Z rises, as a right-hand screw.
#pragma once

#include <optional>
#include <string_view>
#include <vector>

namespace gaugeloop {

enum class Hand { kRight, kLeft };
std::string_view hand_name(Hand hand);  // "right", "left"
std::optional<Hand> hand_from_name(std::string_view name);
inline int hand_sign(Hand hand) { return hand == Hand::kRight ? 1 : -1; }

struct GearGeometry {
  double normal_module_mm = 2.25;
  int teeth = 71;
  double pressure_angle_deg = 20.0;  // normal pressure angle
  double helix_angle_deg = 21.8;     // at the pitch cylinder; 0 for a spur gear
  Hand hand = Hand::kRight;          // of the helix; a spur gear's is not used
  double face_width_mm = 24.0;
};

// The threaded grinding wheel: a worm of `starts` threads.
struct WormWheel {
  int starts = 1;
  double pitch_diameter_mm = 275.0;
  // Lead angle at the pitch diameter, from sin(lead) = starts * normal module / pitch diameter;
  // the part file may give it, and must then agree.
  double lead_angle_deg = 0.0;
  Hand hand = Hand::kRight;
};

// The grinding stroke along Z, cut into spline points where the compensation is written.
struct GearStroke {
  double z_start_mm = -15.0;
  double z_end_mm = 15.0;
  double spline_step_mm = 1.0;  // spacing of the spline points along Z
};

struct GearPart {
  GearGeometry gear;
  WormWheel worm;
  GearStroke stroke;
};

// A tooth flank. The left flank is the one facing +C: turning the gear by +dC against the worm
// leaves the left flank thicker and the right one thinner (compensation/gear_lead.h).
enum class Flank { kLeft, kRight };
std::string_view flank_name(Flank flank);  // "left", "right"
inline int flank_sign(Flank flank) { return flank == Flank::kLeft ? 1 : -1; }

// A flank line across the face width (a lead, or helix, trace) as a gear checker or the
// grinder's probe measures it: deviations in um along the base circle's tangent in the
// transverse plane, positive where the flank has more metal than the design helix, at heights
// z_mm of the stroke's frame (the face from -b/2 to +b/2 around Z = 0).
struct LeadTrace {
  int gap = 0;  // the tooth gap, 1-based
  Flank flank = Flank::kLeft;
  std::vector<double> z_mm;          // across the face, increasing
  std::vector<double> deviation_um;  // one per z_mm
};

// A flank along its involute at the face's middle (a profile trace) as a gear checker measures
// it: deviations as LeadTrace's, at roll lengths roll_mm (along the base circle's tangent, from
// where the involute leaves the base circle), increasing from the root towards the tip.
struct ProfileTrace {
  int gap = 0;
  Flank flank = Flank::kLeft;
  std::vector<double> roll_mm;
  std::vector<double> deviation_um;
};

// The heights across the face a lead is measured at: from -b/2 every step_mm, up to +b/2.
std::vector<double> lead_heights_mm(const GearGeometry& gear, double step_mm);

// Aligns a trace on its tooth as a gear checker does: its mean taken out of every deviation (the
// probe's zero and the tooth's thickness are not lead).
void align_on_tooth(LeadTrace& trace);
// The same for a trace's deviations alone (a profile trace's).
void align_on_tooth(std::vector<double>& deviation_um);

}  // namespace gaugeloop
