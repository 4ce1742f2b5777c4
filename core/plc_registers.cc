// Names of the PLC handshake's result codes, as the log and the docs say them; the words
// in the block as the PLC and the service write them.
#include "core/plc_registers.h"

#include <cmath>
#include <cstdio>

#include "core/number_text.h"
#include "core/part_temperature.h"

namespace gaugeloop {

std::string_view plc_result_name(PlcResultCode code) {
  switch (code) {
    case PlcResultCode::kTablePushed:
      return "table pushed";
    case PlcResultCode::kTableHeld:
      return "table held for approval";
    case PlcResultCode::kTableRefused:
      return "correction refused";
    case PlcResultCode::kUnknownPart:
      return "unknown part or lobe";
    case PlcResultCode::kGaugeFault:
      return "gauge fault";
    case PlcResultCode::kStorageFault:
      return "storage fault";
    case PlcResultCode::kNcFault:
      return "NC output fault";
    case PlcResultCode::kNotNow:
      return "busy or stopping";
    case PlcResultCode::kOtherFault:
      return "other fault";
    case PlcResultCode::kBadIdentity:
      return "bad serial number or operator";
    case PlcResultCode::kBadPartTemperature:
      return "bad part temperature";
  }
  return "unknown result code";
}

Status encode_plc_text(std::string_view text, std::span<std::uint16_t> words) {
  if (text.size() > 2 * words.size()) {
    return make_error(ErrorCode::kInvalidInput, "'" + std::string(text) + "' has " + std::to_string(text.size()) +
                                                    " characters; the PLC's " + std::to_string(words.size()) +
                                                    " words hold " + std::to_string(2 * words.size()));
  }
  auto byte = [&text](std::size_t at) -> unsigned {
    return at < text.size() ? static_cast<unsigned char>(text[at]) : 0u;
  };
  for (std::size_t i = 0; i < words.size(); ++i) {
    words[i] = static_cast<std::uint16_t>((byte(2 * i) << 8) | byte(2 * i + 1));
  }
  return {};
}

Result<std::string> decode_plc_text(std::span<const std::uint16_t> words, int first_word, int base_address,
                                    std::string_view what) {
  std::string text;
  text.reserve(2 * words.size());
  for (std::size_t at = 0; at < 2 * words.size(); ++at) {
    const unsigned w = words[at / 2];
    const bool high = at % 2 == 0;
    const unsigned byte = high ? (w >> 8) : (w & 0xffu);
    if (byte == 0) break;
    if (byte < 0x20 || byte > 0x7e) {
      const int word = first_word + static_cast<int>(at / 2);
      char hex[8];
      std::snprintf(hex, sizeof hex, "0x%02X", byte);
      return make_error(ErrorCode::kInvalidInput,
                        "PLC " + std::string(what) + ": word " + std::to_string(word) + " (holding register " +
                            std::to_string(base_address + word) + "), " + (high ? "high" : "low") + " byte, is " + hex +
                            ", not printable ASCII (0x20 to 0x7E); the PLC program must write text there, "
                            "ended by a NUL byte, or 0 in every word when there is none");
    }
    text.push_back(static_cast<char>(byte));
  }
  const std::size_t first = text.find_first_not_of(' ');
  if (first == std::string::npos) return std::string();
  return text.substr(first, text.find_last_not_of(' ') - first + 1);
}

Result<std::optional<double>> decode_plc_part_temperature(std::uint16_t word, int base_address) {
  namespace r = plc_registers;
  if (word == r::kPartTemperatureNotGiven) return std::optional<double>();
  const int tenths = word >= 0x8000 ? static_cast<int>(word) - 0x10000 : static_cast<int>(word);
  const double temperature_c = tenths / 10.0;
  if (temperature_c < kPartTemperatureMinC || temperature_c > kPartTemperatureMaxC) {
    return make_error(ErrorCode::kInvalidInput,
                      "PLC part temperature: word " + std::to_string(r::kPartTemperature) + " (holding register " +
                          std::to_string(base_address + r::kPartTemperature) + ") is " + std::to_string(tenths) + ", " +
                          format_fixed(temperature_c, 1) + " deg C, outside " + format_fixed(kPartTemperatureMinC, 1) +
                          " to " + format_fixed(kPartTemperatureMaxC, 1) +
                          " deg C; the PLC program must write the part's temperature there in tenths of a degree "
                          "Celsius as a signed 16-bit word (214 = 21.4 deg C), or -32768 (0x8000) when it has none");
  }
  return std::optional<double>(temperature_c);
}

Result<std::uint16_t> encode_plc_part_temperature(std::optional<double> temperature_c) {
  if (!temperature_c) return plc_registers::kPartTemperatureNotGiven;
  const double tenths = std::round(*temperature_c * 10.0);
  if (!std::isfinite(tenths) || tenths < -32767.0 || tenths > 32767.0) {
    return make_error(ErrorCode::kInvalidInput, "part temperature " + format_fixed(*temperature_c, 1) +
                                                    " deg C does not fit the PLC's word (an int16 in 0.1 deg C)");
  }
  return static_cast<std::uint16_t>(static_cast<std::int16_t>(tenths));
}

std::array<std::uint16_t, plc_registers::kServiceWords> encode_service_words(const PlcServiceWords& w) {
  namespace r = plc_registers;
  std::array<std::uint16_t, r::kServiceWords> out{};
  auto at = [&out](int reg) -> std::uint16_t& { return out[static_cast<size_t>(reg - r::kServiceFirst)]; };
  at(r::kHeartbeat) = w.heartbeat;
  at(r::kAck) = w.ack ? 1 : 0;
  at(r::kBusy) = w.busy ? 1 : 0;
  at(r::kDone) = w.done ? 1 : 0;
  at(r::kFault) = w.fault ? 1 : 0;
  at(r::kResultCode) = static_cast<std::uint16_t>(w.result_code);
  at(r::kRunIdHigh) = static_cast<std::uint16_t>(w.run_id >> 16);
  at(r::kRunIdLow) = static_cast<std::uint16_t>(w.run_id & 0xffffu);
  at(r::kTableVersion) = w.table_version;
  return out;
}

PlcServiceWords decode_service_words(const std::array<std::uint16_t, plc_registers::kServiceWords>& regs) {
  namespace r = plc_registers;
  auto at = [&regs](int reg) { return regs[static_cast<size_t>(reg - r::kServiceFirst)]; };
  PlcServiceWords w;
  w.heartbeat = at(r::kHeartbeat);
  w.ack = at(r::kAck) != 0;
  w.busy = at(r::kBusy) != 0;
  w.done = at(r::kDone) != 0;
  w.fault = at(r::kFault) != 0;
  w.result_code = static_cast<PlcResultCode>(at(r::kResultCode));
  w.run_id = (static_cast<std::uint32_t>(at(r::kRunIdHigh)) << 16) | at(r::kRunIdLow);
  w.table_version = at(r::kTableVersion);
  return w;
}

}  // namespace gaugeloop
