// The virtual gear grinder: a worm-wheel generating grinder whose axes Y, Z, B and C stand off
// their commands by stated errors along the stroke, grinding a gear from the stroke program in
// the NC directory (read back as the control would) with SIM1 moving C between the spline
// points; and the gear checker that measures the lead of a few tooth gaps on both flanks.
// docs/gears.md, "The virtual gear grinder".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "compensation/gear_coupling.h"
#include "compensation/gear_lead.h"
#include "core/gear.h"
#include "core/result.h"
#include "nc_out/stroke_program.h"

namespace gaugeloop {

// One axis' error with the worm at stroke position z (mm): where the axis stands less where it
// was commanded, in the axis' unit (mm for Y and Z, degrees for B and C).
//   offset                       constant: a servo's lag at the stroke's constant speed, a
//                                position offset
//   + linear_per_mm z            a scale error, a squareness, a thermal drift over the stroke
//   + bow_per_mm2 z^2            a guide's straightness
//   + slow sin(2 pi z / slow_pitch_mm + slow_phase)
//                                a ball screw's or a drive's periodic error, slower than the
//                                spline points
//   + fast sin(2 pi z / fast_pitch_mm + fast_phase + gap phase)
//                                a spindle's once-per-turn error (the worm's, the table's drive):
//                                faster than the spline points can follow, and met by each tooth
//                                gap at another phase
struct AxisErrorTerms {
  double offset = 0.0;
  double linear_per_mm = 0.0;
  double bow_per_mm2 = 0.0;
  double slow = 0.0;
  double slow_pitch_mm = 10.0;
  double slow_phase_rad = 0.0;
  double fast = 0.0;
  double fast_pitch_mm = 0.4;
  double fast_phase_rad = 0.0;
  double at(double z_mm, double gap_phase_rad = 0.0) const;
};

struct GearMachineErrors {
  AxisErrorTerms y_mm;
  AxisErrorTerms z_mm;
  AxisErrorTerms b_deg;
  AxisErrorTerms c_deg;
  double checker_noise_um = 0.3;  // the gear checker's probe, one sigma
  std::uint64_t seed = 1;
  // The axes' errors at z for gap `gap` (its phase for the fast terms); `worm_phase_rad` turns
  // B's once-per-turn term on, as the worm turns while a profile is generated.
  AxisErrors at(double z_mm, int gap, double worm_phase_rad = 0.0) const;
};

// A machine drawn from `seed` within stated ranges (docs/gears.md): Y's guide bowed 10-25 um over
// 15 mm and squareness 0.3-0.6 um/mm; Z's screw 3-6 um at a 10-16 mm pitch and 30-60 ppm; B
// drifting 0.004-0.008 deg over 30 mm; C's drive 0.003-0.006 deg at a 20-30 mm period; the fast
// terms 0.2-0.4 um on Y and a few ten-thousandths of a degree of C from B and C; the checker's
// noise 0.3 um. Lags and offsets of a few um and thousandths of a degree.
GearMachineErrors seeded_gear_machine(std::uint64_t seed);

// The gear as ground: at each height z of the face and tooth gap, how far C stood ahead of where
// the worm needed it (degrees): SIM1 (linear in Z between the stroke's spline points, as the
// control moves it under FGROUP(Z)) less dSIM of the axes' errors there.
class GroundGear {
 public:
  GroundGear(GearPart part, GearCoupling coupling, GearMachineErrors machine, std::vector<StrokeProgramPoint> stroke);
  double mesh_error_deg(double z_mm, int gap, double worm_phase_rad = 0.0) const;
  // What a probe finds on `flank` of `gap` at height z, without noise: flank_sign(flank) r_b
  // mesh (radians), um.
  double flank_deviation_um(double z_mm, int gap, Flank flank) const;
  // The same at roll length `roll_mm` of the profile at the face's middle: generating the profile
  // from the root to the tip, the worm turns once per transverse base pitch over its starts, and
  // B's once-per-turn error goes round with it; the slower terms are those at the middle.
  double profile_deviation_um(double roll_mm, int gap, Flank flank) const;
  const GearPart& part() const { return part_; }
  std::uint64_t machine_seed() const { return machine_.seed; }
  double checker_noise_um() const { return machine_.checker_noise_um; }

 private:
  double sim_deg(double z_mm) const;
  GearPart part_;
  GearCoupling coupling_;
  GearMachineErrors machine_;
  std::vector<StrokeProgramPoint> stroke_;
};

// Grinds a gear from the stroke program at `stroke_file` (parse_stroke_program: a program that
// does not read back, or was edited by hand, is refused as the control's reader would).
Result<GroundGear> grind_gear(const GearPart& part, const GearMachineErrors& machine, const std::string& stroke_file);

// What the checker's probe reads on `flank` of `gap` at height z of gear measurement number
// `measurement`: flank_deviation_um plus the checker's noise, a pure function of the machine's
// seed, the measurement and the point (gap, flank, Z to 0.1 um), whatever order points are
// taken in, so the probe over Modbus (simulator/gear_probe_simulator.h) reads what the
// checker below reads.
double probed_deviation_um(const GroundGear& gear, std::uint64_t measurement, int gap, Flank flank, double z_mm);

// The gear checker's profile: each gap in `gaps`, left and right flank, at the face's middle,
// every step_mm of roll length over profile_range (noise as probed_deviation_um's, seeded apart),
// each trace aligned on its tooth (its mean taken out).
std::vector<ProfileTrace> measure_profile(const GroundGear& gear, const std::vector<int>& gaps, double step_mm,
                                          std::uint64_t measurement);

// The gear checker: the lead of each gap in `gaps` (1-based), left and right flank, at every
// step_mm across the face (from -b/2 to +b/2), with the checker's noise (seeded by the machine's
// seed, `measurement` and the point), each trace aligned on its tooth (its mean taken out, as a
// checker's alignment does). The deviation of flank f is flank_sign(f) r_b mesh (radians).
std::vector<LeadTrace> measure_lead(const GroundGear& gear, const std::vector<int>& gaps, double step_mm,
                                    std::uint64_t measurement);

}  // namespace gaugeloop
