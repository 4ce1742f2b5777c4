// Where a gauge amplifier keeps each value, and how to decode its 16-bit words into numbers.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "acquisition/gauge_client.h"
#include "core/result.h"

namespace gaugeloop {

// Order of the four bytes of a 32-bit value across two registers, as Telegraf names it:
// ABCD = high word first, big-endian bytes (Modbus convention); CDAB = low word first;
// BADC = high word first, bytes swapped; DCBA = low word first, bytes swapped.
enum class WordOrder { kABCD, kCDAB, kBADC, kDCBA };

enum class RegisterTable {
  kHolding,  // function 03
  kInput,    // function 04
};

enum class ValueType { kInt16, kUInt16, kInt32, kUInt32, kFloat32 };

// Registers a value of this type occupies: 1 or 2.
int register_count(ValueType type);

std::string_view word_order_name(WordOrder order);
std::string_view register_table_name(RegisterTable table);
std::string_view value_type_name(ValueType type);

// Decodes two registers (as received, in address order) into 32 bits. Written here rather
// than using libmodbus 3.1.6's float helpers, whose names are mirrored on little-endian hosts.
std::uint32_t decode_u32(std::uint16_t first, std::uint16_t second, WordOrder order);
float decode_float32(std::uint16_t first, std::uint16_t second, WordOrder order);

// One value in the amplifier: raw register(s) -> number -> raw * scale + offset.
struct FieldSpec {
  bool present = true;  // optional fields may be absent
  RegisterTable table = RegisterTable::kInput;
  int address = 0;  // 0-based
  ValueType type = ValueType::kUInt16;
  WordOrder order = WordOrder::kABCD;  // for 32-bit types
  double scale = 1.0;
  double offset = 0.0;
};

// The raw number a field holds (before scale and offset). `words` starts at the field.
double decode_raw(const FieldSpec& field, std::span<const std::uint16_t> words);

// The amplifier's status word, described one of two ways (docs/gauge.md):
// - Masks (ok_value unset): ready when every bit of `ready` is set (0: always); each fault
//   mask means that fault when any of its bits is set (0: not reported).
// - An ok value: the word equals ok_value when the reading can be used. Any bit set that is
//   clear in ok_value is a fault of the amplifier's own (kGaugeFault, its bit kept), named by
//   bit_names; a word that lacks bits of ok_value and has none extra is "not ready".
struct StatusMasks {
  std::uint16_t ready = 0x0001;
  std::uint16_t over_range = 0x0002;
  std::uint16_t under_range = 0x0004;
  std::uint16_t probe_missing = 0x0008;
  std::optional<std::uint16_t> ok_value;
  StatusBitNames bit_names;
};

// The amplifier's status word translated to GaugeStatusBit flags.
GaugeStatus translate_status(std::uint16_t raw, const StatusMasks& masks);

// The latch buffer for latched mode: a count of latched degree marks (uint32, the map's word
// order), the ring size (fixed, or read from a register), and the ring of entries. Latch
// number n (the count's value before it was latched) lives in ring slot n mod ring size.
//
// Two entry layouts:
// - Labelled (degree_offset >= 0): each entry carries the machine degree its amplifier
//   latched it at. An entry overwritten while it is read shows a different degree.
// - Compact (degree_offset == kDegreeImpliedByCount): the entry is the reading alone (plus
//   a status word if status_offset >= 0). Latch number n is machine degree n mod 360 of
//   revolution n / 360: the amplifier zeroes its count at an encoder index pulse and latches
//   every degree mark after it, so mark 0 is machine degree 0. The poller checks that
//   frame against the angle field before it takes any entry (a count not zeroed at the
//   index, or wrapped past 2^32, which is not a multiple of 360, is refused), and confirms
//   each block against the count read after it (an overwritten entry cannot show itself).
//
// Status of entries without a status word (status_offset == -1): when the amplifier keeps
// a fault mark counter (fault_count_address >= 0: uint32, the map's word order, marks
// latched since start whose status was not ready or had a fault bit; optionally at
// fault_status_address the uint16 status word of the latest such mark), every revolution
// holding a latch number between two count reads across which the counter rose is
// discarded. A compact layout on a map with a status field must have one of the two.
inline constexpr int kDegreeImpliedByCount = -1;

struct LatchSpec {
  bool present = true;
  RegisterTable table = RegisterTable::kInput;
  int count_address = 100;
  int ring_size = 0;  // > 0: fixed size; 0: read from ring_size_address
  int ring_size_address = 102;
  int ring_address = 1000;
  int entry_words = 4;
  int reading_offset = 0;              // within an entry; decoded like the reading field (type, order, scale)
  int degree_offset = 2;               // uint16 whole machine degree; kDegreeImpliedByCount: compact
  int status_offset = 3;               // uint16 status word; -1: none
  int fault_count_address = -1;        // uint32 fault mark counter (same table as the count); -1: none
  int fault_status_address = -1;       // uint16 status of the latest fault mark; -1: none
  WordOrder order = WordOrder::kABCD;  // of the count and the fault counter

