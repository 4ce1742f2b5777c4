// Text for gauge status words.
#include "acquisition/gauge_client.h"

namespace gaugeloop {

std::string describe_gauge_status(std::uint16_t status) {
  std::string out;
  auto add = [&out](const char* what) {
    if (!out.empty()) out += ", ";
    out += what;
  };
  if ((status & kGaugeReady) == 0) add("not ready");
  if (status & kGaugeOverRange) add("over-range");
  if (status & kGaugeUnderRange) add("under-range");
  if (status & kGaugeProbeMissing) add("probe missing");
  return out.empty() ? "ok" : out;
}

}  // namespace gaugeloop
