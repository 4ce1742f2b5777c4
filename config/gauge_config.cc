// toml++ reading of gauge configs into ModbusSettings and a RegisterMap.
#include "config/gauge_config.h"

#include <algorithm>

#include "acquisition/tcp_endpoint.h"
#include "config/toml_reader.h"
#include "core/text_file.h"

namespace gaugeloop {
namespace {

WordOrder word_order(const std::string& s) {
  return s == "CDAB"   ? WordOrder::kCDAB
         : s == "BADC" ? WordOrder::kBADC
         : s == "DCBA" ? WordOrder::kDCBA
                       : WordOrder::kABCD;
}

RegisterTable register_table(const std::string& s) {
  return s == "holding" ? RegisterTable::kHolding : RegisterTable::kInput;
}

ValueType value_type(const std::string& s) {
  return s == "INT16"     ? ValueType::kInt16
         : s == "INT32"   ? ValueType::kInt32
         : s == "UINT32"  ? ValueType::kUInt32
         : s == "FLOAT32" ? ValueType::kFloat32
                          : ValueType::kUInt16;
}

// Reads the status word's description: the masks, or ok_value and the names of its bits
// ([map.status.bits], bit number = name). The two ways are not mixed.
void read_status_masks(TomlReader& r, std::string_view source, StatusMasks& masks) {
  const bool by_masks =
      r.has("ready_mask") || r.has("over_range_mask") || r.has("under_range_mask") || r.has("probe_missing_mask");
  if (!r.has("ok_value")) {
    if (r.has("bits")) r.fail(r.where("bits") + ": names status bits of an ok_value status word; give ok_value too");
    masks.ready = static_cast<std::uint16_t>(r.integer("ready_mask", 0x0001, 0, 0xffff));
    masks.over_range = static_cast<std::uint16_t>(r.integer("over_range_mask", 0, 0, 0xffff));
    masks.under_range = static_cast<std::uint16_t>(r.integer("under_range_mask", 0, 0, 0xffff));
    masks.probe_missing = static_cast<std::uint16_t>(r.integer("probe_missing_mask", 0, 0, 0xffff));
    return;
  }
  if (by_masks) r.fail(r.where("ok_value") + ": give either ok_value (and bits) or the masks, not both");
  masks.ok_value = static_cast<std::uint16_t>(r.integer("ok_value", std::nullopt, 0, 0xffff));
  const toml::table* bits = r.subtable("bits");
  if (bits == nullptr) return;
  TomlReader br(*bits, source, "map.status.bits.");
  for (auto&& [key, value] : *bits) {
    const std::string k(key.str());
    int bit = -1;
    if (k.size() <= 2 && std::all_of(k.begin(), k.end(), [](char c) { return c >= '0' && c <= '9'; }))
      bit = std::stoi(k);
    if (bit < 0 || bit > 15) {
      br.fail(br.where(k) + ": a status bit is a number 0 to 15");
      break;
    }
    masks.bit_names[static_cast<size_t>(bit)] = br.text(k, std::nullopt);
  }
  if (br.error) r.fail(br.error->message);
}

// Reads [map.<name>] into `f`; absent table = absent field. Returns the reader's error state.
void read_field(std::string_view name, std::string_view source, WordOrder default_order, FieldSpec& f,
                TomlReader& parent, bool is_status, StatusMasks* masks) {
  const toml::table* t = parent.subtable(name);
  if (t == nullptr) {
    f.present = false;
    return;
  }
  TomlReader r(*t, source, "map." + std::string(name) + ".");
  if (is_status) {
    r.allow_only({"register", "address", "type", "ready_mask", "over_range_mask", "under_range_mask",
                  "probe_missing_mask", "ok_value", "bits"});
  } else {
    r.allow_only({"register", "address", "type", "byte_order", "scale", "offset"});
  }
  f.present = true;
  f.table = register_table(r.choice("register", "input", {"holding", "input"}));
  f.address = static_cast<int>(r.integer("address", std::nullopt, 0, 65535));
  f.type = value_type(r.choice("type", is_status ? std::optional<std::string>("UINT16") : std::nullopt,
                               {"INT16", "UINT16", "INT32", "UINT32", "FLOAT32"}));
  if (is_status) {
    read_status_masks(r, source, *masks);
  } else {
    f.order = word_order(
        r.choice("byte_order", std::string(word_order_name(default_order)), {"ABCD", "CDAB", "BADC", "DCBA"}));
    f.scale = r.number("scale", 1.0, -1e12, 1e12);
    f.offset = r.number("offset", 0.0, -1e12, 1e12);
  }
  if (r.error) parent.fail(r.error->message);
}

}  // namespace

void read_modbus_link(TomlReader& lr, const ModbusSettings& defaults, ModbusSettings& out, std::string_view device) {
  const bool rtu = lr.choice("transport", "tcp", {"tcp", "rtu"}) == "rtu";
  out.transport = rtu ? ModbusTransport::kRtu : ModbusTransport::kTcp;
  if (rtu) {
    for (const char* tcp_key : {"host", "port"}) {
      if (lr.has(tcp_key)) lr.fail(lr.where(tcp_key) + ": a TCP setting in an RTU link; remove it");
    }
    out.device = lr.text("device", std::nullopt);
    out.baud = static_cast<int>(lr.integer("baud", defaults.baud, 300, 4000000));
    out.parity = lr.choice("parity", std::string(1, defaults.parity), {"N", "E", "O"})[0];
    out.data_bits = static_cast<int>(lr.integer("data_bits", defaults.data_bits, 7, 8));
    out.stop_bits = static_cast<int>(lr.integer("stop_bits", defaults.stop_bits, 1, 2));
  } else {
    for (const char* rtu_key : {"device", "baud", "parity", "data_bits", "stop_bits"}) {
      if (lr.has(rtu_key)) lr.fail(lr.where(rtu_key) + ": a serial setting in a TCP link; set transport = \"rtu\"");
    }
    out.host = lr.text("host", defaults.host);
    out.port = static_cast<int>(lr.integer("port", defaults.port, 1, 65535));
    // A name that does not exist fails now, not at the first run. A resolver that cannot
    // answer now (kGaugeUnreachable) is let pass: the name may exist, and the link retries.
    if (!lr.error) {
      Status resolved = resolve_tcp_host(out.host, out.port, device);
      if (!resolved && resolved.error().code == ErrorCode::kInvalidInput) {
        lr.fail(lr.where("host") + ": " + resolved.error().message);
      }
    }
  }
  out.unit_id = static_cast<int>(lr.integer("unit_id", defaults.unit_id, 0, 247));
  out.response_timeout =
      std::chrono::milliseconds(lr.integer("response_timeout_ms", defaults.response_timeout.count(), 10, 10000));
}

Result<ModbusSettings> parse_gauge_toml(std::string_view text, std::string_view source_name,
                                        const ModbusSettings& defaults) {
  Result<toml::table> parsed = parse_toml(text, source_name);
  if (!parsed) return parsed.error();
  const toml::table& top = *parsed;
  TomlReader r(top, source_name);
  r.allow_only({"link", "map"});
  ModbusSettings out = defaults;

  if (const toml::table* link = r.subtable("link")) {
    TomlReader lr(*link, source_name, "link.");
    lr.allow_only({"transport", "host", "port", "device", "baud", "parity", "data_bits", "stop_bits", "unit_id",
                   "response_timeout_ms"});
    read_modbus_link(lr, defaults, out);
    if (lr.error) r.fail(lr.error->message);
  }

  if (const toml::table* map = r.subtable("map")) {
    TomlReader mr(*map, source_name, "map.");
    mr.allow_only({"byte_order", "reading", "angle", "revolution", "sequence", "status", "latch"});
    const WordOrder order = word_order(mr.choice("byte_order", "ABCD", {"ABCD", "CDAB", "BADC", "DCBA"}));
    RegisterMap m;
    read_field("reading", source_name, order, m.reading, mr, false, nullptr);
    read_field("angle", source_name, order, m.angle, mr, false, nullptr);
    read_field("revolution", source_name, order, m.revolution, mr, false, nullptr);
    read_field("sequence", source_name, order, m.sequence, mr, false, nullptr);
    read_field("status", source_name, order, m.status, mr, true, &m.masks);
    m.latch.present = false;
    if (const toml::table* latch = mr.subtable("latch")) {
      TomlReader lr(*latch, source_name, "map.latch.");
      lr.allow_only({"register", "count_address", "ring_size", "ring_size_address", "ring_address", "entry_words",
                     "reading_offset", "degree_offset", "status_offset", "fault_count_address",
                     "fault_status_address"});
      LatchSpec& l = m.latch;
      l.present = true;
      l.table = register_table(lr.choice("register", "input", {"holding", "input"}));
      l.count_address = static_cast<int>(lr.integer("count_address", std::nullopt, 0, 65534));
      l.ring_size = static_cast<int>(lr.integer("ring_size", 0, 0, 65535));
      if (l.ring_size == 0) {
        l.ring_size_address = static_cast<int>(lr.integer("ring_size_address", std::nullopt, 0, 65535));
      } else if (lr.has("ring_size_address")) {
        lr.fail(lr.where("ring_size_address") + ": give either ring_size or ring_size_address, not both");
      }
      l.ring_address = static_cast<int>(lr.integer("ring_address", std::nullopt, 0, 65535));
      l.entry_words = static_cast<int>(lr.integer("entry_words", std::nullopt, 1, 125));
      l.reading_offset = static_cast<int>(lr.integer("reading_offset", 0, 0, 124));
      // -1: compact entries, latch number n being machine degree n mod 360 (register_map.h).
      l.degree_offset = static_cast<int>(lr.integer("degree_offset", std::nullopt, -1, 124));
      l.status_offset = static_cast<int>(lr.integer("status_offset", -1, -1, 124));
      l.fault_count_address = static_cast<int>(lr.integer("fault_count_address", -1, -1, 65534));
      l.fault_status_address = static_cast<int>(lr.integer("fault_status_address", -1, -1, 65535));
      l.order = order;
      if (lr.error) mr.fail(lr.error->message);
    }
    if (mr.error) r.fail(mr.error->message);
    if (!r.error) {
      if (Status v = validate(m); !v) r.fail(std::string(source_name) + ": " + v.error().message);
    }
    out.map = m;
  }
  if (r.error) return *r.error;
  return out;
}

Result<ModbusSettings> read_gauge_file(const std::filesystem::path& path, const ModbusSettings& defaults) {
  Result<std::string> text = read_regular_file(path, "gauge config");
  if (!text) return text.error();
  return parse_gauge_toml(without_utf8_bom(*text), path.string(), defaults);
}

}  // namespace gaugeloop
