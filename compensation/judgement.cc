// judge_lobe: figures per zone of the judged lift error and its derivatives.
#include "compensation/judgement.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/number_text.h"

namespace gaugeloop {
namespace {

std::string zone_where(const ZoneTolerance& z) {
  std::string what = "tolerance zone " + std::string(lobe_zone_name(z.zone));
  if (z.by_lift) {
    return what + " (lift " + format_fixed(z.from_lift_mm, 3) + " to " + format_fixed(z.to_lift_mm, 3) + " mm)";
  }
  return what + " (" + format_fixed(z.from_deg, 1) + " to " + format_fixed(z.to_deg, 1) + " deg)";
}

// The whole degrees of the zone, as a membership table.
std::array<bool, kDegreesPerRevolution> zone_members(const ZoneTolerance& z, const DegreeTable& design_lift_mm) {
  std::array<bool, kDegreesPerRevolution> in{};
  if (z.by_lift) {
    const bool opening_side = z.zone == LobeZone::kOpeningRamp || z.zone == LobeZone::kOpeningFlank;
    const bool closing_side = z.zone == LobeZone::kClosingRamp || z.zone == LobeZone::kClosingFlank;
    for (int d = 0; d < kDegreesPerRevolution; ++d) {
      const int x = signed_degree(d);
      if (opening_side && x > 0) continue;
      if (closing_side && x < 0) continue;
      const double lift = design_lift_mm[static_cast<size_t>(d)];
      in[static_cast<size_t>(d)] = lift >= z.from_lift_mm && lift < z.to_lift_mm;
    }
    return in;
  }
  double end = z.to_deg;
  while (end < z.from_deg) end += kDegreesPerRevolution;
  if (end - z.from_deg >= kDegreesPerRevolution) {
    in.fill(true);
    return in;
  }
  for (int d = static_cast<int>(std::ceil(z.from_deg)); d <= end; ++d) in[degree_index(d)] = true;
  return in;
}

// The signed extreme and the range of `table` over `degrees`.
Characteristic figure(std::string key, std::string unit, const DegreeTable& table, const std::vector<int>& degrees,
                      const Limits& limits) {
  Characteristic c;
  c.key = std::move(key);
  c.unit = std::move(unit);
  c.min = c.max = table[static_cast<size_t>(degrees.front())];
  for (int d : degrees) {
    c.min = std::min(c.min, table[static_cast<size_t>(d)]);
    c.max = std::max(c.max, table[static_cast<size_t>(d)]);
  }
  c.value = std::abs(c.max) >= std::abs(c.min) ? c.max : c.min;
  c.limits = limits;
  c.verdict = judge(c.min, c.max, limits);
  return c;
}

}  // namespace

const DegreeTable& judged_lift_error_um(const LobeAnalysis& analysis, LiftErrorReference reference) {
  return reference == LiftErrorReference::kNominal ? analysis.error_um : analysis.residual_error_um;
}

Result<std::vector<ZoneArc>> zone_arcs(const LobeTolerances& tolerances, const DegreeTable& design_lift_mm) {
  std::vector<ZoneArc> arcs;
  std::array<const ZoneTolerance*, kDegreesPerRevolution> owner{};
  std::vector<const ZoneTolerance*> zones;
  for (const ZoneTolerance& z : tolerances.zones) zones.push_back(&z);
  std::stable_sort(zones.begin(), zones.end(),
                   [](const ZoneTolerance* a, const ZoneTolerance* b) { return a->zone < b->zone; });
  for (const ZoneTolerance* z : zones) {
    const std::array<bool, kDegreesPerRevolution> in = zone_members(*z, design_lift_mm);
    ZoneArc arc;
    arc.zone = z->zone;
    int starts = 0;
    int start = 0;
    int count = 0;
    for (int d = 0; d < kDegreesPerRevolution; ++d) {
      if (!in[static_cast<size_t>(d)]) continue;
      ++count;
      if (!in[degree_index(d - 1)]) {
        ++starts;
        start = d;
      }
    }
    if (count == 0) {
      return make_error(ErrorCode::kInvalidInput, zone_where(*z) +
                                                      " holds no whole cam degree of this lobe; widen it or "
                                                      "remove it from the part file's [tolerance]");
    }
    if (starts > 1) {
      return make_error(ErrorCode::kInvalidInput, zone_where(*z) + " covers " + std::to_string(starts) +
                                                      " separate arcs of this lobe's design lift; define it by "
                                                      "angle_deg instead of lift_mm");
    }
    for (int i = 0; i < count; ++i) {
      const int d = static_cast<int>(degree_index(start + i));
      if (const ZoneTolerance* other = owner[static_cast<size_t>(d)]) {
        return make_error(ErrorCode::kInvalidInput, zone_where(*z) + " and " + zone_where(*other) +
                                                        " share cam degree " + std::to_string(signed_degree(d)) +
                                                        "; zones must not overlap: move their bounds apart");
      }
      owner[static_cast<size_t>(d)] = z;
      arc.degrees.push_back(d);
    }
    arc.from_deg = signed_degree(arc.degrees.front());
    arc.to_deg = signed_degree(arc.degrees.back());
    arcs.push_back(std::move(arc));
  }
  return arcs;
}

Result<LobeJudgement> judge_lobe(const LobeAnalysis& analysis, const LobeTolerances& tolerances,
                                 const InspectionSettings& settings) {
  const DegreeTable& lift_error = judged_lift_error_um(analysis, tolerances.lift_error_reference);
  Result<ErrorDerivatives> derivatives = error_derivatives(lift_error, settings);
  if (!derivatives) return derivatives.error();
  Result<std::vector<ZoneArc>> arcs = zone_arcs(tolerances, analysis.design_lift_mm);
  if (!arcs) return arcs.error();

  std::vector<int> all(kDegreesPerRevolution);
  for (int d = 0; d < kDegreesPerRevolution; ++d) all[static_cast<size_t>(d)] = d;
  struct Table {
    const char* key;
    const char* unit;
    const DegreeTable& values;
    Limits LobeTolerances::*whole;
    Limits ZoneTolerance::*zone;
  };
  const Table tables[] = {
      {"lift_error", "um", lift_error, &LobeTolerances::lift_error_um, &ZoneTolerance::lift_error_um},
      {"velocity_error", "mm/deg", derivatives->velocity_error_mm_per_deg, &LobeTolerances::velocity_error_mm_per_deg,
       &ZoneTolerance::velocity_error_mm_per_deg},
      {"acceleration_error", "mm/deg^2", derivatives->acceleration_error_mm_per_deg2,
       &LobeTolerances::acceleration_error_mm_per_deg2, &ZoneTolerance::acceleration_error_mm_per_deg2},
  };
  LobeJudgement out;
  for (const Table& t : tables) {
    out.characteristics.push_back(figure(t.key, t.unit, t.values, all, tolerances.*t.whole));
    for (const ZoneArc& arc : *arcs) {
      const auto zone = std::find_if(tolerances.zones.begin(), tolerances.zones.end(),
                                     [&](const ZoneTolerance& z) { return z.zone == arc.zone; });
      Characteristic c = figure(std::string(t.key) + "." + std::string(lobe_zone_name(arc.zone)), t.unit, t.values,
                                arc.degrees, (*zone).*t.zone);
      c.from_deg = arc.from_deg;
      c.to_deg = arc.to_deg;
      out.characteristics.push_back(std::move(c));
    }
  }
  out.characteristics.push_back(single_characteristic("phase", "deg", analysis.phase_error_deg, tolerances.phase_deg));
  out.characteristics.push_back(
      single_characteristic("base_circle_runout", "um", analysis.dial_runout_um, tolerances.base_circle_runout_um));
  out.characteristics.push_back(
      single_characteristic("base_circle_runout_h1", "um", analysis.base_circle_runout_um, Limits{}));
  out.characteristics.push_back(
      single_characteristic("roundness", "um", analysis.roundness_um, tolerances.roundness_um));
  std::vector<Verdict> verdicts;
  for (const Characteristic& c : out.characteristics) verdicts.push_back(c.verdict);
  out.verdict = combined_verdict(verdicts);
  return out;
}

}  // namespace gaugeloop
