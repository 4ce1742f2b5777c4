// The gauge link over libmodbus (modbus_context.cc makes the calls): snapshots, latch states
// and latched entries read and decoded.
#include "acquisition/modbus_gauge.h"

#include <modbus/modbus.h>

#include <utility>
#include <vector>

#include "acquisition/modbus_context.h"

namespace gaugeloop {
namespace {

ModbusPeer gauge_peer(const ModbusSettings& s) {
  const bool rtu = s.transport == ModbusTransport::kRtu;
  return ModbusPeer{
      "gauge",
      ErrorCode::kGaugeUnreachable,
      ErrorCode::kGaugeTimeout,
      ErrorCode::kGaugeProtocol,
      rtu ? "; check the device, baud (e.g. 115200), parity (N, E, O), data and stop bits"
          : "; give a host name or address and a port",
      rtu ? "; check the serial device exists and is not in use"
          : "; check the address, the port and that the amplifier is on the network",
      "; check the register map against the amplifier's manual",
  };
}

}  // namespace

ModbusGauge::ModbusGauge(ModbusSettings settings)
    : settings_(std::move(settings)),
      blocks_(snapshot_blocks(settings_.map)),
      ctx_(std::make_unique<ModbusContext>(settings_, gauge_peer(settings_))) {
  for (const ReadBlock& b : blocks_) words_.emplace_back(static_cast<size_t>(b.count));
  if (settings_.map.latch.present) latch_blocks_ = latch_state_blocks(settings_.map);
  for (const ReadBlock& b : latch_blocks_) latch_words_.emplace_back(static_cast<size_t>(b.count));
}

ModbusGauge::~ModbusGauge() = default;

std::string ModbusGauge::address() const { return ctx_->address(); }

Status ModbusGauge::connect() { return ctx_->open(); }

void ModbusGauge::disconnect() { ctx_->close(); }

bool ModbusGauge::connected() const { return ctx_->is_open(); }

Result<GaugeSnapshot> ModbusGauge::read_snapshot() {
  for (size_t b = 0; b < blocks_.size(); ++b) {
    if (Status s = ctx_->read_registers(blocks_[b].table, blocks_[b].start, blocks_[b].count, words_[b].data()); !s) {
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
    if (Status s = ctx_->read_registers(blk.table, blk.start, blk.count, latch_words_[b].data()); !s) return s.error();
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
  if (Status s = ctx_->read_registers(map.latch.table, map.latch.ring_address + first_slot * map.latch.entry_words,
                                      words, regs);
      !s) {
    return s.error();
  }
  return decode_latched(map, std::span<const std::uint16_t>(regs, static_cast<size_t>(words)));
}

}  // namespace gaugeloop
