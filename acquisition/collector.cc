// The run state and the steps both collectors share.
#include "acquisition/collector.h"

#include <utility>
#include <vector>

namespace gaugeloop {
namespace {

LinkPolicy link_policy(const PollerSettings& s) { return {s.max_attempts, s.backoff_initial, s.backoff_max}; }

std::vector<int> degrees_of(const std::bitset<kDegreesPerRevolution>& set, bool value) {
  std::vector<int> out;
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    if (set.test(static_cast<size_t>(d)) == value) out.push_back(d);
  }
  return out;
}

// Why a revolution was discarded: what broke it, the status it was read with, the degrees
// it lacks; e.g. "gauge status over-range at degrees 100-359; missing degrees 200-210".
std::string discard_reason(const RevolutionInProgress& rev, const GaugeClient& gauge) {
  std::string out = rev.broken;
  auto add = [&out](const std::string& part) { out += (out.empty() ? "" : "; ") + part; };
  if (rev.bad_status.any()) {
    add("gauge status " + gauge.describe_status(rev.bad_status_seen) + " at degrees " +
        format_degree_ranges(degrees_of(rev.bad_status, true)));
  }
  if (!rev.filled.all()) add("missing degrees " + format_degree_ranges(degrees_of(rev.filled, false)));
  return out;
}

}  // namespace

// The budget and the freeze watch read the clock in this order, as members are initialised.
Collector::Collector(const CollectorContext& context)
    : gauge_(context.gauge),
      settings_(context.settings),
      clock_(context.clock),
      on_revolution_(context.on_revolution),
      wanted_(context.settings.revolutions),
      link_(context.gauge, link_policy(context.settings), context.clock),
      budget_(context.settings, context.clock.now()),
      freeze_(context.settings, context.clock.now()) {}

std::string Collector::where_now() const {
  return "during revolution " + std::to_string(run_.revolutions.size() + 1) + " of " + std::to_string(wanted_);
}

void Collector::finish_revolution(std::int64_t number, const RevolutionInProgress& rev) {
  if (!rev.usable()) {
    count_discarded(number, discard_reason(rev, gauge_));
    return;
  }
  run_.revolutions.push_back(RevolutionSamples{number, rev.lift_mm});
  if (on_revolution_) on_revolution_(static_cast<int>(run_.revolutions.size()));
}

void Collector::count_discarded(std::int64_t number, const std::string& why) {
  ++run_.discarded_revolutions;
  last_discard_ = "revolution " + std::to_string(number) + ": " + why;
}

MeasuredRun Collector::finished() {
  run_.reconnects = link_.reconnects();
  return std::move(run_);
}

Error Collector::too_many_discarded(const char* advice) const {
  return make_error(ErrorCode::kIncompleteRun, "only " + std::to_string(run_.revolutions.size()) + " of " +
                                                   std::to_string(wanted_) + " revolutions were complete, " +
                                                   std::to_string(run_.discarded_revolutions) +
                                                   " discarded; last discarded " + last_discard_ + ". " + advice);
}

Error Collector::timed_out() const {
  return make_error(ErrorCode::kIncompleteRun, budget_.timeout_text() + " " + where_now() +
                                                   (last_discard_.empty() ? "" : "; last discarded " + last_discard_));
}

Error Collector::frozen(const std::string& what_stood_still) const {
  return make_error(ErrorCode::kGaugeTimeout,
                    "the gauge at " + gauge_.address() + " stood still " + where_now() + ": " + what_stood_still +
                        " for " + std::to_string(freeze_.frozen_for().count()) +
                        " ms while the link answered (frozen amplifier or stopped spindle); no run was stored");
}

}  // namespace gaugeloop
