// libmodbus calls for the PLC handshake; errno is turned into an ErrorCode right after each.
#include "acquisition/plc_link.h"

#include <modbus/modbus.h>

#include <array>
#include <cerrno>
#include <utility>

#include "acquisition/tcp_endpoint.h"

namespace gaugeloop {

ModbusPlcLink::ModbusPlcLink(PlcLinkSettings settings) : settings_(std::move(settings)) {}

ModbusPlcLink::~ModbusPlcLink() { disconnect(); }

std::string ModbusPlcLink::address() const {
  const ModbusSettings& l = settings_.link;
  if (l.transport == ModbusTransport::kRtu) {
    return "rtu:" + l.device + "@" + std::to_string(l.baud) + "/" + l.parity + "/unit " + std::to_string(l.unit_id);
  }
  return "tcp:" + format_tcp_endpoint(l.host, l.port);
}

Status ModbusPlcLink::connect() {
  disconnect();
  const ModbusSettings& l = settings_.link;
  const bool rtu = l.transport == ModbusTransport::kRtu;
  if (!rtu) {
    // As for the gauge: libmodbus would call a name it cannot resolve "Connection refused".
    if (Status s = resolve_tcp_host(l.host, l.port, "PLC"); !s) {
      return make_error(s.error().code == ErrorCode::kInvalidInput ? ErrorCode::kInvalidInput : ErrorCode::kIo,
                        s.error().message);
    }
  }
  modbus_t* ctx = rtu ? modbus_new_rtu(l.device.c_str(), l.baud, l.parity, l.data_bits, l.stop_bits)
                      : modbus_new_tcp_pi(l.host.c_str(), std::to_string(l.port).c_str());
  if (ctx == nullptr) {
    return make_error(ErrorCode::kInvalidInput, "PLC address " + address() + " is not usable: " +
                                                    modbus_strerror(errno) + "; check [plc] in the service config");
  }
  modbus_set_slave(ctx, l.unit_id);
  modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_NONE);
  const auto ms = l.response_timeout.count();
  modbus_set_response_timeout(ctx, static_cast<uint32_t>(ms / 1000), static_cast<uint32_t>((ms % 1000) * 1000));
  if (modbus_connect(ctx) != 0) {
    const int err = errno;
    modbus_free(ctx);
    return make_error(ErrorCode::kIo, "cannot connect to the PLC at " + address() + ": " + modbus_strerror(err) +
                                          "; check the PLC is on and its Modbus server is enabled");
  }
  ctx_ = ctx;
  return {};
}

void ModbusPlcLink::disconnect() {
  if (ctx_ == nullptr) return;
  modbus_close(ctx_);
  modbus_free(ctx_);
  ctx_ = nullptr;
}

Error ModbusPlcLink::failed(int n, const std::string& what) {
  const int err = n < 0 ? errno : EMBMDATA;
  const std::string where = what + " of the PLC at " + address();
  if (err >= EMBXILFUN && err <= EMBMDATA) {
    modbus_flush(ctx_);
    return make_error(ErrorCode::kInvalidInput, where + ": " + modbus_strerror(err) +
                                                    "; check [plc] base_address against the PLC's register block");
  }
  if (err == ETIMEDOUT) {
    modbus_flush(ctx_);
    disconnect();
    return make_error(ErrorCode::kIo,
                      where + ": no reply within " + std::to_string(settings_.link.response_timeout.count()) + " ms");
  }
  disconnect();
  return make_error(ErrorCode::kIo, where + ": " + modbus_strerror(err) + " (link lost)");
}

Result<PlcRequestWords> ModbusPlcLink::read_request() {
  if (ctx_ == nullptr) return make_error(ErrorCode::kIo, "PLC at " + address() + " is not connected");
  // The whole block in one request: the PLC's words are 0-2 and 12.
  std::array<std::uint16_t, plc_registers::kBlockWords> regs{};
  const int n = modbus_read_registers(ctx_, settings_.base_address, plc_registers::kBlockWords, regs.data());
  if (n != plc_registers::kBlockWords) {
    return failed(n, "reading holding registers " + std::to_string(settings_.base_address) + ".." +
                         std::to_string(settings_.base_address + plc_registers::kBlockWords - 1));
  }
  PlcRequestWords w;
  w.request = regs[plc_registers::kRequest];
  w.part_number = regs[plc_registers::kPartNumber];
  w.lobe = regs[plc_registers::kLobe];
  w.ground_with = regs[plc_registers::kGroundWith];
  return w;
}

Status ModbusPlcLink::write_service_words(const PlcServiceWords& words) {
  if (ctx_ == nullptr) return make_error(ErrorCode::kIo, "PLC at " + address() + " is not connected");
  const auto regs = encode_service_words(words);
  const int first = settings_.base_address + plc_registers::kServiceFirst;
  const int n = modbus_write_registers(ctx_, first, plc_registers::kServiceWords, regs.data());
  if (n != plc_registers::kServiceWords) {
    return failed(n, "writing holding registers " + std::to_string(first) + ".." +
                         std::to_string(first + plc_registers::kServiceWords - 1));
  }
  return {};
}

}  // namespace gaugeloop
