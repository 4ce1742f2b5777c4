// Latched mode: drains the amplifier's per-degree latch buffer in block reads, keeping or
// discarding whole revolutions.
#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "acquisition/collector.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

// Latch numbers [from, to) among which the amplifier's fault mark counter says a mark was
// latched with a bad status; every revolution holding one of them is discarded.
struct FaultWindow {
  std::uint32_t from = 0;
  std::uint32_t to = 0;
  std::optional<GaugeStatus> status;
};

class LatchedCollector : private Collector {
 public:
  explicit LatchedCollector(const CollectorContext& context) : Collector(context) {}

  Result<MeasuredRun> run();

 private:
  // Reads the latch state, and for compact entries checks the frame first. nullopt: a link
  // fault the run goes on after (the drain restarts); an error ends the run.
  Result<std::optional<LatchState>> read_state();
  Result<std::optional<LatchState>> after_link_fault(const Error& e);
  Result<LatchState> check_frame(const LatchState& first);
  void note_faults(const LatchState& st);
  // Takes the entries read last once `state` shows the ring kept them. True: the run is complete.
  bool take_pending(const LatchState& state);
  bool take(const LatchedSample& e, std::uint32_t index, bool implied);
  void mark_fault_windows(std::uint32_t index, bool implied);
  // Reads the next block of entries, or waits for one to latch.
  Status drain(const LatchState& state);
  Status wait_for_entries(const LatchState& state);
  Status read_block(const LatchState& state, std::uint32_t available);
  Clock::duration drain_pause(const LatchState& latch) const;
  void discard(const std::string& why);
  void restart_drain(const std::string& why);
  Status link_fault(const Error& e);

  bool have_next_ = false;
  std::uint32_t next_ = 0;       // latch number of the next entry to read
  std::int64_t read_total_ = 0;  // entries consumed, unwrapped: labelled revolutions are numbered from it
  int expected_degree_ = -1;     // -1: waiting for degree 0 to start a revolution
  RevolutionInProgress rev_;
  std::int64_t rev_number_ = 0;
  // Entries read but not yet taken: the count read after them must show the ring had not
  // overwritten them while they were read (count at the read <= first + ring size).
  std::vector<LatchedSample> pending_;
  std::uint32_t pending_first_ = 0;
  std::vector<FaultWindow> fault_windows_;
  std::optional<std::pair<std::uint32_t, std::uint32_t>> last_faults_;  // (count, fault count) at the last state read
  // Compact entries: whether the latch count has been checked against the encoder angle.
  bool frame_checked_ = false;
  // Latch marks per second: paces the drain and gives the spindle speed. Restarted with the
  // drain, so a freeze or an outage never slows it (and so lengthens the patience and the run
  // timeout). The count is taken as it comes: at its 2^32 wrap the rate waits for a restart.
  RateWatch latch_rate_{std::chrono::milliseconds(5)};
};

Result<MeasuredRun> LatchedCollector::run() {
  while (!complete()) {
    if (budget_.timed_out(clock_.now())) return timed_out();
    if (run_.discarded_revolutions > settings_.spare_revolutions) {
      return too_many_discarded("Check the gauge status and the encoder");
    }
    if (Status s = link_.ensure(where_now()); !s) return s.error();
    Result<std::optional<LatchState>> state = read_state();
    if (!state) return state.error();
    if (!state->has_value()) continue;
    if (take_pending(**state)) break;
    if (Status s = drain(**state); !s) return s.error();
  }
  return finished();
}

Result<std::optional<LatchState>> LatchedCollector::read_state() {
  Result<LatchState> state = gauge_.read_latch_state();
  ++run_.polls;
  if (!state) return after_link_fault(state.error());
  link_.succeeded();
  freeze_.answered(clock_.now());
  note_faults(*state);
  if (!state->degree_implied || frame_checked_) return std::optional<LatchState>(std::move(*state));
  Result<LatchState> later = check_frame(*state);
  if (!later) {
    if (later.error().code == ErrorCode::kInvalidInput) return later.error();
    return after_link_fault(later.error());
  }
  note_faults(*later);
  if (!frame_checked_) restart_drain("the latch count moved too far to be checked against the angle");
  return std::optional<LatchState>(std::move(*later));
}

Result<std::optional<LatchState>> LatchedCollector::after_link_fault(const Error& e) {
  if (Status s = link_fault(e); !s) return s.error();
  return std::optional<LatchState>();
}

