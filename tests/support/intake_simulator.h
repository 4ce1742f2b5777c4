// The sample intake lobe and a simulator turning it, for acquisition tests and benchmarks.
// Needs GAUGELOOP_SOURCE_DIR (set by tests/ and bench/ CMake).
#pragma once

#include <filesystem>
#include <memory>

#include "core/lift_table.h"
#include "core/part.h"
#include "simulator/gauge_simulator.h"

namespace gaugeloop::testing {

// examples/intake_flat: flat follower, base circle 18 mm, wheel 200 mm, sense +1, no offsets.
inline Part intake_part() {
  Part p;
  p.name = "intake_flat";
  p.base_circle_radius_mm = 18.0;
  p.wheel_radius_mm = 200.0;
  return p;
}

inline Result<LiftTable> intake_table() {
  return read_lift_table_csv(std::filesystem::path(GAUGELOOP_SOURCE_DIR) / "examples" / "intake_flat.csv");
}

// Starts a simulator on the intake lobe; the error (missing file, bad settings, busy port)
// comes back for the caller to assert on.
inline Result<std::unique_ptr<GaugeSimulator>> start_intake_simulator(const SimulatorSettings& settings = {}) {
  Result<LiftTable> table = intake_table();
  if (!table) return table.error();
  return GaugeSimulator::start(intake_part(), *table, settings);
}

}  // namespace gaugeloop::testing
