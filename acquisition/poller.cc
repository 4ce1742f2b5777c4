// Live and latched collection of complete revolutions, with reconnects and whole-revolution
// rejection.
#include "acquisition/poller.h"
#include "core/number_text.h"

#include <sys/prctl.h>

#include <algorithm>
#include <bitset>
#include <cmath>
#include <deque>
#include <map>
#include <optional>
#include <sstream>
#include <thread>

namespace gaugeloop {
namespace {

using Clock = std::chrono::steady_clock;

// Live mode fills a gap between two polls by a straight line only up to this length.
constexpr double kLinearGapDeg = 0.5;

// One usable poll, on the unwrapped angle axis: u = revolution * 360 + angle.
struct Poll {
  double u_deg = 0.0;
  double reading_mm = 0.0;
  std::uint16_t sequence = 0;
  GaugeStatus status = 0;
};

struct RevolutionInProgress {
  DegreeTable lift_mm{};
  std::bitset<kDegreesPerRevolution> filled;
  std::string broken;  // non-empty: why this revolution cannot be used
  // Degrees read (latched) or polled near (live) with a status that was not ok, and the
  // union of those statuses: a lasting bad status is named with the degrees it covered.
  std::bitset<kDegreesPerRevolution> bad_status;
  GaugeStatus bad_status_seen = 0;

  void mark_status(int degree, GaugeStatus status) {
    bad_status.set(static_cast<size_t>(degree));
    bad_status_seen |= status;
  }
  bool usable() const { return broken.empty() && bad_status.none() && filled.all(); }
};

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

// A run's budget of time, from the spindle speed seen so far: the run timeout, and how long
// an outage or a frozen amplifier is waited out before the run fails.
class RunBudget {
 public:
  RunBudget(const PollerSettings& s, Clock::time_point start) : s_(s), start_(start) {}

  // Spindle speed from the poller's own view (latch rate, angle rate); <= 0: unknown.
  void saw_speed(double rev_per_s) {
    if (rev_per_s > 0.0) rev_per_s_ = rev_per_s;
  }
  // One revolution at the speed seen; zero while unknown.
  Clock::duration revolution() const {
    if (rev_per_s_ <= 0.0) return Clock::duration::zero();
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rev_per_s_));
  }
  // How long an outage or a freeze is waited out (PollerSettings::patience_revolutions).
  Clock::duration patience() const { return s_.patience_revolutions * revolution(); }
  Clock::duration run_timeout() const { return run_timeout_at(s_, rev_per_s_ * 60.0); }
  bool timed_out(Clock::time_point now) const { return now - start_ > run_timeout(); }
  std::string timeout_text() const {
    const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(run_timeout()).count();
    std::string why = "the spindle speed was never seen";
    if (s_.run_timeout.count() > 0) {
      why = "as set";
    } else if (rev_per_s_ > 0.0) {
      why = std::to_string(s_.revolutions + s_.spare_revolutions + 2) + " revolutions at " + format_fixed(rev_per_s_ * 60.0, 1) +
            " rpm, at least " + std::to_string(kRunTimeoutFloor.count() / 1000) + " s";
    }
    return "run timed out after " + std::to_string(ms) + " ms (" + why + ")";
  }

 private:
  const PollerSettings& s_;
  Clock::time_point start_;
  double rev_per_s_ = 0.0;
};

// The spindle's rate over a long baseline: the progress (latch marks, unwrapped degrees)
// since the first observation after the last restart. Restarted at every gap (an outage, a
// freeze), so a gap never slows it; per-poll ratios of tiny, quantised steps would read
// several times the true rate. Only progress of kMinProgress or more counts, so an encoder
// dithering on a stopped spindle never makes the rate (and with it the patience and the
// run timeout) creep towards zero.
class RateWatch {
 public:
  static constexpr double kMinProgress = 10.0;  // degrees, or latch marks

