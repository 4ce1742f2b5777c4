// The virtual gear grinder's slides and a ballbar run on them.
#include "simulator/slide_ballbar.h"

#include <cmath>

#include "core/angles.h"
#include "simulator/seeded_random.h"

namespace gaugeloop {
namespace {

double sign_of(double v) { return v > 0.0 ? 1.0 : v < 0.0 ? -1.0 : 0.0; }

}  // namespace

void SlideErrors::error_mm(double y, double z, double vy, double vz, const std::vector<SlideCompensationTable>& tables,
                           double& ey, double& ez) const {
  ey = y_scale * y + squareness * z + y_bow_per_mm * z * z +
       y_screw_mm * std::sin(2.0 * kPi * y / y_screw_lead_mm + y_screw_phase_rad) - vy * y_lag_ms / 1000.0 -
       0.5e-3 * y_backlash_um * sign_of(vy) - taken_out_mm(tables, 'Y', y, z);
  ez = z_scale * z + z_bow_per_mm * y * y + z_screw_mm * std::sin(2.0 * kPi * z / z_screw_lead_mm + z_screw_phase_rad) -
       vz * z_lag_ms / 1000.0 - 0.5e-3 * z_backlash_um * sign_of(vz) - taken_out_mm(tables, 'Z', y, z);
}

SlideErrors seeded_slides(std::uint64_t seed) {
  SlideErrors s;
  s.seed = seed;
  std::uint64_t i = 0;
  auto u = [&](double lo, double hi) { return seeded::uniform(seed ^ 0x511de5ULL, ++i, lo, hi); };
  auto sg = [&] { return u(0.0, 1.0) < 0.5 ? -1.0 : 1.0; };
  s.y_scale = sg() * u(20e-6, 50e-6);
  s.z_scale = sg() * u(20e-6, 50e-6);
  s.squareness = sg() * u(200e-6, 300e-6);
  s.y_bow_per_mm = sg() * u(20e-3, 35e-3) / (100.0 * 100.0);
  s.z_bow_per_mm = sg() * u(20e-3, 35e-3) / (100.0 * 100.0);
  s.y_screw_mm = u(1.5e-3, 3e-3);
  s.y_screw_phase_rad = u(0.0, 2.0 * kPi);
  s.z_screw_mm = u(1.5e-3, 3e-3);
  s.z_screw_phase_rad = u(0.0, 2.0 * kPi);
  s.y_lag_ms = u(1.0, 3.0);
  s.z_lag_ms = s.y_lag_ms + sg() * u(0.05, 0.2);
  s.y_backlash_um = u(1.0, 3.0);
  s.z_backlash_um = u(1.0, 3.0);
  return s;
}

BallbarTest run_ballbar(const SlideErrors& slides, const std::vector<SlideCompensationTable>& tables, double radius_mm,
                        double feed_mm_per_min, double rate_hz, std::uint64_t measurement) {
  BallbarTest t;
  t.radius_mm = radius_mm;
  t.feed_mm_per_min = feed_mm_per_min;
  const double v = feed_mm_per_min / 60.0;  // mm/s along the path
  const double step_rad = v / rate_hz / radius_mm;
  const int samples = static_cast<int>(std::floor(2.0 * kPi / step_rad));
  // The set-up: the bar's centre cup where the axes stand when commanded to the circle's centre
  // (at rest: no lag; each drive's play as it last moved, towards the start of the circle).
  double cy = 0.0, cz = 0.0;
  slides.error_mm(0.0, 0.0, 1e-9, 0.0, tables, cy, cz);
  const std::uint64_t noise_seed = seeded::mix(slides.seed ^ seeded::mix(measurement + 0xba11ULL));
  std::uint64_t index = 0;
  for (const double d : {1.0, -1.0}) {
    BallbarCircle& c = d > 0.0 ? t.ccw : t.cw;
    c.radius_mm = radius_mm;
    for (int k = 0; k < samples; ++k) {
      const double a = d * k * step_rad;
      const double y = radius_mm * std::cos(a), z = radius_mm * std::sin(a);
      const double vy = -d * v * std::sin(a), vz = d * v * std::cos(a);
      double ey = 0.0, ez = 0.0;
      slides.error_mm(y, z, vy, vz, tables, ey, ez);
      // The bar's length: from the centre cup to where the ball stands, less the radius.
      const double length = std::hypot(y + ey - cy, z + ez - cz);
      double angle = std::fmod(a * 180.0 / kPi, 360.0);
      if (angle < 0.0) angle += 360.0;
      c.angle_deg.push_back(angle);
      c.radial_um.push_back((length - radius_mm) * 1000.0 + slides.bar_noise_um * seeded::normal(noise_seed, ++index));
    }
  }
  return t;
}

}  // namespace gaugeloop
