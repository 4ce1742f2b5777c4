// Live mode: polls the gauge's snapshot and fills each whole degree between the polls around
// it, keeping or discarding whole revolutions.
#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "acquisition/collector.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

// Live mode fills a gap between two polls by a straight line only up to this length.
constexpr double kLinearGapDeg = 0.5;
// Progress is the angle passing the last point of progress by this much: an encoder dithers
// by a count or so on a stopped spindle.
constexpr double kStandstillDeg = 0.5;

// One usable poll, on the unwrapped angle axis: u = revolution * 360 + angle.
struct Poll {
  double u_deg = 0.0;
  double reading_mm = 0.0;
  std::uint16_t sequence = 0;
  GaugeStatus status = 0;
};

// The revolution a whole unwrapped degree t belongs to (floor division, also below 0).
std::int64_t revolution_of(std::int64_t t) { return t >= 0 ? t / 360 : (t - 359) / 360; }

// Unwraps the amplifier's 16-bit revolution counter and the angle into the unwrapped angle
// u = revolution * 360 + angle. Amplifiers may update the counter a little after the angle
// wraps: up to kRevolutionLagDeg after it, an angle just past 0 with a counter that has not
// moved is the wrap the counter lags, not the encoder running a revolution backwards.
class RevolutionUnwrapper {
 public:
  static constexpr double kRevolutionLagDeg = 5.0;

  double unwrap(const GaugeSnapshot& snap) {
    if (last_u_) {
      count_ += static_cast<std::int16_t>(static_cast<std::uint16_t>(snap.revolution - last_raw_));
    } else {
      count_ = snap.revolution;
    }
    last_raw_ = snap.revolution;
    double u = static_cast<double>(count_) * 360.0 + snap.angle_deg;
    if (last_u_ && snap.angle_deg < kRevolutionLagDeg) {
      const double behind = *last_u_ - u;
      if (behind > 360.0 - 2.0 * kRevolutionLagDeg && behind < 360.0 + kRevolutionLagDeg) u += 360.0;
    }
    last_u_ = u;
    return u;
  }

 private:
  std::int64_t count_ = 0;
  std::uint16_t last_raw_ = 0;
  std::optional<double> last_u_;
};

class LiveCollector : private Collector {
 public:
  explicit LiveCollector(const CollectorContext& context) : Collector(context), last_new_sample_(clock_.now()) {}

  Result<MeasuredRun> run();

 private:
  // One poll: reconnect if the link is down, pace, read; a failed read ends the chain.
  Status poll_once();
  Status ensure_link();
  // Pacing, not synchronisation: wait until the spindle has turned about poll_step_deg.
  void pace();
  // A snapshot read: a new sample extends the run; a repeated or a standing one is no
  // progress. An error ends the run.
  Status take_snapshot(const GaugeSnapshot& snap);
  void update_rates(const Poll& cur, Clock::time_point now);
  // Marks every revolution touched by [from_u, to_u] as unusable.
  void break_span(double from_u, double to_u, const std::string& why);
  void fill_segment(const Poll* left, const Poll& a, const Poll& b, const Poll* right);
  void fill_ready(bool closing);
  void mark_status(double from_u, const Poll& cur);
  void take_poll(const Poll& cur);
  Status finish_behind(double u);
  void break_chain(const std::string& why);
  Status no_progress(Clock::time_point now, const std::string& what);

