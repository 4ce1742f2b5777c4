// A gauge amplifier reached over Modbus TCP through libmodbus.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "acquisition/gauge_client.h"
#include "acquisition/register_map.h"

typedef struct _modbus modbus_t;  // libmodbus stays private to acquisition/

namespace gaugeloop {

struct ModbusTcpSettings {
  std::string host = "127.0.0.1";
  int port = 502;
  int unit_id = 1;  // Modbus unit (slave) id the amplifier answers to
  std::chrono::milliseconds response_timeout{200};
  RegisterMap map;
};

// Owns one libmodbus context. Not thread-safe (libmodbus contexts are not): one per thread.
// Never uses MODBUS_ERROR_RECOVERY_LINK, which can block for seconds; the poller reconnects.
class ModbusTcpGauge final : public GaugeClient {
 public:
  explicit ModbusTcpGauge(ModbusTcpSettings settings);
  ~ModbusTcpGauge() override;
  ModbusTcpGauge(const ModbusTcpGauge&) = delete;
  ModbusTcpGauge& operator=(const ModbusTcpGauge&) = delete;

  Status connect() override;
  void disconnect() override;
  bool connected() const override { return ctx_ != nullptr; }
  // After a timeout the link is flushed and closed: a late reply would otherwise be taken as
  // the answer to the next request (transaction ids shift by one).
  Result<GaugeSnapshot> read_snapshot() override;
  Result<LatchState> read_latch_state() override;
  Result<std::vector<LatchedSample>> read_latched(int first_slot, int count) override;
  std::string address() const override;

 private:
  // Reads `count` registers of `table` at `address` into `dest`; on failure returns the
  // error, with errno turned into a code, after flushing and closing the link where needed.
  Status read_registers(RegisterTable table, int address, int count, std::uint16_t* dest);

  ModbusTcpSettings settings_;
  std::vector<ReadBlock> blocks_;  // the requests of one snapshot
  std::vector<std::vector<std::uint16_t>> words_;
  modbus_t* ctx_ = nullptr;
  std::uint64_t polls_ = 0;
  // Revolution count inferred from the angle wrapping, for maps without a revolution field.
  std::uint16_t inferred_revolution_ = 0;
  double last_angle_deg_ = -1.0;
};

}  // namespace gaugeloop
