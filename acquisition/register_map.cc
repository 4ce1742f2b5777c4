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

// The block and offset holding a field, found by address.
std::span<const std::uint16_t> field_words(const FieldSpec& f, const std::vector<ReadBlock>& blocks,
                                           const std::vector<std::vector<std::uint16_t>>& words) {
  for (size_t b = 0; b < blocks.size(); ++b) {
    const ReadBlock& blk = blocks[b];
    if (blk.table == f.table && f.address >= blk.start && f.address + register_count(f.type) <= blk.start + blk.count) {
      return std::span<const std::uint16_t>(words[b]).subspan(static_cast<size_t>(f.address - blk.start));
    }
  }
  assert(false && "field outside every block: snapshot_blocks and decode_snapshot disagree");
  return {};
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

std::uint16_t translate_status(std::uint16_t raw, const StatusMasks& m) {
  std::uint16_t s = 0;
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
    if (l.reading_offset < 0 || l.reading_offset + reading_words > l.entry_words || l.degree_offset < 0 ||
        l.degree_offset >= l.entry_words || l.status_offset >= l.entry_words) {
      return bad("latch entry layout: reading, degree and status offsets must lie inside the " +
                 std::to_string(l.entry_words) + "-register entry");
    }
    if (l.ring_size < 0 || l.ring_size > 65535) return bad("latch `ring_size` must be 0 (read it) to 65535");
  }
  return {};
}

std::vector<ReadBlock> snapshot_blocks(const RegisterMap& map) {
  std::vector<const FieldSpec*> present;
  for (const NamedField& nf : live_fields(map)) {
    if (nf.field->present) present.push_back(nf.field);
  }
  std::sort(present.begin(), present.end(), [](const FieldSpec* a, const FieldSpec* b) {
    return a->table != b->table ? a->table < b->table : a->address < b->address;
  });
  std::vector<ReadBlock> blocks;
  for (const FieldSpec* f : present) {
    const int end = f->address + register_count(f->type);
    if (!blocks.empty() && blocks.back().table == f->table &&
        f->address <= blocks.back().start + blocks.back().count + kMaxBlockGap && end - blocks.back().start <= 125) {
      blocks.back().count = std::max(blocks.back().count, end - blocks.back().start);
    } else {
      blocks.push_back({f->table, f->address, end - f->address});
    }
  }
  return blocks;
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
          : static_cast<std::uint16_t>(kGaugeReady);
  return s;
}

int latched_entries_per_read(const RegisterMap& map) { return 125 / map.latch.entry_words; }

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
    e.degree = entry[static_cast<size_t>(l.degree_offset)];
    e.status = l.status_offset >= 0 ? translate_status(entry[static_cast<size_t>(l.status_offset)], map.masks)
                                    : static_cast<std::uint16_t>(kGaugeReady);
    out.push_back(e);
  }
  return out;
}

}  // namespace gaugeloop
