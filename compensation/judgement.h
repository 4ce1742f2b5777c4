// A run judged against its lobe's tolerances: the characteristics a cam inspection report
// lists, each with its limits and verdict, and the run's verdict.
#pragma once

#include <vector>

#include "compensation/inspection.h"
#include "core/result.h"
#include "core/run.h"
#include "core/tolerance.h"

namespace gaugeloop {

// A zone as judged: the whole cam degrees it covers (cam frame, nose at 0), an arc from
// from_deg up to to_deg in (-180, 180].
struct ZoneArc {
  LobeZone zone = LobeZone::kBaseCircle;
  int from_deg = 0;
  int to_deg = 0;
  std::vector<int> degrees;  // in [0, 360), in order along the arc
};

// The arcs of the tolerances' zones on this design (design_lift_mm: the flat-probe reading
// of the design, cam frame, LobeAnalysis::design_lift_mm). Errors (kInvalidInput): a zone
// holding no whole degree; two zones sharing a degree; a zone by lift whose degrees are not
// one arc (name the zone and say to define it by angle).
Result<std::vector<ZoneArc>> zone_arcs(const LobeTolerances& tolerances, const DegreeTable& design_lift_mm);

// The lift error table the tolerances judge: residual_error_um (best fit) or error_um.
const DegreeTable& judged_lift_error_um(const LobeAnalysis& analysis, LiftErrorReference reference);

struct LobeJudgement {
  // In this order: lift_error, then lift_error.<zone> for each zone (in LobeZone order),
  // velocity_error and its zones, acceleration_error and its zones, phase,
  // base_circle_runout, base_circle_runout_h1, roundness.
  std::vector<Characteristic> characteristics;
  Verdict verdict = Verdict::kNotJudged;
};

// Every characteristic of the run, judged where the tolerances give limits: whole-turn lift,
// velocity and acceleration error of the judged table (derivatives by error_derivatives with
// `settings`), the same per zone, phase, base-circle runout (dial and first harmonic) and
// roundness. Every figure is given, judged or not (so SPC sees the same keys on every run);
// base_circle_runout_h1 is never judged (the dial figure is). Errors: those of zone_arcs and
// error_derivatives.
Result<LobeJudgement> judge_lobe(const LobeAnalysis& analysis, const LobeTolerances& tolerances,
                                 const InspectionSettings& settings = {});

}  // namespace gaugeloop
