// Names of the helix hands.
#include "core/gear.h"

namespace gaugeloop {

std::string_view hand_name(Hand hand) { return hand == Hand::kRight ? "right" : "left"; }

std::string_view flank_name(Flank flank) { return flank == Flank::kLeft ? "left" : "right"; }

void align_on_tooth(LeadTrace& trace) {
  if (trace.deviation_um.empty()) return;
  double mean = 0.0;
  for (double d : trace.deviation_um) mean += d;
  mean /= static_cast<double>(trace.deviation_um.size());
  for (double& d : trace.deviation_um) d -= mean;
}

std::optional<Hand> hand_from_name(std::string_view name) {
  if (name == "right") return Hand::kRight;
  if (name == "left") return Hand::kLeft;
  return std::nullopt;
}

}  // namespace gaugeloop
