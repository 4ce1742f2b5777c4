// What the benchmarks share: the thread's CPU clock, inputs that must load, and the two sample
// lobes as parts with their design lift tables.
#pragma once

#include <time.h>

#include <cstdio>
#include <cstdlib>
#include <string>
#include <utility>

#include "core/lift_table.h"
#include "core/part.h"
#include "core/result.h"

namespace gaugeloop::bench {

// CPU time of this thread: on a machine shared with builds, wall time measures the others.
inline double thread_cpu_s() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

// The value, or the message and abort: a benchmark on inputs that did not load measures nothing.
template <typename T>
T or_die(Result<T> r, const char* what) {
  if (!r.ok()) {
    std::fprintf(stderr, "%s: %s\n", what, r.error().message.c_str());
    std::abort();
  }
  return std::move(r).value();
}

// Sample lobe 0 (intake_flat: flat follower, 200 mm wheel) or 1 (exhaust_roller: 11 mm roller,
// 45 mm wheel, concave flanks), and its design lift table from examples/.
struct SampleLobe {
  Part part;
  LiftTable design;
};

inline SampleLobe sample_lobe(int which) {
  Part part;
  part.name = which == 0 ? "intake_flat" : "exhaust_roller";
  part.follower = which == 0 ? FollowerKind::kFlat : FollowerKind::kRoller;
  part.follower_radius_mm = which == 0 ? 0.0 : 11.0;
  part.base_circle_radius_mm = which == 0 ? 18.0 : 17.0;
  part.wheel_radius_mm = which == 0 ? 200.0 : 45.0;
  LiftTable design =
      or_die(read_lift_table_csv(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/" + part.name + ".csv"), "lift table");
  return {std::move(part), std::move(design)};
}

}  // namespace gaugeloop::bench