// Compact entries: the count must be zeroed at the index. Reads count c1, the snapshot
// angle a, count c2: the latest mark before the snapshot is one of c1-1 .. c2-1, so a lies
// in [(c1-1) mod 360, (c2-1) mod 360 + 1), give or take 1 degree of encoder resolution.
// Returns the later state when the frame agrees or cannot be judged yet (frame_checked_
// tells which), an Error for a link fault (code other than kInvalidInput) or a mismatch.
Result<LatchState> LatchedCollector::check_frame(const LatchState& first) {
  Result<GaugeSnapshot> snap = gauge_.read_snapshot();
  ++run_.polls;
  if (!snap) return snap.error();
  Result<LatchState> second = gauge_.read_latch_state();
  ++run_.polls;
  if (!second) return second.error();
  const std::uint32_t c1 = first.write_count;
  const std::uint32_t c2 = second->write_count;
  const std::uint32_t span = c2 - c1 + 1;
  if (c2 == 0 || span >= 300) return second;  // nothing latched yet, or the spindle outran the reads
  const double lo = static_cast<double>((static_cast<std::uint64_t>(c1) + 359) % 360);
  const double off = std::fmod(snap->angle_deg - lo + 720.0, 360.0);
  constexpr double kToleranceDeg = 1.0;
  if (off < span + kToleranceDeg || off > 360.0 - kToleranceDeg) {
    frame_checked_ = true;
    return second;
  }
  return make_error(ErrorCode::kInvalidInput,
                    "compact latch entries: the latch count " + std::to_string(c1) + " says machine degree " +
                        std::to_string((c1 + 359ULL) % 360) + " but the encoder angle reads " +
                        format_fixed(snap->angle_deg, 1) +
                        " deg. The count must be zeroed at the encoder's index pulse (mark 0 = degree 0) and "
                        "must not have passed 2^32; reset the amplifier's latch count, or use an entry layout "
                        "with a degree word (docs/gauge.md)");
}

void LatchedCollector::note_faults(const LatchState& st) {
  if (!st.fault_count) return;
  if (last_faults_ && *st.fault_count != last_faults_->second) {
    fault_windows_.push_back({last_faults_->first, st.write_count, st.fault_status});
  }
  last_faults_ = {st.write_count, *st.fault_count};
}

bool LatchedCollector::take_pending(const LatchState& state) {
  if (pending_.empty()) return false;
  const std::uint32_t behind = state.write_count - pending_first_;  // modulo 2^32
  if (behind > static_cast<std::uint32_t>(state.ring_size)) {
    restart_drain("latch buffer overrun: the ring may have overwritten entries while they were read");
    return false;
  }
  bool done = false;
  // A compact entry past the count's 2^32 wrap clears frame_checked_: take no more.
  for (size_t i = 0; i < pending_.size() && !done && (frame_checked_ || !state.degree_implied); ++i) {
    done = take(pending_[i], pending_first_ + static_cast<std::uint32_t>(i), state.degree_implied);
  }
  pending_.clear();
  // Windows wholly behind the entries taken can no longer matter.
  std::erase_if(fault_windows_, [&](const FaultWindow& w) { return static_cast<std::int32_t>(next_ - w.to) >= 0; });
  return done;
}

// Takes one confirmed entry, latch number `index`. Returns true when the run is complete.
bool LatchedCollector::take(const LatchedSample& e, std::uint32_t index, bool implied) {
  ++read_total_;
  const int degree = implied ? static_cast<int>(index % kDegreesPerRevolution) : e.degree;
  if (expected_degree_ >= 0 && degree != expected_degree_) {
    // Labelled entries: also catches an entry overwritten during the read (the ring, not a
    // multiple of 360 entries, then holds a different degree in that slot). Compact ones:
    // the count passed 2^32, where n mod 360 restarts at 0 off the index.
    discard("encoder degree jumped from " + std::to_string((expected_degree_ + 359) % 360) + " to " +
            std::to_string(degree));
    if (implied) frame_checked_ = false;
  }
  if (expected_degree_ < 0) {
    if (degree != 0) return false;  // wait for the start of a revolution
    rev_ = RevolutionInProgress{};
    rev_number_ =
        implied ? static_cast<std::int64_t>(index / kDegreesPerRevolution) : read_total_ / kDegreesPerRevolution;
  }
  if (!gauge_status_ok(e.status)) rev_.mark_status(degree, e.status);
  mark_fault_windows(index, implied);
  rev_.lift_mm[degree] = e.reading_mm;
  rev_.filled.set(static_cast<size_t>(degree));
  expected_degree_ = (degree + 1) % kDegreesPerRevolution;
  if (degree != kDegreesPerRevolution - 1) return false;
  expected_degree_ = -1;  // next entry (degree 0) starts the next revolution
  finish_revolution(rev_number_, rev_);
  return complete();
}

