// Text for gauge status words.
#include "acquisition/gauge_client.h"

namespace gaugeloop {

std::string describe_gauge_status(GaugeStatus status, const StatusBitNames* bit_names) {
  std::string out;
  auto add = [&out](const std::string& what) {
    if (!out.empty()) out += ", ";
    out += what;
  };
  if ((status & kGaugeReady) == 0) add("not ready");
  if (status & kGaugeOverRange) add("over-range");
  if (status & kGaugeUnderRange) add("under-range");
  if (status & kGaugeProbeMissing) add("probe missing");
  for (int bit = 0; bit < 16; ++bit) {
    if (((status >> 16) & (1u << bit)) == 0) continue;
    const std::string* name = bit_names != nullptr ? &(*bit_names)[static_cast<size_t>(bit)] : nullptr;
    add(name != nullptr && !name->empty() ? *name : "status bit " + std::to_string(bit));
  }
  return out.empty() ? "ok" : out;
}

}  // namespace gaugeloop
