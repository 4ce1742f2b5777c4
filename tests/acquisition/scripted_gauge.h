// A scripted gauge for fault sequences: a spindle that advances a fixed angle per read, with
// faults injected by read-call number. Beside the real simulator, never instead of it.
#pragma once

#include <cmath>
#include <functional>
#include <map>
#include <numbers>

#include "acquisition/gauge_client.h"

namespace gaugeloop::testing {

enum class Fault {
  kTimeout,    // the read times out and the link drops
  kRepeat,     // the amplifier returns its previous sample again (same sequence)
  kOverRange,  // status says over-range
  kSkip,       // the spindle moves on `skip_deg` without being polled
  kAngleBack,  // the encoder angle jumps back 10 degrees
  kStall,      // a new sample, but the spindle has not moved since the last one
};

class ScriptedGauge final : public GaugeClient {
 public:
  // Reading at unwrapped angle u (degrees since revolution 0 began).
  std::function<double(double)> lift_mm = [](double u) { return 1.0 + 0.5 * std::sin(u * std::numbers::pi / 180.0); };
  double step_deg = 0.3;  // spindle advance between reads
  double u_deg = 12.5;    // current unwrapped angle
  double skip_deg = 5.0;
  std::uint16_t revolution_base = 0;  // raw counter at u = 0
  double revolution_lag_deg = 0.0;    // the counter moves this far after the angle wraps
  std::map<int, Fault> faults;        // by read call number, 1-based
  int fail_connects = 0;              // the next n connects fail
  bool dead_after_faults = false;     // every read after the last scripted fault times out
  // From this read call on (0: never) the spindle stands; the amplifier then takes a new
  // sample every `sample_every` reads and repeats its last between them (0: it stands too).
  int stand_from_read = 0;
  int sample_every = 1;

  // Latched mode: every read_latch_state() lets the spindle pass `marks_per_poll` degree
  // marks, latched into a ring of `ring_size`; faults apply by read_latch_state() call.
  int ring_size = 512;
  int marks_per_poll = 7;
  std::uint32_t latch_count = 4294967296u - 700u;  // wraps 100 polls into the run, on purpose
  std::uint64_t marks = 0;                         // marks since the fake started
  std::map<int, Fault> latch_faults;
  bool latch_dead_after_faults = false;

  int reads = 0;
  int latch_state_reads = 0;
  int connects = 0;

  Status connect() override {
    ++connects;
    if (fail_connects > 0) {
      --fail_connects;
      return make_error(ErrorCode::kGaugeUnreachable, "connection refused (scripted)");
    }
    connected_ = true;
    return {};
  }
  void disconnect() override { connected_ = false; }
  bool connected() const override { return connected_; }
  std::string address() const override { return "scripted:0"; }

  // Mark k (since the fake started) latches machine degree (k + 100) % 360: the encoder's
  // degree is its own, not derived from the wrapping latch count.
  static int degree_of_mark(std::uint64_t k) { return static_cast<int>((k + 100) % 360); }
  double latched_mm(std::uint64_t k) const { return lift_mm(static_cast<double>(k + 100)); }

  Result<LatchState> read_latch_state() override {
    ++latch_state_reads;
    if (!connected_) return make_error(ErrorCode::kGaugeUnreachable, "not connected");
    if (ring_.empty()) ring_.resize(static_cast<size_t>(ring_size));
    auto it = latch_faults.find(latch_state_reads);
    const bool dead =
        latch_dead_after_faults && !latch_faults.empty() && latch_state_reads > latch_faults.rbegin()->first;
    int n = marks_per_poll;
    bool jump = false;
    std::uint16_t status = kGaugeReady;
    if (dead || (it != latch_faults.end() && it->second == Fault::kTimeout)) {
      connected_ = false;
      latch(n, false, status);
      return make_error(ErrorCode::kGaugeTimeout, "no reply (scripted)");
    }
    if (it != latch_faults.end()) {
      if (it->second == Fault::kSkip) n += ring_size + 10;  // the poller falls behind: overrun
      if (it->second == Fault::kAngleBack) jump = true;
      if (it->second == Fault::kOverRange) status |= kGaugeOverRange;
    }
    latch(n, jump, status);
    LatchState st;
    st.write_count = latch_count;
    st.ring_size = ring_size;
    return st;
  }

  Result<std::vector<LatchedSample>> read_latched(int first_slot, int count) override {
    ++reads;
    if (!connected_) return make_error(ErrorCode::kGaugeUnreachable, "not connected");
    return std::vector<LatchedSample>(ring_.begin() + first_slot, ring_.begin() + first_slot + count);
  }

  Result<GaugeSnapshot> read_snapshot() override {
    ++reads;
    if (!connected_) return make_error(ErrorCode::kGaugeUnreachable, "not connected");
    auto it = faults.find(reads);
    const bool dead = dead_after_faults && !faults.empty() && reads > faults.rbegin()->first;
    if (stand_from_read > 0 && reads >= stand_from_read) {
      const int since = reads - stand_from_read;
      if (sample_every == 0 || since % sample_every != 0) return last_;
    } else {
      u_deg += step_deg;
    }
    if (dead || (it != faults.end() && it->second == Fault::kTimeout)) {
      connected_ = false;
      return make_error(ErrorCode::kGaugeTimeout, "no reply (scripted)");
    }
    GaugeSnapshot s;
    std::uint16_t status = kGaugeReady;
    if (it != faults.end()) {
      switch (it->second) {
        case Fault::kRepeat:
          return last_;
        case Fault::kOverRange:
          status |= kGaugeOverRange;
          break;
        case Fault::kSkip:
          u_deg += skip_deg;
          break;
        case Fault::kAngleBack:
          u_deg -= 10.0;
          break;
        case Fault::kStall:
          u_deg -= step_deg;
          break;
        case Fault::kTimeout:
          break;
      }
    }
    const double turns = std::floor(u_deg / 360.0);
    s.angle_deg = u_deg - turns * 360.0;
    s.revolution = static_cast<std::uint16_t>(revolution_base +
                                              static_cast<int>(std::floor((u_deg - revolution_lag_deg) / 360.0)));
    s.reading_mm = lift_mm(u_deg);
    s.sequence = ++sequence_;
    s.status = status;
    last_ = s;
    return s;
  }

 private:
  void latch(int n, bool jump, std::uint16_t status) {
    for (int k = 0; k < n; ++k) {
      LatchedSample e{latched_mm(marks), degree_of_mark(marks), status};
      if (jump && k == n / 2) e.degree = (e.degree + 10) % 360;
      ring_[latch_count % static_cast<std::uint32_t>(ring_size)] = e;
      ++latch_count;
      ++marks;
    }
  }

  bool connected_ = false;
  std::uint16_t sequence_ = 0;
  std::vector<LatchedSample> ring_;
  GaugeSnapshot last_;
};

}  // namespace gaugeloop::testing