  std::map<std::int64_t, RevolutionInProgress> in_progress_;
  Poll prev_;  // the last new sample, valid when have_prev_
  bool have_prev_ = false;
  // The amplifier's sample number of the last poll, kept across reconnects: a sample seen
  // before a reconnect is no new sample after it.
  std::optional<std::uint16_t> last_sequence_;
  // When the sample number last changed: a stale period in which it changed is the spindle's,
  // whichever kind of poll meets its end (a poll faster than the amplifier reads the same
  // sample twice).
  std::optional<Clock::time_point> sequence_changed_at_;
  // The polls that form an unbroken chain: good status, moving forward, each within
  // max_interpolation_gap_deg of the one before. Segment chain_[pending_] -> chain_[pending_+1]
  // is the first whose degrees are not filled yet; it waits for a neighbour on its right (see
  // fill_ready). Polls more than 3 gaps behind it can no longer be a neighbour and are dropped.
  std::deque<Poll> chain_;
  size_t pending_ = 0;
  double filled_to_u_ = 0.0;  // degrees up to here have had their chance to be filled (set by the first poll)
  std::optional<std::int64_t> start_rev_;  // first revolution index we collect
  std::int64_t next_rev_ = 0;              // next revolution to keep or discard
  RevolutionUnwrapper unwrapper_;
  Clock::time_point last_new_sample_;
  double rate_deg_per_s_ = 0.0;  // spindle rate from successive new samples, smoothed: paces the polls
  RateWatch speed_{std::chrono::milliseconds(50)};  // unwrapped degrees per second, for the budget
  Clock::time_point last_poll_at_{};
  std::optional<double> progress_u_;  // the angle at the last progress
};

Result<MeasuredRun> LiveCollector::run() {
  while (!complete()) {
    if (budget_.timed_out(clock_.now())) return timed_out();
    if (Status s = poll_once(); !s) return s.error();
  }
  return finished();
}

Status LiveCollector::poll_once() {
  if (Status s = ensure_link(); !s) return s;
  pace();
  last_poll_at_ = clock_.now();
  Result<GaugeSnapshot> r = gauge_.read_snapshot();
  ++run_.polls;
  if (!r) {
    break_chain("link fault: " + r.error().message);
    freeze_.link_failed();
    return link_.failed(r.error(), where_now());
  }
  link_.succeeded();
  return take_snapshot(*r);
}

Status LiveCollector::ensure_link() {
  if (link_.state() == LinkState::kConnected && gauge_.connected()) return {};
  if (Status s = link_.ensure(where_now()); !s) return s;
  last_new_sample_ = clock_.now();
  return {};
}

void LiveCollector::pace() {
  if (!(settings_.poll_step_deg > 0.0 && rate_deg_per_s_ > 0.0)) return;
  const auto wait = std::chrono::duration<double>(settings_.poll_step_deg / rate_deg_per_s_);
  const auto capped = std::min<std::chrono::duration<double>>(wait, settings_.max_poll_interval);
  const auto due = last_poll_at_ + std::chrono::duration_cast<Clock::duration>(capped);
  if (due - clock_.now() > std::chrono::microseconds(20)) clock_.sleep_until(due);
}

Status LiveCollector::take_snapshot(const GaugeSnapshot& snap) {
  const auto now = clock_.now();
  freeze_.answered(now);
  const std::string angle_stayed = "its angle stayed at " + format_fixed(snap.angle_deg, 1) + " deg";
  if (last_sequence_ && snap.sequence == *last_sequence_) {
    // Same amplifier sample as last time: an amplifier whose sample number stops is frozen;
    // one that sampled in this stale period is not, the spindle stands.
    const bool sampled_this_period = sequence_changed_at_ && *sequence_changed_at_ > freeze_.period_began();
    return no_progress(
        now, sampled_this_period ? angle_stayed : "its sample number stayed at " + std::to_string(snap.sequence));
  }
  last_sequence_ = snap.sequence;
  sequence_changed_at_ = now;

  const Poll cur{unwrapper_.unwrap(snap), snap.reading_mm, snap.sequence, snap.status};
  if (!progress_u_ || cur.u_deg > *progress_u_ + kStandstillDeg) {
    progress_u_ = cur.u_deg;
    freeze_.progressed(now);
  } else if (Status s = no_progress(now, angle_stayed); !s) {
    return s;  // new samples, but the spindle stands (or turns backwards)
  }
  update_rates(cur, now);
  if (!start_rev_) {
    start_rev_ = static_cast<std::int64_t>(std::floor(cur.u_deg / 360.0)) + 1;
    next_rev_ = *start_rev_;
  }

  take_poll(cur);
  prev_ = cur;
  have_prev_ = true;
  return finish_behind(filled_to_u_);
}

