// Which error a stored run's verdicts judge.
#include "report/judged_error.h"

#include <algorithm>
#include <cmath>

#include "compensation/judgement.h"
#include "report/run_json.h"

namespace gaugeloop {
namespace {

bool all_zero(const DegreeTable& t) {
  return std::all_of(t.begin(), t.end(), [](double v) { return v == 0.0; });
}

const Characteristic* find_key(const std::vector<Characteristic>& cs, const std::string& key) {
  for (const Characteristic& c : cs) {
    if (c.key == key) return &c;
  }
  return nullptr;
}

}  // namespace

JudgedError judged_error(const StoredRun& run) {
  const LobeAnalysis& a = run.analysis;
  JudgedError j;
  if (run_part(run).pin()) {
    j.basis = JudgedError::Basis::kLeastSquaresCircle;
    j.error_um = a.residual_error_um;
    j.raw_error_um = a.error_um;
    j.name = "radius error less the least-squares circle";
    j.reference = judged_reference_text(PartKind::kPin, LiftErrorReference::kBestFit);
  } else if (run.lift_error_reference == LiftErrorReference::kNominal) {
    j.basis = JudgedError::Basis::kNominal;
    j.error_um = a.error_um;
    j.name = "lift error at nominal timing";
    j.reference = judged_reference_text(PartKind::kLobe, LiftErrorReference::kNominal);
  } else if (all_zero(a.residual_error_um) && !all_zero(a.error_um)) {
    // Stored before the best-fit error was kept: the raw error is all there is.
    j.basis = JudgedError::Basis::kNominalNoBestFit;
    j.error_um = a.error_um;
    j.name = "lift error at nominal timing (the run kept no best-fit error)";
    j.reference = judged_reference_text(PartKind::kLobe, LiftErrorReference::kNominal);
  } else {
    j.error_um = judged_lift_error_um(a, LiftErrorReference::kBestFit);
    j.raw_error_um = a.error_um;
    j.name = "lift error after the best-fit phase";
    j.reference = judged_reference_text(PartKind::kLobe, LiftErrorReference::kBestFit);
  }
  double sum_sq = 0.0;
  double lo = j.error_um[0];
  double hi = j.error_um[0];
  std::size_t worst = 0;
  for (std::size_t d = 0; d < j.error_um.size(); ++d) {
    const double v = j.error_um[d];
    sum_sq += v * v;
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    if (std::abs(v) > std::abs(j.error_um[worst])) worst = d;
  }
  j.max_abs_at_deg = signed_degree(worst);
  j.max_abs_um = std::abs(j.error_um[worst]);
  j.rms_um = std::sqrt(sum_sq / static_cast<double>(j.error_um.size()));
  j.peak_to_valley_um = hi - lo;
  return j;
}

DegreeLimits limits_per_degree(const std::vector<Characteristic>& characteristics, const std::string& figure) {
  DegreeLimits out{};
  if (const Characteristic* whole = find_key(characteristics, figure)) out.fill(whole->limits);
  for (const Characteristic& c : characteristics) {
    if (c.key.rfind(figure + ".", 0) != 0 || !c.limits.any() || !c.from_deg || !c.to_deg) continue;
    const int from = *c.from_deg;
    const int to = *c.to_deg;
    for (int x = -179; x <= 180; ++x) {
      const bool inside = from <= to ? (x >= from && x <= to) : (x >= from || x <= to);
      if (!inside) continue;
      // The whole turn's limits hold at every degree, the zone's as well: the narrower of each.
      Limits& l = out[static_cast<std::size_t>(x + 179)];
      if (c.limits.lower) l.lower = l.lower ? std::max(*l.lower, *c.limits.lower) : *c.limits.lower;
      if (c.limits.upper) l.upper = l.upper ? std::min(*l.upper, *c.limits.upper) : *c.limits.upper;
    }
  }
  return out;
}

DegreeLimits limits_per_cam_degree(const std::vector<Characteristic>& characteristics, const std::string& figure) {
  const DegreeLimits nose_centred = limits_per_degree(characteristics, figure);
  DegreeLimits out{};
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    const int x = d <= 180 ? d : d - kDegreesPerRevolution;
    out[static_cast<std::size_t>(d)] = nose_centred[static_cast<std::size_t>(x + 179)];
  }
  return out;
}

std::string_view judged_reference_text(PartKind kind, LiftErrorReference reference) {
  if (kind == PartKind::kPin) return "less LS circle";
  return reference == LiftErrorReference::kNominal ? "at nominal timing" : "after best-fit phase";
}

bool judges_error_curve(const std::string& key, PartKind kind) {
  if (kind == PartKind::kPin) return key == "roundness";
  if (kind != PartKind::kLobe) return false;
  for (const char* figure : {"lift_error", "velocity_error", "acceleration_error"}) {
    const std::string f = figure;
    if (key == f || key.rfind(f + ".", 0) == 0) return true;
  }
  return false;
}

}  // namespace gaugeloop
