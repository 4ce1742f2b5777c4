// Where the gauge amplifier keeps each value, and how to decode 16-bit words into numbers.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "acquisition/gauge_client.h"

namespace gaugeloop {

// Order of the four bytes of a 32-bit value across two registers, as Telegraf names it:
// ABCD = high word first, big-endian bytes (Modbus convention); CDAB = low word first;
// BADC = high word first, bytes swapped; DCBA = low word first, bytes swapped.
enum class WordOrder { kABCD, kCDAB, kBADC, kDCBA };

// Decodes two registers (as received, in address order) into 32 bits. Written here rather
// than using libmodbus's float helpers, whose names are mirrored on little-endian hosts.
std::uint32_t decode_u32(std::uint16_t first, std::uint16_t second, WordOrder order);
float decode_float32(std::uint16_t first, std::uint16_t second, WordOrder order);

// The input-register block of the gauge, read in one request so the snapshot is consistent.
// Defaults are the simulator's map (docs/simulator.md); issue 4 makes it configuration.
struct RegisterMap {
  int start_address = 0;                 // 0-based address of the block
  int count = 7;                         // registers in the block
  int reading_offset = 0;                // int32 counts
  double reading_mm_per_count = 0.0001;  // 0.1 um
  int status_offset = 2;
  int angle_offset = 3;  // uint32 counts
  double angle_deg_per_count = 0.001;
  int revolution_offset = 5;
  int sequence_offset = 6;
  WordOrder word_order = WordOrder::kABCD;

  // Latch buffer (latched mode).
  int latch_count_address = 100;      // uint32 write count
  int latch_ring_size_address = 102;  // uint16 entries in the ring
  int latch_ring_address = 1000;      // first entry
  int latch_entry_words = 4;          // reading int32 (2), degree uint16, status uint16
};

// Entries per request: a Modbus read returns at most 125 registers.
int latched_entries_per_read(const RegisterMap& map);

// Decodes `count` consecutive entries of the ring.
std::vector<LatchedSample> decode_latched(const RegisterMap& map, std::span<const std::uint16_t> regs);

// Decodes one block (exactly map.count registers from map.start_address).
GaugeSnapshot decode_snapshot(const RegisterMap& map, std::span<const std::uint16_t> regs);

}  // namespace gaugeloop
