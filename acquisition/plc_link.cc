// The PLC's handshake block over libmodbus (modbus_context.cc makes the calls).
#include "acquisition/plc_link.h"

#include <algorithm>
#include <array>
#include <utility>

#include "acquisition/modbus_context.h"

namespace gaugeloop {
namespace {

ModbusPeer plc_peer() {
  return ModbusPeer{
      "PLC",
      ErrorCode::kIo,
      ErrorCode::kIo,
      ErrorCode::kInvalidInput,
      "; check [plc] in the service config",
      "; check the PLC is on and its Modbus server is enabled",
      "; check [plc] base_address (and part_temperature: 38 words, else 37) against the PLC's register block",
  };
}

}  // namespace

ModbusPlcLink::ModbusPlcLink(PlcLinkSettings settings)
    : settings_(std::move(settings)), ctx_(std::make_unique<ModbusContext>(settings_.link, plc_peer())) {}

ModbusPlcLink::~ModbusPlcLink() = default;

std::string ModbusPlcLink::address() const { return ctx_->address(); }

Status ModbusPlcLink::connect() { return ctx_->open(); }

void ModbusPlcLink::disconnect() { ctx_->close(); }

bool ModbusPlcLink::connected() const { return ctx_->is_open(); }

Result<PlcRequestWords> ModbusPlcLink::read_request() {
  // The whole block in one request, so part, lobe, serial, operator and part temperature are
  // from one moment: the PLC's words are 0-2 and 12-36 (37).
  std::array<std::uint16_t, plc_registers::kBlockWordsWithTemperature> regs{};
  const int words = settings_.part_temperature ? plc_registers::kBlockWordsWithTemperature : plc_registers::kBlockWords;
  if (Status s = ctx_->read_registers(RegisterTable::kHolding, settings_.base_address, words, regs.data()); !s) {
    return s.error();
  }
  PlcRequestWords w;
  w.request = regs[plc_registers::kRequest];
  w.part_number = regs[plc_registers::kPartNumber];
  w.lobe = regs[plc_registers::kLobe];
  w.ground_with = regs[plc_registers::kGroundWith];
  std::copy_n(regs.begin() + plc_registers::kSerialFirst, plc_registers::kSerialWords, w.serial.begin());
  std::copy_n(regs.begin() + plc_registers::kOperatorFirst, plc_registers::kOperatorWords, w.operator_name.begin());
  w.part_temperature =
      settings_.part_temperature ? regs[plc_registers::kPartTemperature] : plc_registers::kPartTemperatureNotGiven;
  return w;
}

Status ModbusPlcLink::write_service_words(const PlcServiceWords& words) {
  const auto regs = encode_service_words(words);
  return ctx_->write_registers(settings_.base_address + plc_registers::kServiceFirst, plc_registers::kServiceWords,
                               regs.data());
}

}  // namespace gaugeloop
