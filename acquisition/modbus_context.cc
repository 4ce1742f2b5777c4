// libmodbus contexts opened, and errno turned into an ErrorCode right after each call.
#include "acquisition/modbus_context.h"

#include <modbus/modbus.h>

#include <cerrno>
#include <utility>

#include "acquisition/tcp_endpoint.h"

namespace gaugeloop {

std::string modbus_address(const ModbusSettings& s) {
  if (s.transport == ModbusTransport::kRtu) {
    return "rtu:" + s.device + "@" + std::to_string(s.baud) + "/" + s.parity + "/unit " + std::to_string(s.unit_id);
  }
  return "tcp:" + format_tcp_endpoint(s.host, s.port);
}

ModbusContext::ModbusContext(const ModbusSettings& settings, ModbusPeer peer)
    : settings_(settings), peer_(std::move(peer)) {}

Status ModbusContext::open() {
  close();
  const ModbusSettings& s = settings_;
  const bool rtu = s.transport == ModbusTransport::kRtu;
  if (!rtu) {
    if (Status r = resolve_tcp_host(s.host, s.port, peer_.name); !r) {
      return make_error(r.error().code == ErrorCode::kInvalidInput ? ErrorCode::kInvalidInput : peer_.unreachable,
                        r.error().message);
    }
  }
  // modbus_new_tcp_pi: a host name, an IPv4 or an IPv6 address (modbus_new_tcp takes IPv4 only).
  modbus_t* ctx = rtu ? modbus_new_rtu(s.device.c_str(), s.baud, s.parity, s.data_bits, s.stop_bits)
                      : modbus_new_tcp_pi(s.host.c_str(), std::to_string(s.port).c_str());
  if (ctx == nullptr) {
    return make_error(ErrorCode::kInvalidInput, peer_.name + " address " + address() + " is not usable: " +
                                                    modbus_strerror(errno) + peer_.settings_advice);
  }
  modbus_set_slave(ctx, s.unit_id);
  modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_NONE);
  const auto ms = s.response_timeout.count();
  modbus_set_response_timeout(ctx, static_cast<uint32_t>(ms / 1000), static_cast<uint32_t>((ms % 1000) * 1000));
  if (modbus_connect(ctx) != 0) {
    const int err = errno;
    modbus_free(ctx);
    return make_error(peer_.unreachable, "cannot connect to the " + peer_.name + " at " + address() + ": " +
                                             modbus_strerror(err) + peer_.connect_advice);
  }
  ctx_ = ctx;
  return {};
}

void ModbusContext::close() {
  if (ctx_ == nullptr) return;
  modbus_close(ctx_);
  modbus_free(ctx_);
  ctx_ = nullptr;
}

Status ModbusContext::read_registers(RegisterTable table, int first, int count, std::uint16_t* dest) {
  if (ctx_ == nullptr) return not_open();
  const int n = table == RegisterTable::kInput ? modbus_read_input_registers(ctx_, first, count, dest)
                                               : modbus_read_registers(ctx_, first, count, dest);
  const int err = errno;
  if (n == count) return {};
  return failed(n < 0 ? err : EMBMDATA, "reading", table, first, count);
}

Status ModbusContext::write_registers(int first, int count, const std::uint16_t* src) {
  if (ctx_ == nullptr) return not_open();
  const int n = modbus_write_registers(ctx_, first, count, src);
  const int err = errno;
  if (n == count) return {};
  return failed(n < 0 ? err : EMBMDATA, "writing", RegisterTable::kHolding, first, count);
}

Error ModbusContext::failed(int err, const std::string& verb, RegisterTable table, int first, int count) {
  const std::string where = verb + " " + std::string(register_table_name(table)) + " registers " +
                            std::to_string(first) + ".." + std::to_string(first + count - 1) + " of the " + peer_.name +
                            " at " + address();
  if (err == ETIMEDOUT) {
    modbus_flush(ctx_);
    close();
    return make_error(peer_.timeout,
                      where + ": no reply within " + std::to_string(settings_.response_timeout.count()) + " ms");
  }
  if (err >= EMBXILFUN && err <= EMBMDATA) {
    modbus_flush(ctx_);
    return make_error(peer_.exception, where + ": " + modbus_strerror(err) + peer_.exception_advice);
  }
  close();
  return make_error(peer_.unreachable, where + ": " + modbus_strerror(err) + " (link lost)");
}

Error ModbusContext::not_open() const {
  return make_error(peer_.unreachable, peer_.name + " at " + address() + " is not connected");
}

}  // namespace gaugeloop
