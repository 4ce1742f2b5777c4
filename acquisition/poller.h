// Turns a stream of gauge snapshots into complete revolutions, one sample per machine degree.
#pragma once

#include <chrono>
#include <functional>
#include <string>
#include <string_view>

#include "acquisition/gauge_client.h"
#include "acquisition/gauge_link.h"
#include "core/clock.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

enum class SamplingMode {
  kLive,     // poll the snapshot and interpolate each degree between the polls around it
  kLatched,  // drain the amplifier's per-degree latch buffer in block reads
};

std::string_view sampling_mode_name(SamplingMode mode);

struct PollerSettings {
  SamplingMode mode = SamplingMode::kLatched;
  int revolutions = 3;  // complete revolutions wanted; never fewer than 3
  // Live mode: a degree takes the reading interpolated between the two polls that straddle
  // it, and only if those polls are at most this far apart. Farther apart, nobody sampled
  // near the degree and it stays missing: a degree is never invented. Between 0.5 deg and
  // this limit a degree is filled only by the cubic through well-spaced neighbours, the
  // nearest polls a third of the gap or more beyond either end, within three gaps (error
  // about h^4/24 |H''''|: under 0.001 um at 1 deg on the sample lobes); up to 0.5 deg a
  // straight line will do (h^2/8 |H''|: 0.2 um at 0.5 deg on the intake nose).
  double max_interpolation_gap_deg = 1.0;
  // 0 (default): live mode polls back to back, as fast as the link answers. > 0: polls are
  // paced to about this much spindle rotation apart, sleeping in between. Sleeping saves
  // CPU but a sleep can overrun by milliseconds (measured: 0.1 % of 0.5 ms sleeps took over
  // 3 ms on this project's VM), and each overrun past max_interpolation_gap_deg loses a
  // degree; pace only when half a degree lasts far longer than that (below about 5 rpm).
  double poll_step_deg = 0.0;
  std::chrono::microseconds max_poll_interval{2000};
  // Revolutions that may be discarded, in either mode, before the run fails.
  int spare_revolutions = 3;
  // Consecutive failed requests or connects, and consecutive stale periods of a frozen
  // amplifier, before giving up.
  int max_attempts = 5;
  // Once the spindle speed is known, an outage or a freeze is also waited out for this many
  // revolutions before giving up: one of up to a revolution then costs the (at most two)
  // revolutions it touches, not the run, whatever the speed (docs/acquisition.md).
  int patience_revolutions = 2;
  std::chrono::milliseconds backoff_initial{20};  // first reconnect delay, doubled each time
  std::chrono::milliseconds backoff_max{500};
  // No new latch entry (latched), or no new amplifier sample or half a degree of angle
  // (live), for this long while the link answers = frozen amplifier or stopped spindle:
  // reconnect, discard the revolution.
  std::chrono::milliseconds stale_after{200};
  // Latched mode: after draining the buffer, sleep until about one block (31 entries) has
  // latched again, from the latch rate seen so far, but never longer than
  // latch_max_wait or a quarter of the ring; latch_idle_wait until the rate is known.
  std::chrono::microseconds latch_idle_wait{500};
  std::chrono::milliseconds latch_max_wait{20};
  // The whole run. 0 (default): (revolutions + spare_revolutions + 2) revolutions at the
  // slowest spindle speed the poller has seen in the run, and at least 10 s.
  std::chrono::milliseconds run_timeout{0};
};

// The shortest run timeout derived from the speed.
inline constexpr std::chrono::milliseconds kRunTimeoutFloor{10000};

// The run timeout at a spindle speed: settings.run_timeout when set; else (revolutions +
// spare_revolutions + 2 to find the start) revolutions at speed_rpm (the speed the poller
// sees; <= 0: not seen yet), and never less than kRunTimeoutFloor.
std::chrono::milliseconds run_timeout_at(const PollerSettings& settings, double speed_rpm);

// Checks settings before a run; the message names the setting and its allowed range.
Status validate(const PollerSettings& settings);

// Collects one run, one sample per whole machine degree of C.
// - Live mode polls the snapshot and interpolates each degree between the two polls around
//   it (the cubic through those two and their neighbours). It works with any amplifier
//   but needs the link to keep up with the spindle (docs/acquisition.md).
// - Latched mode reads the amplifier's latch buffer: the reading taken at each encoder
//   degree. Entries must arrive in unbroken degree order; a buffer overrun (the poller fell
//   more than a ring behind) or a jump in degree discards the revolution in progress. A
//   block of entries is taken only once the count read after it shows the ring had not
//   overwritten it. Compact entries (register_map.h, LatchSpec) get their degree from the
//   latch number; before taking any, the count is checked against the encoder angle
//   (kInvalidInput when they disagree), and the amplifier's fault mark counter, when
//   present, discards every revolution holding a mark latched while it rose.
//
// Guarantees, both modes:
// - Only complete revolutions are returned: all 360 degrees sampled, every poll involved
//   with a good gauge status, the angle never going backwards. A revolution that fails any
//   of these is discarded whole and a later one taken instead; degrees of different
//   revolutions are never mixed.
// - Collection starts at the first revolution boundary after the first poll.
// - On a read error the link is closed and reopened with exponential backoff; no sample is
//   interpolated across the gap, so the revolution in progress is discarded.
// - Outages and freezes: the failure count restarts at every good reply, and the stale
//   timer does not count time with the link down. Once the speed is seen, an outage or a
//   freeze is waited out for patience_revolutions beside max_attempts (docs/acquisition.md).
// - A failure returns an Error and no samples: kGaugeUnreachable or kGaugeTimeout when the
//   gauge cannot be reached or stops answering (naming the link's last error), kGaugeTimeout
//   when it stands still while answering (frozen amplifier or stopped spindle),
//   kIncompleteRun when more than spare_revolutions are discarded (naming the last one's
//   status and degrees, or its missing degrees) or the run times out (run_timeout_at).
//
// Thread: runs on the caller's thread; the GaugeClient must not be used elsewhere meanwhile.
// `clock` times the run, the freezes and the backoffs and sleeps the pacing; it must outlive
// the poller.
class Poller {
 public:
  Poller(GaugeClient& gauge, PollerSettings settings, Clock& clock = real_clock());

  // Called on the poller's thread after each complete revolution with the count so far.
  void set_on_revolution(std::function<void(int completed)> callback) { on_revolution_ = std::move(callback); }

  Result<MeasuredRun> measure();

 private:
  GaugeClient& gauge_;
  PollerSettings settings_;
  Clock& clock_;
  std::function<void(int)> on_revolution_;
};

// "12-15, 200, 359" for a set of degrees; "none" when empty.
std::string format_degree_ranges(const std::vector<int>& degrees);

}  // namespace gaugeloop
