// libmodbus calls for the TCP gauge link; errno is turned into an ErrorCode right after each.
#include "acquisition/modbus_gauge.h"

#include <modbus/modbus.h>

#include <cerrno>
#include <utility>
#include <vector>

namespace gaugeloop {

ModbusTcpGauge::ModbusTcpGauge(ModbusTcpSettings settings) : settings_(std::move(settings)) {}

ModbusTcpGauge::~ModbusTcpGauge() { disconnect(); }

std::string ModbusTcpGauge::address() const { return "tcp:" + settings_.host + ":" + std::to_string(settings_.port); }

Status ModbusTcpGauge::connect() {
  disconnect();
  modbus_t* ctx = modbus_new_tcp(settings_.host.c_str(), settings_.port);
  if (ctx == nullptr) {
    return make_error(ErrorCode::kInvalidInput, "gauge address " + address() + " is not usable: " +
                                                    modbus_strerror(errno) + "; give an IPv4 address and a port");
  }
  modbus_set_slave(ctx, settings_.unit_id);
  modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_NONE);
  const auto ms = settings_.response_timeout.count();
  modbus_set_response_timeout(ctx, static_cast<uint32_t>(ms / 1000), static_cast<uint32_t>((ms % 1000) * 1000));
  if (modbus_connect(ctx) != 0) {
    const int err = errno;
    modbus_free(ctx);
    return make_error(ErrorCode::kGaugeUnreachable,
                      "cannot connect to the gauge at " + address() + ": " + modbus_strerror(err) +
                          "; check the address, the port and that the amplifier is on the network");
  }
  ctx_ = ctx;
  return {};
}

void ModbusTcpGauge::disconnect() {
  if (ctx_ == nullptr) return;
  modbus_close(ctx_);
  modbus_free(ctx_);
  ctx_ = nullptr;
}

Status ModbusTcpGauge::read_registers(int address, int count, std::uint16_t* dest) {
  if (ctx_ == nullptr) {
    return make_error(ErrorCode::kGaugeUnreachable, "gauge at " + this->address() + " is not connected");
  }
  const int n = modbus_read_input_registers(ctx_, address, count, dest);
  if (n == count) return {};
  const int err = n < 0 ? errno : EMBMDATA;
  const std::string where = "reading input registers " + std::to_string(address) + ".." +
                            std::to_string(address + count - 1) + " of the gauge at " + this->address();
  if (err == ETIMEDOUT) {
    modbus_flush(ctx_);
    disconnect();
    return make_error(ErrorCode::kGaugeTimeout,
                      where + ": no reply within " + std::to_string(settings_.response_timeout.count()) + " ms");
  }
  if (err >= EMBXILFUN && err <= EMBMDATA) {
    modbus_flush(ctx_);
    return make_error(ErrorCode::kGaugeProtocol,
                      where + ": " + modbus_strerror(err) + "; check the register map against the amplifier's manual");
  }
  disconnect();
  return make_error(ErrorCode::kGaugeUnreachable, where + ": " + modbus_strerror(err) + " (link lost)");
}

Result<GaugeSnapshot> ModbusTcpGauge::read_snapshot() {
  const RegisterMap& map = settings_.map;
  std::uint16_t regs[MODBUS_MAX_READ_REGISTERS];
  if (Status s = read_registers(map.start_address, map.count, regs); !s) return s.error();
  return decode_snapshot(map, std::span<const std::uint16_t>(regs, static_cast<size_t>(map.count)));
}

Result<LatchState> ModbusTcpGauge::read_latch_state() {
  const RegisterMap& map = settings_.map;
  std::uint16_t regs[3];
  if (Status s = read_registers(map.latch_count_address, 3, regs); !s) return s.error();
  LatchState st;
  st.write_count = decode_u32(regs[0], regs[1], map.word_order);
  st.ring_size = regs[map.latch_ring_size_address - map.latch_count_address];
  if (st.ring_size < 2) {
    return make_error(ErrorCode::kGaugeProtocol, "gauge at " + address() + " reports a latch ring of " +
                                                     std::to_string(st.ring_size) +
                                                     " entries; check the latch registers of the map");
  }
  return st;
}

Result<std::vector<LatchedSample>> ModbusTcpGauge::read_latched(int first_slot, int count) {
  const RegisterMap& map = settings_.map;
  const int words = count * map.latch_entry_words;
  std::uint16_t regs[MODBUS_MAX_READ_REGISTERS];
  if (words > MODBUS_MAX_READ_REGISTERS) {
    return make_error(ErrorCode::kInternal, "read_latched: " + std::to_string(count) + " entries exceed one request");
  }
  if (Status s = read_registers(map.latch_ring_address + first_slot * map.latch_entry_words, words, regs); !s) {
    return s.error();
  }
  return decode_latched(map, std::span<const std::uint16_t>(regs, static_cast<size_t>(words)));
}

}  // namespace gaugeloop
