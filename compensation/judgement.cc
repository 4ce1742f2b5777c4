// judge_lobe: figures per zone of the judged lift error and its derivatives.
#include "compensation/judgement.h"

namespace gaugeloop {

const DegreeTable& judged_lift_error_um(const LobeAnalysis& analysis, LiftErrorReference reference) {
  return reference == LiftErrorReference::kNominal ? analysis.error_um : analysis.residual_error_um;
}

Result<std::vector<ZoneArc>> zone_arcs(const LobeTolerances&, const DegreeTable&) {
  return std::vector<ZoneArc>{};  // TODO
}

Result<LobeJudgement> judge_lobe(const LobeAnalysis&, const LobeTolerances&, const InspectionSettings&) {
  return LobeJudgement{};  // TODO
}

}  // namespace gaugeloop
