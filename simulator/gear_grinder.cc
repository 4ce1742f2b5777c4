// The virtual gear grinder and its gear checker.
#include "simulator/gear_grinder.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "core/angles.h"
#include "core/text_file.h"
#include "simulator/seeded_random.h"

namespace gaugeloop {
namespace {

using seeded::uniform;

// A sign drawn from (seed, index).
double sign(std::uint64_t seed, std::uint64_t index) { return uniform(seed, index, 0.0, 1.0) < 0.5 ? -1.0 : 1.0; }

// The phase at which gap `gap` meets a spindle's once-per-turn error: the golden angle apart.
double gap_phase(int gap) { return gap * 2.399963229728653; }

}  // namespace

double AxisErrorTerms::at(double z, double gap_phase_rad) const {
  return offset + linear_per_mm * z + bow_per_mm2 * z * z +
         slow * std::sin(2.0 * kPi * z / slow_pitch_mm + slow_phase_rad) +
         fast * std::sin(2.0 * kPi * z / fast_pitch_mm + fast_phase_rad + gap_phase_rad);
}

AxisErrors GearMachineErrors::at(double z, int gap, double worm_phase_rad) const {
  const double phase = gap_phase(gap);
  return {y_mm.at(z, phase), z_mm.at(z, phase), b_deg.at(z, phase + worm_phase_rad), c_deg.at(z, phase)};
}

GearMachineErrors seeded_gear_machine(std::uint64_t seed) {
  GearMachineErrors m;
  m.seed = seed;
  std::uint64_t i = 0;
  auto u = [&](double lo, double hi) { return uniform(seed, ++i, lo, hi); };
  auto s = [&] { return sign(seed, ++i); };
  // Y: the shift slide's guide, bowed over the stroke, and its squareness to Z.
  m.y_mm.offset = u(-0.003, 0.003);
  m.y_mm.bow_per_mm2 = s() * u(10e-3, 25e-3) / (15.0 * 15.0);
  m.y_mm.linear_per_mm = s() * u(3e-4, 6e-4);
  m.y_mm.fast = u(0.0002, 0.0004);
  m.y_mm.fast_pitch_mm = u(0.3, 0.5);
  m.y_mm.fast_phase_rad = u(0.0, 2.0 * kPi);
  // Z: the stroke's ball screw, its scale and lag.
  m.z_mm.offset = u(-0.005, 0.005);
  m.z_mm.linear_per_mm = s() * u(30e-6, 60e-6);
  m.z_mm.slow = u(0.003, 0.006);
  m.z_mm.slow_pitch_mm = u(10.0, 16.0);
  m.z_mm.slow_phase_rad = u(0.0, 2.0 * kPi);
  // B: the worm spindle, its lag and a thermal drift, and once per worm turn.
  m.b_deg.offset = u(-0.005, 0.005);
  m.b_deg.linear_per_mm = s() * u(0.004, 0.008) / 30.0;
  m.b_deg.fast = u(0.01, 0.02);  // times S_BC (1/71): a few ten-thousandths of a degree of C
  m.b_deg.fast_pitch_mm = u(0.2, 0.3);
  m.b_deg.fast_phase_rad = u(0.0, 2.0 * kPi);
  // C: the table's drive, periodic over the stroke, and once per table turn.
  m.c_deg.offset = u(-0.003, 0.003);
  m.c_deg.slow = u(0.003, 0.006);
  m.c_deg.slow_pitch_mm = u(20.0, 30.0);
  m.c_deg.slow_phase_rad = u(0.0, 2.0 * kPi);
  m.c_deg.fast = u(0.0002, 0.0004);
  m.c_deg.fast_pitch_mm = u(0.5, 0.8);
  m.c_deg.fast_phase_rad = u(0.0, 2.0 * kPi);
  return m;
}

GroundGear::GroundGear(GearPart part, GearCoupling coupling, GearMachineErrors machine,
                       std::vector<StrokeProgramPoint> stroke)
    : part_(std::move(part)), coupling_(coupling), machine_(std::move(machine)), stroke_(std::move(stroke)) {}

double GroundGear::sim_deg(double z) const {
  if (z <= stroke_.front().z_mm) return stroke_.front().sim_deg;
  if (z >= stroke_.back().z_mm) return stroke_.back().sim_deg;
  const auto it = std::upper_bound(stroke_.begin(), stroke_.end(), z,
                                   [](double v, const StrokeProgramPoint& p) { return v < p.z_mm; });
  const StrokeProgramPoint& b = *it;
  const StrokeProgramPoint& a = *(it - 1);
  return a.sim_deg + (z - a.z_mm) / (b.z_mm - a.z_mm) * (b.sim_deg - a.sim_deg);
}

double GroundGear::mesh_error_deg(double z, int gap, double worm_phase_rad) const {
  return sim_deg(z) - equivalent_sim_deg(coupling_, machine_.at(z, gap, worm_phase_rad));
}

double GroundGear::profile_deviation_um(double roll_mm, int gap, Flank flank) const {
  const ProfileRange r = profile_range(part_.gear);
  const double r_b = base_radius_mm(part_.gear);
  // A transverse base pitch is 2 pi r_b / teeth of roll; the worm turns once per `starts` of them.
  const double worm_phase =
      (roll_mm - 0.5 * (r.start_roll_mm + r.tip_roll_mm)) * part_.gear.teeth / (r_b * part_.worm.starts);
  return flank_sign(flank) * r_b * 1000.0 * kPi / 180.0 * mesh_error_deg(0.0, gap, worm_phase);
}

Result<GroundGear> grind_gear(const GearPart& part, const GearMachineErrors& machine, const std::string& stroke_file) {
  if (Status v = validate(part); !v) return v.error();
  Result<std::string> text = read_regular_file(stroke_file, "stroke program");
  if (!text) return text.error();
  Result<ParsedStrokeProgram> p = parse_stroke_program(*text, stroke_file);
  if (!p) return p.error();
  return GroundGear(part, gear_coupling(part), machine, std::move(p->points));
}

double GroundGear::flank_deviation_um(double z_mm, int gap, Flank flank) const {
  return flank_sign(flank) * base_radius_mm(part_.gear) * 1000.0 * kPi / 180.0 * mesh_error_deg(z_mm, gap);
}

namespace {

// A checker point's own index for its noise: the gap, the flank and its position to 0.1 um (Z,
// or roll length with `domain` set apart), whatever order points are taken in.
std::uint64_t point_index(int gap, Flank flank, double position_mm, std::uint64_t domain) {
  const auto units = static_cast<std::uint64_t>(std::llround(position_mm * 1e4) + (1LL << 40)) + domain;
  return seeded::mix((static_cast<std::uint64_t>(gap) << 1 | (flank == Flank::kLeft ? 0u : 1u)) ^ seeded::mix(units));
}

}  // namespace

double probed_deviation_um(const GroundGear& gear, std::uint64_t measurement, int gap, Flank flank, double z_mm) {
  const std::uint64_t noise_seed = seeded::mix(gear.machine_seed() ^ seeded::mix(measurement + 0x51ed));
  const std::uint64_t index = point_index(gap, flank, z_mm, 0);
  return gear.flank_deviation_um(z_mm, gap, flank) + gear.checker_noise_um() * seeded::normal(noise_seed, index);
}

std::vector<ProfileTrace> measure_profile(const GroundGear& gear, const std::vector<int>& gaps, double step_mm,
                                          std::uint64_t measurement) {
  const ProfileRange r = profile_range(gear.part().gear);
  const std::uint64_t noise_seed = seeded::mix(gear.machine_seed() ^ seeded::mix(measurement + 0x9f0f11eULL));
  std::vector<ProfileTrace> out;
  for (int gap : gaps) {
    for (Flank f : {Flank::kLeft, Flank::kRight}) {
      ProfileTrace t;
      t.gap = gap;
      t.flank = f;
      for (double roll = r.start_roll_mm; roll <= r.tip_roll_mm + 1e-9; roll += step_mm) {
        t.roll_mm.push_back(roll);
        t.deviation_um.push_back(gear.profile_deviation_um(roll, gap, f) +
                                 gear.checker_noise_um() *
                                     seeded::normal(noise_seed, point_index(gap, f, roll, 1ULL << 50)));
      }
      align_on_tooth(t.deviation_um);
      out.push_back(std::move(t));
    }
  }
  return out;
}

std::vector<LeadTrace> measure_lead(const GroundGear& gear, const std::vector<int>& gaps, double step_mm,
                                    std::uint64_t measurement) {
  const std::vector<double> heights = lead_heights_mm(gear.part().gear, step_mm);
  std::vector<LeadTrace> out;
  for (int gap : gaps) {
    for (Flank f : {Flank::kLeft, Flank::kRight}) {
      LeadTrace t;
      t.gap = gap;
      t.flank = f;
      t.z_mm = heights;
      for (double z : heights) t.deviation_um.push_back(probed_deviation_um(gear, measurement, gap, f, z));
      align_on_tooth(t);
      out.push_back(std::move(t));
    }
  }
  return out;
}

}  // namespace gaugeloop
