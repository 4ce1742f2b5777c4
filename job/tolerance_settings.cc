// Canonical settings lines of a lobe's tolerances.
#include "job/tolerance_settings.h"

#include <algorithm>
#include <charconv>
#include <optional>

namespace gaugeloop {
namespace {

// Shortest fixed-point text that reads back to the same double ("0.0005", not "5e-04");
// never locale-dependent.
std::string exact(double v) {
  if (v == 0.0) v = 0.0;  // no "-0"
  char buf[400];          // fixed notation of the largest double fits
  const auto res = std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed);
  return std::string(buf, res.ptr);
}

std::string bound(const std::optional<double>& v) { return v ? exact(*v) : "none"; }

bool judges_anything(const LobeTolerances& t) {
  if (t.lift_error_um.any() || t.velocity_error_mm_per_deg.any() || t.acceleration_error_mm_per_deg2.any() ||
      t.phase_deg.any() || t.base_circle_runout_um.any() || t.roundness_um.any()) {
    return true;
  }
  return std::any_of(t.zones.begin(), t.zones.end(), [](const ZoneTolerance& z) {
    return z.lift_error_um.any() || z.velocity_error_mm_per_deg.any() || z.acceleration_error_mm_per_deg2.any();
  });
}

// `key = lower upper` when `l` has a bound.
void append_limits(std::string& out, const std::string& key, const Limits& l) {
  if (l.any()) out += key + " = " + bound(l.lower) + " " + bound(l.upper) + "\n";
}

}  // namespace

std::string tolerances_settings_text(const PinTolerances& t) {
  std::string out;
  append_limits(out, "tolerance.roundness_um", t.roundness_um);
  append_limits(out, "tolerance.diameter_error_um", t.diameter_error_um);
  append_limits(out, "tolerance.stroke_error_um", t.stroke_error_um);
  append_limits(out, "tolerance.index_error_deg", t.index_error_deg);
  return out;
}

std::string tolerances_settings_text(const LobeTolerances& t) {
  if (!judges_anything(t)) return {};
  std::string out;
  auto line = [&out](const std::string& key, const std::string& value) { out += key + " = " + value + "\n"; };
  auto limits = [&out](const std::string& key, const Limits& l) { append_limits(out, key, l); };
  line("tolerance.lift_error", std::string(lift_error_reference_name(t.lift_error_reference)));
  limits("tolerance.lift_error_um", t.lift_error_um);
  limits("tolerance.velocity_error_mm_per_deg", t.velocity_error_mm_per_deg);
  limits("tolerance.acceleration_error_mm_per_deg2", t.acceleration_error_mm_per_deg2);
  limits("tolerance.phase_deg", t.phase_deg);
  limits("tolerance.base_circle_runout_um", t.base_circle_runout_um);
  limits("tolerance.roundness_um", t.roundness_um);
  for (LobeZone zone : kLobeZones) {
    for (const ZoneTolerance& z : t.zones) {
      if (z.zone != zone) continue;
      const std::string key = "tolerance.zone." + std::string(lobe_zone_name(zone)) + ".";
      if (z.by_lift) {
        line(key + "lift_mm", exact(z.from_lift_mm) + " " + exact(z.to_lift_mm));
      } else {
        line(key + "angle_deg", exact(z.from_deg) + " " + exact(z.to_deg));
      }
      limits(key + "lift_error_um", z.lift_error_um);
      limits(key + "velocity_error_mm_per_deg", z.velocity_error_mm_per_deg);
      limits(key + "acceleration_error_mm_per_deg2", z.acceleration_error_mm_per_deg2);
    }
  }
  return out;
}

}  // namespace gaugeloop
