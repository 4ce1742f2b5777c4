// A run's time budget, the spindle's rate and the freeze watch.
#include "acquisition/run_watches.h"

#include "core/number_text.h"

namespace gaugeloop {

Clock::duration RunBudget::revolution() const {
  if (rev_per_s_ <= 0.0) return Clock::duration::zero();
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rev_per_s_));
}

std::string RunBudget::timeout_text() const {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(run_timeout()).count();
  std::string why = "the spindle speed was never seen";
  if (s_.run_timeout.count() > 0) {
    why = "as set";
  } else if (rev_per_s_ > 0.0) {
    why = std::to_string(s_.revolutions + s_.spare_revolutions + 2) + " revolutions at " +
          format_fixed(rev_per_s_ * 60.0, 1) + " rpm, at least " + std::to_string(kRunTimeoutFloor.count() / 1000) +
          " s";
  }
  return "run timed out after " + std::to_string(ms) + " ms (" + why + ")";
}

bool RateWatch::observe(Clock::time_point now, double progress) {
  if (!origin_) {
    origin_ = {now, progress};
    return false;
  }
  if (now - origin_->first <= baseline_ || progress < origin_->second + kMinProgress) return false;
  per_s_ = (progress - origin_->second) / std::chrono::duration<double>(now - origin_->first).count();
  return true;
}

bool FreezeWatch::stale(Clock::time_point now) {
  if (outage_ || now - since_ <= s_.stale_after) return false;
  ++periods_;
  since_ = now;
  return true;
}

}  // namespace gaugeloop
