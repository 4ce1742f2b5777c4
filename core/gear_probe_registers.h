// The grinder's flank probe for gears, over Modbus: the block of holding registers through which
// gaugeloop asks the machine for one point of a tooth flank (gap, flank, height Z across the
// face) and reads the deviation the probe found there (docs/gears.md, "The flank probe"). The
// one layout the link (acquisition/gear_probe.h) and the virtual machine's probe
// (simulator/gear_probe_simulator.h) share.
#pragma once

#include <cstdint>

namespace gaugeloop {

// Offsets from the configured base address, in the machine's holding registers (function 03 to
// read, 16 to write). Words 0-4 are gaugeloop's, written in one request; 5-10 the machine's,
// read in one request. 32-bit values are two words, high word first (ABCD).
namespace gear_probe_registers {
inline constexpr int kRequestSequence = 0;  // gaugeloop: +1 for each point asked (wraps, never 0)
inline constexpr int kGap = 1;              // gaugeloop: the tooth gap, 1-based
inline constexpr int kFlank = 2;            // gaugeloop: 0 left, 1 right
inline constexpr int kZ = 3;                // gaugeloop: int32, the height on the face, 0.1 um
inline constexpr int kAnswerSequence = 5;   // machine: the request sequence the words below answer
inline constexpr int kStatus = 6;           // machine: 0 ok, else the bits below
inline constexpr int kDeviation = 7;        // machine: int32, the flank's deviation, nm
inline constexpr int kZMeasured = 9;        // machine: int32, where the probe touched, 0.1 um
inline constexpr int kRequestWords = 5;     // words 0..4
inline constexpr int kAnswerWords = 6;      // words 5..10
inline constexpr int kBlockWords = 11;
// Status bits.
inline constexpr std::uint16_t kNoContact = 0x0001;   // the probe did not touch the flank
inline constexpr std::uint16_t kOverRange = 0x0002;   // the probe's reading is beyond its range
inline constexpr std::uint16_t kOutOfReach = 0x0004;  // gap, flank or Z the machine cannot reach
inline constexpr std::uint16_t kProbeFault = 0x0008;  // the probe or its amplifier reports a fault
inline constexpr double kZUnitMm = 1e-4;              // 0.1 um
inline constexpr double kDeviationUnitUm = 1e-3;      // 1 nm
}  // namespace gear_probe_registers

}  // namespace gaugeloop
