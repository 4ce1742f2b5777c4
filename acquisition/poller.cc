// The poller's settings checked, its run timeout, and the run handed to the collector of its
// mode (live_collector.cc, latched_collector.cc).
#include "acquisition/poller.h"

#include <sys/prctl.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <utility>

#include "acquisition/collector.h"

namespace gaugeloop {

std::string_view sampling_mode_name(SamplingMode mode) { return mode == SamplingMode::kLive ? "live" : "latched"; }

std::string format_degree_ranges(const std::vector<int>& degrees) {
  if (degrees.empty()) return "none";
  std::string out;
  size_t i = 0;
  while (i < degrees.size()) {
    size_t j = i;
    while (j + 1 < degrees.size() && degrees[j + 1] == degrees[j] + 1) ++j;
    if (!out.empty()) out += ", ";
    out += std::to_string(degrees[i]);
    if (j > i) out += "-" + std::to_string(degrees[j]);
    i = j + 1;
  }
  return out;
}

std::chrono::milliseconds run_timeout_at(const PollerSettings& s, double speed_rpm) {
  if (s.run_timeout.count() > 0) return s.run_timeout;
  if (!(speed_rpm > 0.0)) return kRunTimeoutFloor;
  const int revolutions = s.revolutions + s.spare_revolutions + 2;
  const auto ms = static_cast<std::int64_t>(std::ceil(revolutions * 60000.0 / speed_rpm));
  return std::max(kRunTimeoutFloor, std::chrono::milliseconds(ms));
}

Status validate(const PollerSettings& s) {
  if (s.revolutions < 3) {
    return make_error(ErrorCode::kInvalidInput,
                      "revolutions = " + std::to_string(s.revolutions) +
                          ": a run needs at least 3 revolutions to average and to judge repeatability");
  }
  if (!(s.max_interpolation_gap_deg > 0.0 && s.max_interpolation_gap_deg <= 5.0)) {
    return make_error(ErrorCode::kInvalidInput, "max_interpolation_gap_deg must be in (0, 5]");
  }
  if (!(s.poll_step_deg >= 0.0 && s.poll_step_deg < s.max_interpolation_gap_deg)) {
    return make_error(ErrorCode::kInvalidInput, "poll_step_deg must be in [0, max_interpolation_gap_deg)");
  }
  if (s.spare_revolutions < 0 || s.max_attempts < 1 || s.patience_revolutions < 0) {
    return make_error(ErrorCode::kInvalidInput,
                      "spare_revolutions and patience_revolutions must be >= 0 and max_attempts >= 1");
  }
  if (s.run_timeout.count() < 0) return make_error(ErrorCode::kInvalidInput, "run_timeout must be >= 0 (0: derived)");
  return {};
}

Poller::Poller(GaugeClient& gauge, PollerSettings settings, Clock& clock)
    : gauge_(gauge), settings_(std::move(settings)), clock_(clock) {}

Result<MeasuredRun> Poller::measure() {
  if (Status s = validate(settings_); !s) return s.error();
  // Pacing sleeps are short; the default 50 us timer slack would stretch them. The thread's
  // own slack is given back after the run: the thread may go on to other work.
  const int slack_before_ns = ::prctl(PR_GET_TIMERSLACK, 0UL, 0UL, 0UL, 0UL);
  ::prctl(PR_SET_TIMERSLACK, 1000UL, 0UL, 0UL, 0UL);
  const CollectorContext context{gauge_, settings_, clock_, on_revolution_};
  Result<MeasuredRun> run = settings_.mode == SamplingMode::kLive ? collect_live(context) : collect_latched(context);
  if (slack_before_ns > 0) ::prctl(PR_SET_TIMERSLACK, static_cast<unsigned long>(slack_before_ns), 0UL, 0UL, 0UL);
  return run;
}

}  // namespace gaugeloop
