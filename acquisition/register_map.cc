// Field decoding, map validation and grouping of fields into block reads.
#include "acquisition/register_map.h"

#include <algorithm>
#include <bit>
#include <cassert>
#include <cmath>

namespace gaugeloop {
namespace {

std::uint16_t swap_bytes(std::uint16_t w) { return static_cast<std::uint16_t>((w << 8) | (w >> 8)); }

struct NamedField {
  const char* name;
  const FieldSpec* field;
};

std::vector<NamedField> live_fields(const RegisterMap& map) {
  return {{"reading", &map.reading},
          {"status", &map.status},
          {"angle", &map.angle},
          {"revolution", &map.revolution},
          {"sequence", &map.sequence}};
}

// The registers from `address` on, in the block that holds all `count` of them.
std::span<const std::uint16_t> words_at(RegisterTable table, int address, int count,
                                        const std::vector<ReadBlock>& blocks,
                                        const std::vector<std::vector<std::uint16_t>>& words) {
  for (size_t b = 0; b < blocks.size(); ++b) {
    const ReadBlock& blk = blocks[b];
    if (blk.table == table && address >= blk.start && address + count <= blk.start + blk.count) {
      return std::span<const std::uint16_t>(words[b]).subspan(static_cast<size_t>(address - blk.start));
    }
  }
  assert(false && "registers outside every block: the block plan and the decoder disagree");
  return {};
}

std::span<const std::uint16_t> field_words(const FieldSpec& f, const std::vector<ReadBlock>& blocks,
                                           const std::vector<std::vector<std::uint16_t>>& words) {
  return words_at(f.table, f.address, register_count(f.type), blocks, words);
}

// A run of registers to read, before grouping into requests.
struct Span {
  RegisterTable table;
  int address;
  int count;
};

// Groups spans of one table lying within kMaxBlockGap of each other into requests of at
// most 125 registers.
std::vector<ReadBlock> group_blocks(std::vector<Span> spans) {
  std::sort(spans.begin(), spans.end(), [](const Span& a, const Span& b) {
    return a.table != b.table ? a.table < b.table : a.address < b.address;
  });
  std::vector<ReadBlock> blocks;
  for (const Span& f : spans) {
    const int end = f.address + f.count;
    if (!blocks.empty() && blocks.back().table == f.table &&
        f.address <= blocks.back().start + blocks.back().count + kMaxBlockGap && end - blocks.back().start <= 125) {
      blocks.back().count = std::max(blocks.back().count, end - blocks.back().start);
    } else {
      blocks.push_back({f.table, f.address, end - f.address});
    }
  }
  return blocks;
}

}  // namespace

int register_count(ValueType type) {
  return type == ValueType::kInt32 || type == ValueType::kUInt32 || type == ValueType::kFloat32 ? 2 : 1;
}

std::string_view word_order_name(WordOrder order) {
  switch (order) {
    case WordOrder::kABCD:
      return "ABCD";
    case WordOrder::kCDAB:
      return "CDAB";
    case WordOrder::kBADC:
      return "BADC";
    case WordOrder::kDCBA:
      return "DCBA";
  }
  return "?";
}

std::string_view register_table_name(RegisterTable table) {
  return table == RegisterTable::kHolding ? "holding" : "input";
}

std::string_view value_type_name(ValueType type) {
  switch (type) {
    case ValueType::kInt16:
      return "INT16";
    case ValueType::kUInt16:
      return "UINT16";
    case ValueType::kInt32:
      return "INT32";
    case ValueType::kUInt32:
      return "UINT32";
    case ValueType::kFloat32:
      return "FLOAT32";
  }
  return "?";
}

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

double decode_raw(const FieldSpec& f, std::span<const std::uint16_t> w) {
  switch (f.type) {
    case ValueType::kInt16:
      return static_cast<std::int16_t>(w[0]);
    case ValueType::kUInt16:
      return w[0];
    case ValueType::kInt32:
      return static_cast<std::int32_t>(decode_u32(w[0], w[1], f.order));
    case ValueType::kUInt32:
      return decode_u32(w[0], w[1], f.order);
    case ValueType::kFloat32:
      return decode_float32(w[0], w[1], f.order);
  }
  return 0.0;
}

GaugeStatus translate_status(std::uint16_t raw, const StatusMasks& m) {
  if (m.ok_value) {
    if (raw == *m.ok_value) return kGaugeReady;
    const std::uint16_t faults = static_cast<std::uint16_t>(raw & ~*m.ok_value);
    return faults == 0 ? GaugeStatus{0} : GaugeStatus{kGaugeReady | kGaugeFault} | (GaugeStatus{faults} << 16);
  }
  GaugeStatus s = 0;
  if (m.ready == 0 || (raw & m.ready) == m.ready) s |= kGaugeReady;
  if (m.over_range != 0 && (raw & m.over_range) != 0) s |= kGaugeOverRange;
  if (m.under_range != 0 && (raw & m.under_range) != 0) s |= kGaugeUnderRange;
  if (m.probe_missing != 0 && (raw & m.probe_missing) != 0) s |= kGaugeProbeMissing;
  return s;
}

Status validate(const RegisterMap& map) {
  auto bad = [](const std::string& what) { return make_error(ErrorCode::kInvalidInput, "register map: " + what); };
  if (!map.reading.present) return bad("`reading` is required");
  if (!map.angle.present) return bad("`angle` is required");
  const auto fields = live_fields(map);
  for (const NamedField& nf : fields) {
    const FieldSpec& f = *nf.field;
    if (!f.present) continue;
    if (f.address < 0 || f.address + register_count(f.type) > 65536) {
      return bad(std::string("`") + nf.name + "` address " + std::to_string(f.address) + " is outside 0..65535");
    }
    if (!std::isfinite(f.scale) || f.scale == 0.0 || !std::isfinite(f.offset)) {
      return bad(std::string("`") + nf.name + "` needs a finite, non-zero scale and a finite offset");
    }
  }
  for (const NamedField& nf : {NamedField{"revolution", &map.revolution}, NamedField{"sequence", &map.sequence},
                               NamedField{"status", &map.status}}) {
    const FieldSpec& f = *nf.field;
    if (f.present && f.type != ValueType::kUInt16 && f.type != ValueType::kUInt32) {
      return bad(std::string("`") + nf.name + "` must be UINT16 or UINT32, not " +
                 std::string(value_type_name(f.type)));
    }
  }
  for (size_t i = 0; i < fields.size(); ++i) {
    for (size_t j = i + 1; j < fields.size(); ++j) {
      const FieldSpec& a = *fields[i].field;
      const FieldSpec& b = *fields[j].field;
      if (!a.present || !b.present || a.table != b.table) continue;
      if (a.address < b.address + register_count(b.type) && b.address < a.address + register_count(a.type)) {
        return bad(std::string("`") + fields[i].name + "` and `" + fields[j].name + "` overlap at " +
                   std::string(register_table_name(a.table)) + " register " +
                   std::to_string(std::max(a.address, b.address)));
      }
    }
  }
  if (map.latch.present) {
    const LatchSpec& l = map.latch;
    const int reading_words = register_count(map.reading.type);
    if (l.entry_words < 1 || l.entry_words > 125) return bad("latch `entry_words` must be 1..125");
    auto inside = [&l](int offset, int words) { return offset >= 0 && offset + words <= l.entry_words; };
    if (!inside(l.reading_offset, reading_words) || (!l.degree_implied() && !inside(l.degree_offset, 1)) ||
        (l.status_offset != -1 && !inside(l.status_offset, 1))) {
      return bad("latch entry layout: reading, degree and status offsets must lie inside the " +
                 std::to_string(l.entry_words) +
                 "-register entry (degree_offset -1: implied by the latch count; status_offset -1: none)");
    }
    struct Part {
      const char* name;
      int offset;
      int words;
    };
    std::vector<Part> parts = {{"reading", l.reading_offset, reading_words}};
    if (!l.degree_implied()) parts.push_back({"degree", l.degree_offset, 1});
    if (l.status_offset >= 0) parts.push_back({"status", l.status_offset, 1});
    for (size_t i = 0; i < parts.size(); ++i) {
      for (size_t j = i + 1; j < parts.size(); ++j) {
        if (parts[i].offset < parts[j].offset + parts[j].words && parts[j].offset < parts[i].offset + parts[i].words) {
          return bad(std::string("latch entry layout: the ") + parts[i].name + " and the " + parts[j].name +
                     " overlap at offset " + std::to_string(std::max(parts[i].offset, parts[j].offset)));
        }
      }
    }
    if (l.ring_size < 0 || l.ring_size > 65535) return bad("latch `ring_size` must be 0 (read it) to 65535");
    if (l.fault_count_address < -1 || l.fault_count_address > 65534 || l.fault_status_address < -1 ||
        l.fault_status_address > 65535) {
      return bad("latch `fault_count_address` and `fault_status_address` must be -1 (none) or a register address");
    }
    if (l.fault_status_address >= 0 && l.fault_count_address < 0) {
      return bad("latch `fault_status_address` needs `fault_count_address`: the status is read when the count rises");
    }
    if (l.fault_count_address >= 0 && l.fault_count_address < l.count_address + 2 &&
        l.count_address < l.fault_count_address + 2) {
      return bad("latch `fault_count_address` overlaps the latch count at register " +
                 std::to_string(std::max(l.count_address, l.fault_count_address)));
    }
    if (l.degree_implied() && l.status_offset < 0 && l.fault_count_address < 0 && map.status.present) {
      return bad(
          "latch: compact entries (degree_offset = -1) without a status word would let an over-range or a "
          "missing probe become a run; give `status_offset` (a status word in each entry) or "
          "`fault_count_address` (the amplifier's count of marks latched with a bad status)");
    }
  }
  return {};
}

std::vector<ReadBlock> snapshot_blocks(const RegisterMap& map) {
  std::vector<Span> spans;
  for (const NamedField& nf : live_fields(map)) {
    const FieldSpec& f = *nf.field;
    if (f.present) spans.push_back({f.table, f.address, register_count(f.type)});
  }
  return group_blocks(std::move(spans));
}

GaugeSnapshot decode_snapshot(const RegisterMap& map, const std::vector<ReadBlock>& blocks,
                              const std::vector<std::vector<std::uint16_t>>& words, std::uint64_t polls) {
  auto value = [&](const FieldSpec& f) { return decode_raw(f, field_words(f, blocks, words)) * f.scale + f.offset; };
  GaugeSnapshot s;
  s.reading_mm = value(map.reading);
  double angle = std::fmod(value(map.angle), 360.0);
  if (angle < 0.0) angle += 360.0;
  s.angle_deg = angle;
  s.revolution =
      map.revolution.present ? static_cast<std::uint16_t>(static_cast<std::uint64_t>(value(map.revolution))) : 0;
  s.sequence = map.sequence.present ? static_cast<std::uint16_t>(static_cast<std::uint64_t>(value(map.sequence)))
                                    : static_cast<std::uint16_t>(polls);
  s.status =
      map.status.present
          ? translate_status(static_cast<std::uint16_t>(decode_raw(map.status, field_words(map.status, blocks, words))),
                             map.masks)
          : GaugeStatus{kGaugeReady};
  return s;
}

int latched_entries_per_read(const RegisterMap& map) { return 125 / map.latch.entry_words; }

std::vector<ReadBlock> latch_state_blocks(const RegisterMap& map) {
  const LatchSpec& l = map.latch;
  std::vector<Span> spans = {{l.table, l.count_address, 2}};
  if (l.ring_size == 0) spans.push_back({l.table, l.ring_size_address, 1});
  if (l.fault_count_address >= 0) spans.push_back({l.table, l.fault_count_address, 2});
  if (l.fault_status_address >= 0) spans.push_back({l.table, l.fault_status_address, 1});
  return group_blocks(std::move(spans));
}

LatchState decode_latch_state(const RegisterMap& map, const std::vector<ReadBlock>& blocks,
                              const std::vector<std::vector<std::uint16_t>>& words) {
  const LatchSpec& l = map.latch;
  auto u32_at = [&](int address) {
    const auto w = words_at(l.table, address, 2, blocks, words);
    return decode_u32(w[0], w[1], l.order);
  };
  LatchState st;
  st.write_count = u32_at(l.count_address);
  st.ring_size = l.ring_size > 0 ? l.ring_size : words_at(l.table, l.ring_size_address, 1, blocks, words)[0];
  st.entries_per_read = latched_entries_per_read(map);
  st.degree_implied = l.degree_implied();
  if (l.fault_count_address >= 0) st.fault_count = u32_at(l.fault_count_address);
  if (l.fault_status_address >= 0) {
    st.fault_status = translate_status(words_at(l.table, l.fault_status_address, 1, blocks, words)[0], map.masks);
  }
  return st;
}

std::vector<LatchedSample> decode_latched(const RegisterMap& map, std::span<const std::uint16_t> regs) {
  const LatchSpec& l = map.latch;
  std::vector<LatchedSample> out;
  const size_t words = static_cast<size_t>(l.entry_words);
  out.reserve(regs.size() / words);
  for (size_t at = 0; at + words <= regs.size(); at += words) {
    const auto entry = regs.subspan(at, words);
    LatchedSample e;
    e.reading_mm = decode_raw(map.reading, entry.subspan(static_cast<size_t>(l.reading_offset))) * map.reading.scale +
                   map.reading.offset;
    e.degree = l.degree_implied() ? kDegreeImpliedByCount : entry[static_cast<size_t>(l.degree_offset)];
    e.status = l.status_offset >= 0 ? translate_status(entry[static_cast<size_t>(l.status_offset)], map.masks)
                                    : GaugeStatus{kGaugeReady};
    out.push_back(e);
  }
  return out;
}

}  // namespace gaugeloop
