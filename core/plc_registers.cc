// Names of the PLC handshake's result codes, as the log and the docs say them.
#include "core/plc_registers.h"

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
  }
  return "unknown result code";
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