void LiveCollector::update_rates(const Poll& cur, Clock::time_point now) {
  if (have_prev_ && cur.u_deg > prev_.u_deg) {
    const double dt_s = std::chrono::duration<double>(now - last_new_sample_).count();
    if (dt_s > 0.0) {
      const double rate = (cur.u_deg - prev_.u_deg) / dt_s;
      rate_deg_per_s_ = rate_deg_per_s_ > 0.0 ? 0.9 * rate_deg_per_s_ + 0.1 * rate : rate;
    }
  }
  if (speed_.observe(now, cur.u_deg)) {
    budget_.saw_speed(speed_.per_s() / 360.0);
    link_.set_patience(budget_.patience());
  }
  last_new_sample_ = now;
}

void LiveCollector::break_span(double from_u, double to_u, const std::string& why) {
  if (!start_rev_) return;
  const auto r0 = std::max<std::int64_t>(next_rev_, static_cast<std::int64_t>(std::floor(from_u / 360.0)));
  const auto r1 = static_cast<std::int64_t>(std::floor(to_u / 360.0));
  for (auto r = r0; r <= r1; ++r) {
    auto& rev = in_progress_[r];
    if (rev.broken.empty()) rev.broken = why;
  }
}

// Fills the whole degrees t with a.u < t <= b.u. The cubic through `left`, a, b and `right`
// is used when both neighbours are given (fill_ready finds them between h/3 and 3h from the
// segment, h = its length): then its error is about h^4/24 |H''''|, under 0.001 um at
// h = 1 deg on the sample lobes, and its weights stay under about 1.5, so noise is not
// amplified (clustered nodes would turn 0.3 um of noise into microns).
// Otherwise a segment up to kLinearGapDeg is filled linearly (error h^2/8 |H''|: 0.2 um at
// 0.5 deg on the intake nose), and a longer one stays missing.
void LiveCollector::fill_segment(const Poll* left, const Poll& a, const Poll& b, const Poll* right) {
  const double h = b.u_deg - a.u_deg;
  std::vector<const Poll*> support;
  if (left != nullptr && right != nullptr) {
    support = {left, &a, &b, right};
  } else if (h <= kLinearGapDeg) {
    support = {&a, &b};
  } else {
    return;  // no well-spaced support for a segment this long
  }
  for (auto t = static_cast<std::int64_t>(std::floor(a.u_deg)) + 1; t <= static_cast<std::int64_t>(std::floor(b.u_deg));
       ++t) {
    const std::int64_t r = revolution_of(t);
    if (r < next_rev_) continue;
    const int deg = static_cast<int>(t - r * 360);
    double value = 0.0;  // Lagrange form
    for (size_t i = 0; i < support.size(); ++i) {
      double w = 1.0;
      for (size_t j = 0; j < support.size(); ++j) {
        if (j != i) w *= (static_cast<double>(t) - support[j]->u_deg) / (support[i]->u_deg - support[j]->u_deg);
      }
      value += w * support[i]->reading_mm;
    }
    auto& rev = in_progress_[r];
    rev.lift_mm[deg] = value;
    rev.filled.set(static_cast<size_t>(deg));
  }
}

// Fills the pending segments in order. A segment a -> b of length h takes as neighbours
// the nearest polls at least h/3 beyond either end, if they lie within 3h: a long segment
// left by a stalled poll among dense polls reaches past its immediate neighbours for
// well-spaced ones. It waits until a poll h/3 beyond b has arrived, unless `closing`: the
// chain ends here, and its last segments are filled with the support they have.
void LiveCollector::fill_ready(bool closing) {
  while (pending_ + 1 < chain_.size()) {
    const Poll& a = chain_[pending_];
    const Poll& b = chain_[pending_ + 1];
    const double h = b.u_deg - a.u_deg;
    size_t j = pending_ + 2;
    while (j < chain_.size() && chain_[j].u_deg < b.u_deg + h / 3.0) ++j;
    if (j == chain_.size() && !closing) break;  // the right neighbour is still to come
    const Poll* right = j < chain_.size() && chain_[j].u_deg <= b.u_deg + 3.0 * h ? &chain_[j] : nullptr;
    const Poll* left = nullptr;
    for (size_t i = pending_; i-- > 0;) {
      if (chain_[i].u_deg <= a.u_deg - h / 3.0) {
        if (chain_[i].u_deg >= a.u_deg - 3.0 * h) left = &chain_[i];
        break;
      }
    }
    fill_segment(left, a, b, right);
    filled_to_u_ = b.u_deg;
    ++pending_;
  }
  if (closing) {
    chain_.clear();
    pending_ = 0;
    return;
  }
  while (pending_ > 0 && chain_.front().u_deg < chain_[pending_].u_deg - 3.0 * settings_.max_interpolation_gap_deg) {
    chain_.pop_front();
    --pending_;
  }
}

