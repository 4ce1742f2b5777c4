// Names of the helix hands and the flanks; the heights a lead is measured at and its alignment.
#include "core/gear.h"

#include <cmath>

namespace gaugeloop {

std::string_view hand_name(Hand hand) { return hand == Hand::kRight ? "right" : "left"; }

std::string_view flank_name(Flank flank) { return flank == Flank::kLeft ? "left" : "right"; }

std::vector<double> lead_heights_mm(const GearGeometry& gear, double step_mm) {
  std::vector<double> z;
  const int n = static_cast<int>(std::floor(gear.face_width_mm / step_mm + 1e-9)) + 1;
  for (int i = 0; i < n; ++i) z.push_back(-gear.face_width_mm / 2.0 + i * step_mm);
  return z;
}

void align_on_tooth(std::vector<double>& deviation_um) {
  if (deviation_um.empty()) return;
  double mean = 0.0;
  for (double d : deviation_um) mean += d;
  mean /= static_cast<double>(deviation_um.size());
  for (double& d : deviation_um) d -= mean;
}

void align_on_tooth(LeadTrace& trace) { align_on_tooth(trace.deviation_um); }

std::optional<Hand> hand_from_name(std::string_view name) {
  if (name == "right") return Hand::kRight;
  if (name == "left") return Hand::kLeft;
  return std::nullopt;
}

}  // namespace gaugeloop