  bool degree_implied() const { return degree_offset == kDegreeImpliedByCount; }
};

// Where the gauge keeps what the poller needs. Defaults are the simulator's map
// (docs/simulator.md); a gauge config file (docs/gauge.md) describes any other amplifier.
struct RegisterMap {
  // Gauge reading, scaled to mm (defaults: int32 counts of 0.1 um).
  FieldSpec reading{true, RegisterTable::kInput, 0, ValueType::kInt32, WordOrder::kABCD, 0.0001, 0.0};
  FieldSpec status{true, RegisterTable::kInput, 2, ValueType::kUInt16, WordOrder::kABCD, 1.0, 0.0};
  // Work spindle angle, scaled to degrees (defaults: uint32 counts of 0.001 deg).
  FieldSpec angle{true, RegisterTable::kInput, 3, ValueType::kUInt32, WordOrder::kABCD, 0.001, 0.0};
  // Revolution count; absent: a revolution is counted when the angle wraps.
  FieldSpec revolution{true, RegisterTable::kInput, 5, ValueType::kUInt16, WordOrder::kABCD, 1.0, 0.0};
  // Amplifier sample number; absent: every poll counts as a new sample (no stale detection).
  FieldSpec sequence{true, RegisterTable::kInput, 6, ValueType::kUInt16, WordOrder::kABCD, 1.0, 0.0};
  StatusMasks masks;
  LatchSpec latch;
};

// Checks a map: required fields present, addresses in range, fields not overlapping, 32-bit
// types only where a value needs them, latch layout inside its entry. Messages name the field.
Status validate(const RegisterMap& map);

// A run of registers read in one request.
struct ReadBlock {
  RegisterTable table = RegisterTable::kInput;
  int start = 0;
  int count = 0;
};

// The requests that read every live field: fields of one table whose registers lie within
// kMaxBlockGap of each other share one request (at most 125 registers), so a snapshot that
// the amplifier keeps contiguous costs one request.
inline constexpr int kMaxBlockGap = 8;
std::vector<ReadBlock> snapshot_blocks(const RegisterMap& map);

// Decodes a snapshot from the registers of `blocks` (one span per block, in order).
// `polls` stands in for the sequence number when the map has none.
GaugeSnapshot decode_snapshot(const RegisterMap& map, const std::vector<ReadBlock>& blocks,
                              const std::vector<std::vector<std::uint16_t>>& words, std::uint64_t polls);

// Entries per request: a Modbus read returns at most 125 registers.
int latched_entries_per_read(const RegisterMap& map);

// The requests that read the latch state: the count, the ring size register (when the size
// is not fixed) and the fault registers, grouped like snapshot_blocks.
std::vector<ReadBlock> latch_state_blocks(const RegisterMap& map);

// Decodes the latch state from the registers of latch_state_blocks (one span per block).
// ring_size is not checked here.
LatchState decode_latch_state(const RegisterMap& map, const std::vector<ReadBlock>& blocks,
                              const std::vector<std::vector<std::uint16_t>>& words);

// Decodes consecutive ring entries. In the compact layout each entry's degree is
// kDegreeImpliedByCount: the poller knows it from the latch number.
std::vector<LatchedSample> decode_latched(const RegisterMap& map, std::span<const std::uint16_t> regs);

}  // namespace gaugeloop