// A poll with a bad status: the whole degrees since the poll before it, or its own degree,
// were read with that status; their revolutions are discarded, naming it.
void LiveCollector::mark_status(double from_u, const Poll& cur) {
  if (!start_rev_) return;
  const auto last = static_cast<std::int64_t>(std::floor(cur.u_deg));
  const auto first = std::min(static_cast<std::int64_t>(std::floor(from_u)) + 1, last);
  for (auto t = first; t <= last; ++t) {
    const std::int64_t r = revolution_of(t);
    if (r >= next_rev_) in_progress_[r].mark_status(static_cast<int>(t - r * 360), cur.status);
  }
}

// Takes a new poll: extends the chain, or closes it and starts a new one.
void LiveCollector::take_poll(const Poll& cur) {
  const bool ok = gauge_status_ok(cur.status);
  if (!chain_.empty()) {
    const Poll last = chain_.back();
    if (ok && cur.u_deg == last.u_deg) return;  // a new sample at the same angle adds nothing
    const bool backwards = cur.u_deg < last.u_deg;
    const bool too_far = cur.u_deg - last.u_deg > settings_.max_interpolation_gap_deg;
    if (!ok || backwards || too_far) {
      fill_ready(/*closing=*/true);
      if (backwards) {
        break_span(cur.u_deg, last.u_deg,
                   "encoder angle went backwards from " + format_fixed(std::fmod(last.u_deg, 360.0), 1) + " to " +
                       format_fixed(std::fmod(cur.u_deg, 360.0), 1) + " deg");
      }  // too far: the degrees in between stay missing
    }
  }
  if (!ok) {
    mark_status(have_prev_ ? prev_.u_deg : cur.u_deg, cur);
    filled_to_u_ = std::max(filled_to_u_, cur.u_deg);
    return;
  }
  chain_.push_back(cur);
  if (chain_.size() == 1) filled_to_u_ = std::max(filled_to_u_, cur.u_deg);
  fill_ready(/*closing=*/false);
}

// Moves revolutions that lie wholly behind `u` out of in_progress_: kept or discarded.
Status LiveCollector::finish_behind(double u) {
  const auto current = static_cast<std::int64_t>(std::floor(u / 360.0));
  for (auto r = next_rev_; r < current && !complete(); ++r) {
    auto it = in_progress_.find(r);
    RevolutionInProgress rev = it == in_progress_.end() ? RevolutionInProgress{} : std::move(it->second);
    if (it != in_progress_.end()) in_progress_.erase(it);
    finish_revolution(r, rev);
    next_rev_ = r + 1;
  }
  if (run_.discarded_revolutions > settings_.spare_revolutions) {
    return too_many_discarded(
        "Check the gauge status, and that the link keeps up with the spindle (slower spindle, or latched mode)");
  }
  return {};
}

// Never interpolate across a gap in the polls: a failed read, or a frozen amplifier.
void LiveCollector::break_chain(const std::string& why) {
  if (have_prev_) break_span(prev_.u_deg, prev_.u_deg, why);
  have_prev_ = false;
  speed_.restart();
  fill_ready(/*closing=*/true);
}

// A poll without progress (`what` stood still). After stale_after the chain breaks and the
// link is reset (a stuck connection can look frozen); after the freeze watch's patience the
// run fails. An error ends the run.
Status LiveCollector::no_progress(Clock::time_point now, const std::string& what) {
  if (!freeze_.stale(now)) return {};
  if (freeze_.exhausted(budget_)) return frozen(what);
  break_chain("frozen amplifier or stopped spindle: " + what);
  return link_.failed(make_error(ErrorCode::kGaugeTimeout, what), where_now());
}

}  // namespace

Result<MeasuredRun> collect_live(const CollectorContext& context) { return LiveCollector(context).run(); }

}  // namespace gaugeloop
