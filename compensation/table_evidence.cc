// The evidence a part's lift error gives about the table that ground it.
#include "compensation/table_evidence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "compensation/correction.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

constexpr double kNotGroundBelowFraction = 0.5;  // of the table's change
constexpr double kCannotTellBelowNoises = 3.0;   // the table's change, in noise RMS

double rms(const DegreeTable& t) {
  double sum = 0.0;
  for (double v : t) sum += v * v;
  return std::sqrt(sum / static_cast<double>(t.size()));
}

// Variance of a run's mean error at one degree, averaged over the degrees.
double mean_error_variance(const MeasuredError& m) {
  const double spread_rms = rms(*m.spread_um);
  return spread_rms * spread_rms / static_cast<double>(m.revolutions < 1 ? 1 : m.revolutions);
}

}  // namespace

std::string_view table_evidence_verdict_name(TableEvidenceVerdict verdict) {
  switch (verdict) {
    case TableEvidenceVerdict::kGround:
      return "ground";
    case TableEvidenceVerdict::kNotGround:
      return "not ground";
    case TableEvidenceVerdict::kCannotTell:
      return "cannot tell";
  }
  return "?";
}

std::string TableEvidence::describe() const {
  return "the part differs from the one the table was built on by " + format_fixed(difference_rms_um, 2) +
         " um RMS; the table changed the lobe by " + format_fixed(change_rms_um, 2) +
         " um RMS; the gauge's noise alone would give " + format_fixed(noise_rms_um, 2) + " um RMS";
}

TableEvidence judge_table_evidence(const MeasuredError& now, const MeasuredError& before, const DegreeTable& change_um,
                                   int max_harmonic) {
  DegreeTable difference{};
  for (std::size_t d = 0; d < difference.size(); ++d) difference[d] = (*now.error_um)[d] - (*before.error_um)[d];
  TableEvidence e;
  e.difference_rms_um = rms(smooth_harmonics(difference, max_harmonic));
  e.change_rms_um = rms(change_um);
  const double kept = (2.0 * max_harmonic + 1.0) / static_cast<double>(kDegreesPerRevolution);
  e.noise_rms_um = std::sqrt((mean_error_variance(now) + mean_error_variance(before)) * std::min(1.0, kept));
  if (e.change_rms_um < kCannotTellBelowNoises * e.noise_rms_um) {
    e.verdict = TableEvidenceVerdict::kCannotTell;
  } else if (e.difference_rms_um < kNotGroundBelowFraction * e.change_rms_um) {
    e.verdict = TableEvidenceVerdict::kNotGround;
  } else {
    e.verdict = TableEvidenceVerdict::kGround;
  }
  return e;
}

}  // namespace gaugeloop
