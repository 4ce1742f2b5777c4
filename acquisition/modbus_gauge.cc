// libmodbus calls for the TCP gauge link; errno is turned into an ErrorCode right after each.
#include "acquisition/modbus_gauge.h"

#include <modbus/modbus.h>

#include "acquisition/tcp_endpoint.h"

#include <cerrno>
#include <utility>
#include <vector>

namespace gaugeloop {

ModbusGauge::ModbusGauge(ModbusSettings settings)
    : settings_(std::move(settings)), blocks_(snapshot_blocks(settings_.map)) {
  for (const ReadBlock& b : blocks_) words_.emplace_back(static_cast<size_t>(b.count));
  if (settings_.map.latch.present) latch_blocks_ = latch_state_blocks(settings_.map);
  for (const ReadBlock& b : latch_blocks_) latch_words_.emplace_back(static_cast<size_t>(b.count));
}

ModbusGauge::~ModbusGauge() { disconnect(); }

std::string ModbusGauge::address() const {
  if (settings_.transport == ModbusTransport::kRtu) {
    return "rtu:" + settings_.device + "@" + std::to_string(settings_.baud) + "/" + settings_.parity + "/unit " +
           std::to_string(settings_.unit_id);
  }
  return "tcp:" + format_tcp_endpoint(settings_.host, settings_.port);
}

Status ModbusGauge::connect() {
  disconnect();
  const bool rtu = settings_.transport == ModbusTransport::kRtu;
  // libmodbus's connect turns a name it cannot resolve into "Connection refused": resolve
  // first, for a message that says what is wrong.
  if (!rtu) {
    if (Status s = resolve_tcp_host(settings_.host, settings_.port, "gauge"); !s) return s;
  }
  // modbus_new_tcp_pi: a host name, an IPv4 or an IPv6 address (modbus_new_tcp takes IPv4 only).
  modbus_t* ctx = rtu ? modbus_new_rtu(settings_.device.c_str(), settings_.baud, settings_.parity, settings_.data_bits,
                                       settings_.stop_bits)
                      : modbus_new_tcp_pi(settings_.host.c_str(), std::to_string(settings_.port).c_str());
  if (ctx == nullptr) {
    return make_error(ErrorCode::kInvalidInput,
                      "gauge address " + address() + " is not usable: " + modbus_strerror(errno) +
                          (rtu ? "; check the device, baud (e.g. 115200), parity (N, E, O), data and stop bits"
                               : "; give a host name or address and a port"));
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
                          (rtu ? "; check the serial device exists and is not in use"
                               : "; check the address, the port and that the amplifier is on the network"));
  }
  ctx_ = ctx;
  return {};
}

void ModbusGauge::disconnect() {
  if (ctx_ == nullptr) return;
  modbus_close(ctx_);
  modbus_free(ctx_);
  ctx_ = nullptr;
}

Status ModbusGauge::read_registers(RegisterTable table, int address, int count, std::uint16_t* dest) {
  if (ctx_ == nullptr) {
    return make_error(ErrorCode::kGaugeUnreachable, "gauge at " + this->address() + " is not connected");
  }
  const int n = table == RegisterTable::kInput ? modbus_read_input_registers(ctx_, address, count, dest)
                                               : modbus_read_registers(ctx_, address, count, dest);
  if (n == count) return {};
  const int err = n < 0 ? errno : EMBMDATA;
  const std::string where = "reading " + std::string(register_table_name(table)) + " registers " +
                            std::to_string(address) + ".." + std::to_string(address + count - 1) + " of the gauge at " +
                            this->address();
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

Result<GaugeSnapshot> ModbusGauge::read_snapshot() {
  for (size_t b = 0; b < blocks_.size(); ++b) {
    if (Status s = read_registers(blocks_[b].table, blocks_[b].start, blocks_[b].count, words_[b].data()); !s) {
      return s.error();
    }
  }
  GaugeSnapshot snap = decode_snapshot(settings_.map, blocks_, words_, ++polls_);
  if (!settings_.map.revolution.present) {
    // A wrap is the angle dropping by more than half a turn between polls.
    if (last_angle_deg_ >= 0.0 && snap.angle_deg < last_angle_deg_ - 180.0) ++inferred_revolution_;
    last_angle_deg_ = snap.angle_deg;
    snap.revolution = inferred_revolution_;
  }
  return snap;
}

Result<LatchState> ModbusGauge::read_latch_state() {
  const LatchSpec& l = settings_.map.latch;
  if (!l.present) {
    return make_error(ErrorCode::kInvalidInput, "the register map of the gauge at " + address() +
                                                    " has no latch buffer; use live mode (--mode live)");
  }
  for (size_t b = 0; b < latch_blocks_.size(); ++b) {
    const ReadBlock& blk = latch_blocks_[b];
    if (Status s = read_registers(blk.table, blk.start, blk.count, latch_words_[b].data()); !s) return s.error();
  }
  const LatchState st = decode_latch_state(settings_.map, latch_blocks_, latch_words_);
  if (st.ring_size < 2) {
    return make_error(ErrorCode::kGaugeProtocol, "gauge at " + address() + " reports a latch ring of " +
                                                     std::to_string(st.ring_size) +
                                                     " entries; check the latch registers of the map");
  }
  return st;
}

Result<std::vector<LatchedSample>> ModbusGauge::read_latched(int first_slot, int count) {
  const RegisterMap& map = settings_.map;
  const int words = count * map.latch.entry_words;
  std::uint16_t regs[MODBUS_MAX_READ_REGISTERS];
  if (words > MODBUS_MAX_READ_REGISTERS) {
    return make_error(ErrorCode::kInternal, "read_latched: " + std::to_string(count) + " entries exceed one request");
  }
  if (Status s =
          read_registers(map.latch.table, map.latch.ring_address + first_slot * map.latch.entry_words, words, regs);
      !s) {
    return s.error();
  }
  return decode_latched(map, std::span<const std::uint16_t>(regs, static_cast<size_t>(words)));
}

}  // namespace gaugeloop
