// The sample intake lobe and a simulator turning it, for acquisition tests and benchmarks.
// Needs GAUGELOOP_SOURCE_DIR (set by tests/ and bench/ CMake).
#pragma once

#include <filesystem>
#include <memory>

#include "acquisition/register_map.h"
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

// The simulator's register map read through its compact latch ring (docs/simulator.md): the
// reading alone, 2 registers an entry, the degree implied by the latch count, the status from
// the fault mark counter.
inline RegisterMap compact_simulator_map() {
  RegisterMap m;
  m.latch.ring_size_address = sim_registers::kCompactRingSize;
  m.latch.ring_address = sim_registers::kCompactRing;
  m.latch.entry_words = 2;
  m.latch.reading_offset = 0;
  m.latch.degree_offset = kDegreeImpliedByCount;
  m.latch.status_offset = -1;
  m.latch.fault_count_address = sim_registers::kFaultMarkCount;
  m.latch.fault_status_address = sim_registers::kFaultMarkStatus;
  return m;
}

}  // namespace gaugeloop::testing