  explicit RateWatch(Clock::duration baseline) : baseline_(baseline) {}
  void restart() { origin_.reset(); }
  // Progress at `now`, counting up. True when the rate was updated.
  bool observe(Clock::time_point now, double progress) {
    if (!origin_) {
      origin_ = {now, progress};
      return false;
    }
    if (now - origin_->first <= baseline_ || progress < origin_->second + kMinProgress) return false;
    per_s_ = (progress - origin_->second) / std::chrono::duration<double>(now - origin_->first).count();
    return true;
  }
  double per_s() const { return per_s_; }  // 0 until known

 private:
  Clock::duration baseline_;
  std::optional<std::pair<Clock::time_point, double>> origin_;
  double per_s_ = 0.0;
};

// Whether the gauge stands still while the link answers: no progress (a new latch entry; a
// new sample and half a degree of angle in live mode) for stale_after. Time with the link down does not count: the
// timer restarts at the first good exchange after a failure, so an outage is never taken for a freeze. Each stale
// period found restarts the timer; the freeze is given up on after max_attempts periods in a row and the budget's
// patience.
class FreezeWatch {
 public:
  FreezeWatch(const PollerSettings& s, Clock::time_point now) : s_(s), since_(now) {}

  void progressed(Clock::time_point now) {
    since_ = now;
    periods_ = 0;
    outage_ = false;
  }
  void link_failed() { outage_ = true; }
  void answered(Clock::time_point now) {
    if (!outage_) return;
    since_ = now;
    outage_ = false;
  }
  // True when a new stale period has passed; counts it and restarts the timer.
  bool stale(Clock::time_point now) {
    if (outage_ || now - since_ <= s_.stale_after) return false;
    ++periods_;
    since_ = now;
    return true;
  }
  std::chrono::milliseconds frozen_for() const { return periods_ * s_.stale_after; }
  bool exhausted(const RunBudget& budget) const {
    return periods_ >= s_.max_attempts && frozen_for() >= budget.patience();
  }

 private:
  const PollerSettings& s_;
  Clock::time_point since_;
  int periods_ = 0;
  bool outage_ = false;
};

// The run fails: the amplifier stood still for the freeze watch's whole patience.
Error frozen_error(const GaugeClient& gauge, const std::string& what_stood_still, const FreezeWatch& watch,
                   const std::string& where_now) {
  return make_error(ErrorCode::kGaugeTimeout,
                    "the gauge at " + gauge.address() + " stood still " + where_now + ": " + what_stood_still +
                        " for " + std::to_string(watch.frozen_for().count()) +
                        " ms while the link answered (frozen amplifier or stopped spindle); no run was stored");
}

Error run_timed_out(const RunBudget& budget, const std::string& where_now, const std::string& last_discard) {
  return make_error(ErrorCode::kIncompleteRun, budget.timeout_text() + " " + where_now +
                                                   (last_discard.empty() ? "" : "; last discarded " + last_discard));
}

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

// The run fails: more revolutions discarded than there are spares.
Error too_many_discarded(const MeasuredRun& run, int wanted, const std::string& last_discard, const char* advice) {
  return make_error(ErrorCode::kIncompleteRun, "only " + std::to_string(run.revolutions.size()) + " of " +
                                                   std::to_string(wanted) + " revolutions were complete, " +
                                                   std::to_string(run.discarded_revolutions) +
                                                   " discarded; last discarded " + last_discard + ". " + advice);
}

LinkPolicy link_policy(const PollerSettings& s) { return {s.max_attempts, s.backoff_initial, s.backoff_max}; }

}  // namespace

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

Poller::Poller(GaugeClient& gauge, PollerSettings settings) : gauge_(gauge), settings_(std::move(settings)) {}

Result<MeasuredRun> Poller::measure() {
  if (Status s = validate(settings_); !s) return s.error();
  // Pacing sleeps are short; the default 50 us timer slack would stretch them.
  ::prctl(PR_SET_TIMERSLACK, 1000UL, 0UL, 0UL, 0UL);
  return settings_.mode == SamplingMode::kLive ? measure_live() : measure_latched();
}