// The revolution in progress is broken when latch number `index` lies in a fault window.
void LatchedCollector::mark_fault_windows(std::uint32_t index, bool implied) {
  for (const FaultWindow& w : fault_windows_) {
    if (rev_.broken.empty() && index - w.from < w.to - w.from) {
      const std::string what = w.status ? gauge_.describe_status(*w.status) : std::string("a fault");
      rev_.broken = "the gauge counted a mark latched with status " + what +
                    (implied ? " between degrees " + std::to_string(w.from % kDegreesPerRevolution) + " and " +
                                   std::to_string((w.to - 1) % kDegreesPerRevolution)
                             : " between latch numbers " + std::to_string(w.from) + " and " + std::to_string(w.to - 1));
    }
  }
}

Status LatchedCollector::drain(const LatchState& state) {
  if (latch_rate_.observe(clock_.now(), state.write_count)) {
    budget_.saw_speed(latch_rate_.per_s() / kDegreesPerRevolution);
    link_.set_patience(budget_.patience());
  }
  if (!have_next_) {
    next_ = state.write_count;
    have_next_ = true;
  }
  const std::uint32_t available = state.write_count - next_;  // modulo 2^32
  if (available > static_cast<std::uint32_t>(state.ring_size)) {
    discard("latch buffer overrun: the poller fell " +
            std::to_string(available - static_cast<std::uint32_t>(state.ring_size)) +
            " entries behind the ring; missing degrees follow");
    next_ = state.write_count;
    if (state.degree_implied) frame_checked_ = false;  // or the count restarted
    return {};
  }
  if (available == 0) return wait_for_entries(state);
  freeze_.progressed(clock_.now());
  if (state.degree_implied && !frame_checked_) return {};  // judge the frame before reading entries
  return read_block(state, available);
}

// Nothing new latched: pace, or after stale_after take the amplifier for frozen.
Status LatchedCollector::wait_for_entries(const LatchState& state) {
  if (!freeze_.stale(clock_.now())) {
    clock_.sleep_for(drain_pause(state));  // pacing: nothing new to read yet
    return {};
  }
  const std::string what = "its latch count stayed at " + std::to_string(state.write_count);
  if (freeze_.exhausted(budget_)) return frozen(what);
  restart_drain("frozen amplifier or stopped spindle: " + what);
  // Reconnect: a stuck connection can look like a frozen amplifier.
  return link_.failed(make_error(ErrorCode::kGaugeTimeout, what), where_now());
}

Status LatchedCollector::read_block(const LatchState& state, std::uint32_t available) {
  const int slot = static_cast<int>(next_ % static_cast<std::uint32_t>(state.ring_size));
  const int count = std::min({static_cast<int>(available), state.entries_per_read, state.ring_size - slot});
  Result<std::vector<LatchedSample>> entries = gauge_.read_latched(slot, count);
  ++run_.polls;
  if (!entries) return link_fault(entries.error());
  pending_ = std::move(*entries);
  pending_first_ = next_;
  next_ += static_cast<std::uint32_t>(pending_.size());
  if (static_cast<std::uint32_t>(count) == available) {
    clock_.sleep_for(drain_pause(state));  // pacing: drained, let a block gather
  }
  return {};
}

// After draining, about one block's worth of latching at the rate seen, capped; the idle
// wait until the rate is known.
Clock::duration LatchedCollector::drain_pause(const LatchState& latch) const {
  const double entries_per_s = latch_rate_.per_s();
  if (entries_per_s <= 0.0) return settings_.latch_idle_wait;
  const double wait_s = std::min<double>(latch.entries_per_read, latch.ring_size / 4.0) / entries_per_s;
  return std::chrono::duration_cast<Clock::duration>(
      std::min(std::chrono::duration<double>(wait_s), std::chrono::duration<double>(settings_.latch_max_wait)));
}

void LatchedCollector::discard(const std::string& why) {
  if (expected_degree_ > 0) count_discarded(rev_number_, why);
  expected_degree_ = -1;
}

// After a link fault or an overrun: drop what is in hand and resume from the newest entry.
void LatchedCollector::restart_drain(const std::string& why) {
  discard(why);
  pending_.clear();
  have_next_ = false;
  latch_rate_.restart();
}

// A request failed: restart the drain, and let the link decide whether to go on.
Status LatchedCollector::link_fault(const Error& e) {
  restart_drain("link fault: " + e.message);
  freeze_.link_failed();
  return link_.failed(e, where_now());
}

}  // namespace

Result<MeasuredRun> collect_latched(const CollectorContext& context) { return LatchedCollector(context).run(); }

}  // namespace gaugeloop
