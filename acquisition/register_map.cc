// Word-order decoding and the snapshot layout.
#include "acquisition/register_map.h"

#include <bit>
#include <cassert>
#include <cmath>

namespace gaugeloop {
namespace {

std::uint16_t swap_bytes(std::uint16_t w) { return static_cast<std::uint16_t>((w << 8) | (w >> 8)); }

}  // namespace

std::uint32_t decode_u32(std::uint16_t first, std::uint16_t second, WordOrder order) {
  std::uint16_t hi = first;
  std::uint16_t lo = second;
  switch (order) {
    case WordOrder::kABCD:
      break;
    case WordOrder::kCDAB:
      hi = second;
      lo = first;
      break;
    case WordOrder::kBADC:
      hi = swap_bytes(first);
      lo = swap_bytes(second);
      break;
    case WordOrder::kDCBA:
      hi = swap_bytes(second);
      lo = swap_bytes(first);
      break;
  }
  return (static_cast<std::uint32_t>(hi) << 16) | lo;
}

float decode_float32(std::uint16_t first, std::uint16_t second, WordOrder order) {
  return std::bit_cast<float>(decode_u32(first, second, order));
}

GaugeSnapshot decode_snapshot(const RegisterMap& map, std::span<const std::uint16_t> regs) {
  assert(static_cast<int>(regs.size()) == map.count);
  GaugeSnapshot s;
  const auto counts =
      static_cast<std::int32_t>(decode_u32(regs[map.reading_offset], regs[map.reading_offset + 1], map.word_order));
  s.reading_mm = counts * map.reading_mm_per_count;
  s.status = regs[map.status_offset];
  const std::uint32_t angle_counts = decode_u32(regs[map.angle_offset], regs[map.angle_offset + 1], map.word_order);
  s.angle_deg = std::fmod(angle_counts * map.angle_deg_per_count, 360.0);
  s.revolution = regs[map.revolution_offset];
  s.sequence = regs[map.sequence_offset];
  return s;
}

int latched_entries_per_read(const RegisterMap& map) { return 125 / map.latch_entry_words; }

std::vector<LatchedSample> decode_latched(const RegisterMap& map, std::span<const std::uint16_t> regs) {
  std::vector<LatchedSample> out;
  const size_t words = static_cast<size_t>(map.latch_entry_words);
  out.reserve(regs.size() / words);
  for (size_t at = 0; at + words <= regs.size(); at += words) {
    LatchedSample e;
    const auto counts = static_cast<std::int32_t>(decode_u32(regs[at], regs[at + 1], map.word_order));
    e.reading_mm = counts * map.reading_mm_per_count;
    e.degree = regs[at + 2];
    e.status = regs[at + 3];
    out.push_back(e);
  }
  return out;
}

}  // namespace gaugeloop