Result<MeasuredRun> Poller::measure_live() {
  const int wanted = settings_.revolutions;
  MeasuredRun run;
  GaugeLink link(gauge_, link_policy(settings_));
  RunBudget budget(settings_, Clock::now());
  FreezeWatch freeze(settings_, Clock::now());

  std::map<std::int64_t, RevolutionInProgress> in_progress;
  Poll prev;  // the last new sample, valid when have_prev
  bool have_prev = false;
  // The amplifier's sample number of the last poll, kept across reconnects: a sample seen
  // before a reconnect is no new sample after it.
  std::optional<std::uint16_t> last_sequence;
  // The polls that form an unbroken chain: good status, moving forward, each within
  // max_interpolation_gap_deg of the one before. Segment chain[pending] -> chain[pending+1] is
  // the first whose degrees are not filled yet; it waits for a neighbour on its right (see
  // fill_ready). Polls more than 3 gaps behind it can no longer be a neighbour and are dropped.
  std::deque<Poll> chain;
  size_t pending = 0;
  double filled_to_u = 0.0;  // degrees up to here have had their chance to be filled (set by the first poll)
  std::optional<std::int64_t> start_rev;  // first revolution index we collect
  std::int64_t next_rev = 0;              // next revolution to keep or discard
  RevolutionUnwrapper revolutions;
  auto last_new_sample = Clock::now();
  double rate_deg_per_s = 0.0;  // spindle rate from successive new samples, smoothed: paces the polls
  RateWatch speed(std::chrono::milliseconds(50));  // unwrapped degrees per second, for the budget
  Clock::time_point last_poll_at{};
  std::string last_discard;  // why the most recent revolution was thrown away

  auto where_now = [&]() {
    return "during revolution " + std::to_string(run.revolutions.size() + 1) + " of " + std::to_string(wanted);
  };

  // Marks every revolution touched by [from_u, to_u] as unusable.
  auto break_span = [&](double from_u, double to_u, const std::string& why) {
    if (!start_rev) return;
    const auto r0 = std::max<std::int64_t>(next_rev, static_cast<std::int64_t>(std::floor(from_u / 360.0)));
    const auto r1 = static_cast<std::int64_t>(std::floor(to_u / 360.0));
    for (auto r = r0; r <= r1; ++r) {
      auto& rev = in_progress[r];
      if (rev.broken.empty()) rev.broken = why;
    }
  };

  // Fills the whole degrees t with a.u < t <= b.u. The cubic through `left`, a, b and `right`
  // is used when both neighbours are given (fill_ready finds them between h/3 and 3h from the
  // segment, h = its length): then its error is about h^4/24 |H''''|, under 0.001 um at
  // h = 1 deg on the sample lobes, and its weights stay under about 1.5, so noise is not
  // amplified (clustered nodes would turn 0.3 um of noise into microns).
  // Otherwise a segment up to kLinearGapDeg is filled linearly (error h^2/8 |H''|: 0.2 um at
  // 0.5 deg on the intake nose), and a longer one stays missing.
  auto fill_segment = [&](const Poll* left, const Poll& a, const Poll& b, const Poll* right) {
    const double h = b.u_deg - a.u_deg;
    std::vector<const Poll*> support;
    if (left != nullptr && right != nullptr) {
      support = {left, &a, &b, right};
    } else if (h <= kLinearGapDeg) {
      support = {&a, &b};
    } else {
      return;  // no well-spaced support for a segment this long
    }
    for (auto t = static_cast<std::int64_t>(std::floor(a.u_deg)) + 1;
         t <= static_cast<std::int64_t>(std::floor(b.u_deg)); ++t) {
      const std::int64_t r = t >= 0 ? t / 360 : (t - 359) / 360;
      if (r < next_rev) continue;
      const int deg = static_cast<int>(t - r * 360);
      double value = 0.0;  // Lagrange form
      for (size_t i = 0; i < support.size(); ++i) {
        double w = 1.0;
        for (size_t j = 0; j < support.size(); ++j) {
          if (j != i) w *= (static_cast<double>(t) - support[j]->u_deg) / (support[i]->u_deg - support[j]->u_deg);
        }
        value += w * support[i]->reading_mm;
      }
      auto& rev = in_progress[r];
      rev.lift_mm[deg] = value;
      rev.filled.set(static_cast<size_t>(deg));
    }
  };

  // Fills the pending segments in order. A segment a -> b of length h takes as neighbours
  // the nearest polls at least h/3 beyond either end, if they lie within 3h: a long segment
  // left by a stalled poll among dense polls reaches past its immediate neighbours for
  // well-spaced ones. It waits until a poll h/3 beyond b has arrived, unless `closing`: the
  // chain ends here, and its last segments are filled with the support they have.
  auto fill_ready = [&](bool closing) {
    while (pending + 1 < chain.size()) {
      const Poll& a = chain[pending];
      const Poll& b = chain[pending + 1];
      const double h = b.u_deg - a.u_deg;
      size_t j = pending + 2;
      while (j < chain.size() && chain[j].u_deg < b.u_deg + h / 3.0) ++j;
      if (j == chain.size() && !closing) break;  // the right neighbour is still to come
      const Poll* right = j < chain.size() && chain[j].u_deg <= b.u_deg + 3.0 * h ? &chain[j] : nullptr;
      const Poll* left = nullptr;
      for (size_t i = pending; i-- > 0;) {
        if (chain[i].u_deg <= a.u_deg - h / 3.0) {
          if (chain[i].u_deg >= a.u_deg - 3.0 * h) left = &chain[i];
          break;
        }
      }
      fill_segment(left, a, b, right);
      filled_to_u = b.u_deg;
      ++pending;
    }
    if (closing) {
      chain.clear();
      pending = 0;
      return;
    }
    while (pending > 0 && chain.front().u_deg < chain[pending].u_deg - 3.0 * settings_.max_interpolation_gap_deg) {
      chain.pop_front();
      --pending;
    }
  };

  // A poll with a bad status: the whole degrees since the poll before it, or its own degree,
  // were read with that status; their revolutions are discarded, naming it.
  auto mark_status = [&](double from_u, const Poll& cur) {
    if (!start_rev) return;
    const auto last = static_cast<std::int64_t>(std::floor(cur.u_deg));
    const auto first = std::min(static_cast<std::int64_t>(std::floor(from_u)) + 1, last);
    for (auto t = first; t <= static_cast<std::int64_t>(std::floor(cur.u_deg)); ++t) {
      const std::int64_t r = t >= 0 ? t / 360 : (t - 359) / 360;
      if (r >= next_rev) in_progress[r].mark_status(static_cast<int>(t - r * 360), cur.status);
    }
  };

  // Takes a new poll: extends the chain, or closes it and starts a new one.
  auto take_poll = [&](const Poll& cur) {
    const bool ok = gauge_status_ok(cur.status);
    if (!chain.empty()) {
      const Poll last = chain.back();
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
      mark_status(have_prev ? prev.u_deg : cur.u_deg, cur);
      filled_to_u = std::max(filled_to_u, cur.u_deg);
      return;
    }
    chain.push_back(cur);
    if (chain.size() == 1) filled_to_u = std::max(filled_to_u, cur.u_deg);
    fill_ready(/*closing=*/false);
  };

  // Moves revolutions that lie wholly behind `u` out of `in_progress`: kept or discarded.
  auto finish_behind = [&](double u) -> Status {
    const auto current = static_cast<std::int64_t>(std::floor(u / 360.0));
    for (auto r = next_rev; r < current && static_cast<int>(run.revolutions.size()) < wanted; ++r) {
      auto it = in_progress.find(r);
      RevolutionInProgress rev = it == in_progress.end() ? RevolutionInProgress{} : std::move(it->second);
      if (it != in_progress.end()) in_progress.erase(it);
      if (rev.usable()) {
        run.revolutions.push_back(RevolutionSamples{r, rev.lift_mm});
        if (on_revolution_) on_revolution_(static_cast<int>(run.revolutions.size()));
      } else {
        ++run.discarded_revolutions;
        last_discard = "revolution " + std::to_string(r) + ": " + discard_reason(rev, gauge_);
      }
      next_rev = r + 1;
    }
    if (run.discarded_revolutions > settings_.spare_revolutions) {
      return too_many_discarded(run, wanted, last_discard,
                                "Check the gauge status, and that the link keeps up with the spindle "
                                "(slower spindle, or latched mode)");
    }
    return {};
  };

  // Never interpolate across a gap in the polls: a failed read, or a frozen amplifier.
  auto break_chain = [&](const std::string& why) {
    if (have_prev) break_span(prev.u_deg, prev.u_deg, why);
    have_prev = false;
    speed.restart();
    fill_ready(/*closing=*/true);
  };
  // A poll without progress (`what` stood still). After stale_after the chain breaks and the
  // link is reset (a stuck connection can look frozen); after the freeze watch's patience
  // the run fails. An error ends the run. Progress is the angle passing the last point of
  // progress by kStandstillDeg: an encoder dithers by a count or so on a stopped spindle.
  constexpr double kStandstillDeg = 0.5;
  std::optional<double> progress_u;
  auto no_progress = [&](Clock::time_point now, const std::string& what) -> Status {
    if (!freeze.stale(now)) return {};
    if (freeze.exhausted(budget)) return frozen_error(gauge_, what, freeze, where_now());
    break_chain("frozen amplifier or stopped spindle: " + what);
    return link.failed(make_error(ErrorCode::kGaugeTimeout, what), where_now());
  };

  while (static_cast<int>(run.revolutions.size()) < wanted) {
    if (budget.timed_out(Clock::now())) return run_timed_out(budget, where_now(), last_discard);
    if (link.state() != LinkState::kConnected || !gauge_.connected()) {
      if (Status s = link.ensure(where_now()); !s) return s.error();
      last_new_sample = Clock::now();
    }
    if (settings_.poll_step_deg > 0.0 && rate_deg_per_s > 0.0) {
      // Pacing, not synchronisation: wait until the spindle has turned about poll_step_deg.
      const auto wait = std::chrono::duration<double>(settings_.poll_step_deg / rate_deg_per_s);
      const auto capped = std::min<std::chrono::duration<double>>(wait, settings_.max_poll_interval);
      const auto due = last_poll_at + std::chrono::duration_cast<Clock::duration>(capped);
      if (due - Clock::now() > std::chrono::microseconds(20)) std::this_thread::sleep_until(due);
    }
    last_poll_at = Clock::now();
    Result<GaugeSnapshot> r = gauge_.read_snapshot();
    ++run.polls;
    if (!r) {
      break_chain("link fault: " + r.error().message);
      freeze.link_failed();
      if (Status s = link.failed(r.error(), where_now()); !s) return s.error();
      continue;
    }
    link.succeeded();
    const GaugeSnapshot& snap = *r;
    const auto now = Clock::now();
    freeze.answered(now);
    if (last_sequence && snap.sequence == *last_sequence) {
      // Same amplifier sample as last time: an amplifier whose sample number stops is frozen.
      if (Status s = no_progress(now, "its sample number stayed at " + std::to_string(snap.sequence)); !s) {
        return s.error();
      }
      continue;
    }
    last_sequence = snap.sequence;

    const Poll cur{revolutions.unwrap(snap), snap.reading_mm, snap.sequence, snap.status};
    if (!progress_u || cur.u_deg > *progress_u + kStandstillDeg) {
      progress_u = cur.u_deg;
      freeze.progressed(now);
    } else if (Status s = no_progress(now, "its angle stayed at " + format_fixed(snap.angle_deg, 1) + " deg"); !s) {
      return s.error();  // new samples, but the spindle stands (or turns backwards)
    }
    if (have_prev && cur.u_deg > prev.u_deg) {
      const double dt_s = std::chrono::duration<double>(now - last_new_sample).count();
      if (dt_s > 0.0) {
        const double rate = (cur.u_deg - prev.u_deg) / dt_s;
        rate_deg_per_s = rate_deg_per_s > 0.0 ? 0.9 * rate_deg_per_s + 0.1 * rate : rate;
      }
    }
    if (speed.observe(now, cur.u_deg)) {
      budget.saw_speed(speed.per_s() / 360.0);
      link.set_patience(budget.patience());
    }
    last_new_sample = now;
    if (!start_rev) {
      start_rev = static_cast<std::int64_t>(std::floor(cur.u_deg / 360.0)) + 1;
      next_rev = *start_rev;
    }

    take_poll(cur);
    prev = cur;
    have_prev = true;
    if (Status s = finish_behind(filled_to_u); !s) return s.error();
  }
  run.reconnects = link.reconnects();
  return run;
}

