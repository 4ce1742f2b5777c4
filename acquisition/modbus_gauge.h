// A gauge amplifier reached over Modbus TCP or RTU through libmodbus.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "acquisition/gauge_client.h"
#include "acquisition/register_map.h"

namespace gaugeloop {

class ModbusContext;  // libmodbus stays private to acquisition/ (modbus_context.h)

enum class ModbusTransport { kTcp, kRtu };

struct ModbusSettings {
  ModbusTransport transport = ModbusTransport::kTcp;
  // TCP
  std::string host = "127.0.0.1";
  int port = 502;
  // RTU: serial line
  std::string device = "/dev/ttyUSB0";
  int baud = 115200;
  char parity = 'N';  // N, E or O
  int data_bits = 8;
  int stop_bits = 1;

  int unit_id = 1;  // Modbus unit (slave) id the amplifier answers to
  std::chrono::milliseconds response_timeout{200};
  RegisterMap map;
};

// Owns one libmodbus context, TCP or RTU. Not thread-safe (libmodbus contexts are not):
// one per thread.
// Never uses MODBUS_ERROR_RECOVERY_LINK, which can block for seconds; the poller reconnects.
class ModbusGauge final : public GaugeClient {
 public:
  explicit ModbusGauge(ModbusSettings settings);
  ~ModbusGauge() override;
  ModbusGauge(const ModbusGauge&) = delete;
  ModbusGauge& operator=(const ModbusGauge&) = delete;

  Status connect() override;
  void disconnect() override;
  bool connected() const override;
  // After a timeout the link is flushed and closed: a late reply would otherwise be taken as
  // the answer to the next request (transaction ids shift by one).
  Result<GaugeSnapshot> read_snapshot() override;
  Result<LatchState> read_latch_state() override;
  Result<std::vector<LatchedSample>> read_latched(int first_slot, int count) override;
  std::string address() const override;
  std::string describe_status(GaugeStatus status) const override {
    return describe_gauge_status(status, &settings_.map.masks.bit_names);
  }

 private:
  ModbusSettings settings_;
  std::vector<ReadBlock> blocks_;  // the requests of one snapshot
  std::vector<std::vector<std::uint16_t>> words_;
  std::vector<ReadBlock> latch_blocks_;  // the requests of one latch state read
  std::vector<std::vector<std::uint16_t>> latch_words_;
  std::unique_ptr<ModbusContext> ctx_;  // never null
  std::uint64_t polls_ = 0;
  // Revolution count inferred from the angle wrapping, for maps without a revolution field.
  std::uint16_t inferred_revolution_ = 0;
  double last_angle_deg_ = -1.0;
};

}  // namespace gaugeloop
