// What the poller's two collectors (live_collector.cc, latched_collector.cc) share: the run
// so far, the link, the run's timers, and the revolution being filled. Internal to
// acquisition/; Poller (poller.h) is the interface and its contract.
#pragma once

#include <bitset>
#include <cstdint>
#include <functional>
#include <string>

#include "acquisition/gauge_client.h"
#include "acquisition/gauge_link.h"
#include "acquisition/poller.h"
#include "acquisition/run_watches.h"
#include "core/clock.h"
#include "core/result.h"
#include "core/run.h"

namespace gaugeloop {

// One run's inputs; every reference outlives the collection.
struct CollectorContext {
  GaugeClient& gauge;
  const PollerSettings& settings;  // already validated
  Clock& clock;
  const std::function<void(int completed)>& on_revolution;  // may be empty
};

// Poller::measure in each mode (poller.h has the contract).
Result<MeasuredRun> collect_live(const CollectorContext& context);
Result<MeasuredRun> collect_latched(const CollectorContext& context);

// The degrees of one revolution as they are filled, and what has spoilt it.
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

// The state both modes keep for a run, and the steps they take alike. Not thread-safe: one
// run on the caller's thread.
class Collector {
 protected:
  explicit Collector(const CollectorContext& context);

  bool complete() const { return static_cast<int>(run_.revolutions.size()) >= wanted_; }
  // "during revolution 2 of 3", for messages.
  std::string where_now() const;
  // Keeps a complete revolution, reports it; or counts it discarded, naming why.
  void finish_revolution(std::int64_t number, const RevolutionInProgress& rev);
  void count_discarded(std::int64_t number, const std::string& why);
  // The run as it stands once the wanted revolutions are in.
  MeasuredRun finished();

  // The run fails: more revolutions discarded than there are spares.
  Error too_many_discarded(const char* advice) const;
  // The run fails: the run timeout has passed.
  Error timed_out() const;
  // The run fails: the amplifier stood still for the freeze watch's whole patience.
  Error frozen(const std::string& what_stood_still) const;

  GaugeClient& gauge_;
  const PollerSettings& settings_;
  Clock& clock_;
  const std::function<void(int)>& on_revolution_;
  const int wanted_;
  MeasuredRun run_;
  GaugeLink link_;
  RunBudget budget_;
  FreezeWatch freeze_;
  std::string last_discard_;  // why the most recent revolution was thrown away
};

}  // namespace gaugeloop