Result<MeasuredRun> Poller::measure_latched() {
  const int wanted = settings_.revolutions;
  MeasuredRun run;
  GaugeLink link(gauge_, link_policy(settings_));
  RunBudget budget(settings_, Clock::now());
  FreezeWatch freeze(settings_, Clock::now());

  bool have_next = false;
  std::uint32_t next = 0;       // latch number of the next entry to read
  std::int64_t read_total = 0;  // entries consumed, unwrapped: labelled revolutions are numbered from it
  int expected_degree = -1;     // -1: waiting for degree 0 to start a revolution
  RevolutionInProgress rev;
  std::int64_t rev_number = 0;
  std::string last_discard;
  // Entries read but not yet taken: the count read after them must show the ring had not
  // overwritten them while they were read (count at the read <= first + ring size).
  std::vector<LatchedSample> pending;
  std::uint32_t pending_first = 0;
  // Latch numbers [from, to) among which the amplifier's fault mark counter says a mark was
  // latched with a bad status; every revolution holding one of them is discarded.
  struct FaultWindow {
    std::uint32_t from = 0;
    std::uint32_t to = 0;
    std::optional<GaugeStatus> status;
  };
  std::vector<FaultWindow> fault_windows;
  std::optional<std::pair<std::uint32_t, std::uint32_t>> last_faults;  // (count, fault count) at the last state read
  // Compact entries: whether the latch count has been checked against the encoder angle.
  bool frame_checked = false;
  // Latch marks per second: paces the drain and gives the spindle speed. Restarted with the
  // drain, so a freeze or an outage never slows it (and so lengthens the patience and the run
  // timeout). The count is taken as it comes: at its 2^32 wrap the rate waits for a restart.
  RateWatch latch_rate(std::chrono::milliseconds(5));
  auto drain_pause = [&](const LatchState& latch) {
    const double entries_per_s = latch_rate.per_s();
    if (entries_per_s <= 0.0) return std::chrono::duration<double>(settings_.latch_idle_wait);
    const double wait_s = std::min<double>(latch.entries_per_read, latch.ring_size / 4.0) / entries_per_s;
    return std::min(std::chrono::duration<double>(wait_s), std::chrono::duration<double>(settings_.latch_max_wait));
  };

  auto where_now = [&]() {
    return "during revolution " + std::to_string(run.revolutions.size() + 1) + " of " + std::to_string(wanted);
  };
  auto discard = [&](const std::string& why) {
    if (expected_degree > 0) {
      ++run.discarded_revolutions;
      last_discard = "revolution " + std::to_string(rev_number) + ": " + why;
    }
    expected_degree = -1;
  };
  // After a link fault or an overrun: drop what is in hand and resume from the newest entry.
  auto restart_drain = [&](const std::string& why) {
    discard(why);
    pending.clear();
    have_next = false;
    latch_rate.restart();
  };
  // A request failed: restart the drain, and let the link decide whether to go on.
  auto link_fault = [&](const Error& e) -> Status {
    restart_drain("link fault: " + e.message);
    freeze.link_failed();
    return link.failed(e, where_now());
  };
  auto note_faults = [&](const LatchState& st) {
    if (!st.fault_count) return;
    if (last_faults && *st.fault_count != last_faults->second) {
      fault_windows.push_back({last_faults->first, st.write_count, st.fault_status});
    }
    last_faults = {st.write_count, *st.fault_count};
  };

  // Takes one confirmed entry, latch number `index`. Returns true when the run is complete.
  auto take = [&](const LatchedSample& e, std::uint32_t index, bool implied) {
    ++read_total;
    const int degree = implied ? static_cast<int>(index % kDegreesPerRevolution) : e.degree;
    if (expected_degree >= 0 && degree != expected_degree) {
      // Labelled entries: also catches an entry overwritten during the read (the ring, not a
      // multiple of 360 entries, then holds a different degree in that slot). Compact ones:
      // the count passed 2^32, where n mod 360 restarts at 0 off the index.
      discard("encoder degree jumped from " + std::to_string((expected_degree + 359) % 360) + " to " +
              std::to_string(degree));
      if (implied) frame_checked = false;
    }
    if (expected_degree < 0) {
      if (degree != 0) return false;  // wait for the start of a revolution
      rev = RevolutionInProgress{};
      rev_number =
          implied ? static_cast<std::int64_t>(index / kDegreesPerRevolution) : read_total / kDegreesPerRevolution;
    }
    if (!gauge_status_ok(e.status)) rev.mark_status(degree, e.status);
    for (const FaultWindow& w : fault_windows) {
      if (rev.broken.empty() && index - w.from < w.to - w.from) {
        const std::string what = w.status ? gauge_.describe_status(*w.status) : std::string("a fault");
        rev.broken =
            "the gauge counted a mark latched with status " + what +
            (implied ? " between degrees " + std::to_string(w.from % kDegreesPerRevolution) + " and " +
                           std::to_string((w.to - 1) % kDegreesPerRevolution)
                     : " between latch numbers " + std::to_string(w.from) + " and " + std::to_string(w.to - 1));
      }
    }
    rev.lift_mm[degree] = e.reading_mm;
    rev.filled.set(static_cast<size_t>(degree));
    expected_degree = (degree + 1) % kDegreesPerRevolution;
    if (degree == kDegreesPerRevolution - 1) {
      expected_degree = -1;  // next entry (degree 0) starts the next revolution
      if (rev.usable()) {
        run.revolutions.push_back(RevolutionSamples{rev_number, rev.lift_mm});
        if (on_revolution_) on_revolution_(static_cast<int>(run.revolutions.size()));
        if (static_cast<int>(run.revolutions.size()) == wanted) return true;
      } else {
        ++run.discarded_revolutions;
        last_discard = "revolution " + std::to_string(rev_number) + ": " + discard_reason(rev, gauge_);
      }
    }
    return false;
  };

  // Compact entries: the count must be zeroed at the index. Reads count c1, the snapshot
  // angle a, count c2: the latest mark before the snapshot is one of c1-1 .. c2-1, so a lies
  // in [(c1-1) mod 360, (c2-1) mod 360 + 1), give or take 1 degree of encoder resolution.
  // Returns the later state when the frame agrees or cannot be judged yet (frame_checked
  // tells which), an Error for a link fault (code other than kInvalidInput) or a mismatch.
  auto check_frame = [&](const LatchState& first) -> Result<LatchState> {
    Result<GaugeSnapshot> snap = gauge_.read_snapshot();
    ++run.polls;
    if (!snap) return snap.error();
    Result<LatchState> second = gauge_.read_latch_state();
    ++run.polls;
    if (!second) return second.error();
    const std::uint32_t c1 = first.write_count;
    const std::uint32_t c2 = second->write_count;
    const std::uint32_t span = c2 - c1 + 1;
    if (c2 == 0 || span >= 300) return second;  // nothing latched yet, or the spindle outran the reads
    const double lo = static_cast<double>((static_cast<std::uint64_t>(c1) + 359) % 360);
    const double off = std::fmod(snap->angle_deg - lo + 720.0, 360.0);
    constexpr double kToleranceDeg = 1.0;
    if (off < span + kToleranceDeg || off > 360.0 - kToleranceDeg) {
      frame_checked = true;
      return second;
    }
    return make_error(ErrorCode::kInvalidInput,
                      "compact latch entries: the latch count " + std::to_string(c1) + " says machine degree " +
                          std::to_string((c1 + 359ULL) % 360) + " but the encoder angle reads " +
                          format_fixed(snap->angle_deg, 1) +
                          " deg. The count must be zeroed at the encoder's index pulse (mark 0 = degree 0) and "
                          "must not have passed 2^32; reset the amplifier's latch count, or use an entry layout "
                          "with a degree word (docs/gauge.md)");
  };

  while (static_cast<int>(run.revolutions.size()) < wanted) {
    if (budget.timed_out(Clock::now())) return run_timed_out(budget, where_now(), last_discard);
    if (run.discarded_revolutions > settings_.spare_revolutions) {
      return too_many_discarded(run, wanted, last_discard, "Check the gauge status and the encoder");
    }
    if (Status s = link.ensure(where_now()); !s) return s.error();
    Result<LatchState> state = gauge_.read_latch_state();
    ++run.polls;
    if (!state) {
      if (Status s = link_fault(state.error()); !s) return s.error();
      continue;
    }
    link.succeeded();
    freeze.answered(Clock::now());
    note_faults(*state);
    if (state->degree_implied && !frame_checked) {
      Result<LatchState> later = check_frame(*state);
      if (!later) {
        if (later.error().code == ErrorCode::kInvalidInput) return later.error();
        if (Status s = link_fault(later.error()); !s) return s.error();
        continue;
      }
      note_faults(*later);
      state = std::move(later);
      if (!frame_checked) restart_drain("the latch count moved too far to be checked against the angle");
    }
    if (!pending.empty()) {
      const std::uint32_t behind = state->write_count - pending_first;  // modulo 2^32
      if (behind > static_cast<std::uint32_t>(state->ring_size)) {
        restart_drain("latch buffer overrun: the ring may have overwritten entries while they were read");
      } else {
        bool done = false;
        // A compact entry past the count's 2^32 wrap clears frame_checked: take no more.
        for (size_t i = 0; i < pending.size() && !done && (frame_checked || !state->degree_implied); ++i) {
          done = take(pending[i], pending_first + static_cast<std::uint32_t>(i), state->degree_implied);
        }
        pending.clear();
        // Windows wholly behind the entries taken can no longer matter.
        std::erase_if(fault_windows, [&](const FaultWindow& w) { return static_cast<std::int32_t>(next - w.to) >= 0; });
        if (done) break;
      }
    }
    if (latch_rate.observe(Clock::now(), state->write_count)) {
      budget.saw_speed(latch_rate.per_s() / kDegreesPerRevolution);
      link.set_patience(budget.patience());
    }
    if (!have_next) {
      next = state->write_count;
      have_next = true;
    }
    const std::uint32_t available = state->write_count - next;  // modulo 2^32
    if (available > static_cast<std::uint32_t>(state->ring_size)) {
      discard("latch buffer overrun: the poller fell " +
              std::to_string(available - static_cast<std::uint32_t>(state->ring_size)) +
              " entries behind the ring; missing degrees follow");
      next = state->write_count;
      if (state->degree_implied) frame_checked = false;  // or the count restarted
      continue;
    }
    if (available == 0) {
      if (!freeze.stale(Clock::now())) {
        std::this_thread::sleep_for(drain_pause(*state));  // pacing: nothing new to read yet
        continue;
      }
      const std::string what = "its latch count stayed at " + std::to_string(state->write_count);
      if (freeze.exhausted(budget)) return frozen_error(gauge_, what, freeze, where_now());
      restart_drain("frozen amplifier or stopped spindle: " + what);
      // Reconnect: a stuck connection can look like a frozen amplifier.
      if (Status s = link.failed(make_error(ErrorCode::kGaugeTimeout, what), where_now()); !s) return s.error();
      continue;
    }
    freeze.progressed(Clock::now());
    if (state->degree_implied && !frame_checked) continue;  // judge the frame before reading entries
    const int slot = static_cast<int>(next % static_cast<std::uint32_t>(state->ring_size));
    const int count = std::min({static_cast<int>(available), state->entries_per_read, state->ring_size - slot});
    Result<std::vector<LatchedSample>> entries = gauge_.read_latched(slot, count);
    ++run.polls;
    if (!entries) {
      if (Status s = link_fault(entries.error()); !s) return s.error();
      continue;
    }
    pending = std::move(*entries);
    pending_first = next;
    next += static_cast<std::uint32_t>(pending.size());
    if (static_cast<std::uint32_t>(count) == available) {
      std::this_thread::sleep_for(drain_pause(*state));  // pacing: drained, let a block gather
    }
  }
  run.reconnects = link.reconnects();
  return run;
}

}  // namespace gaugeloop
