// The PLC's handshake registers (core/plc_registers.h) read and written over Modbus TCP or
// RTU: the service is the client, the PLC the server.
#pragma once

#include <memory>
#include <string>

#include "acquisition/modbus_gauge.h"
#include "core/plc_registers.h"
#include "core/result.h"

namespace gaugeloop {

class ModbusContext;  // libmodbus stays private to acquisition/ (modbus_context.h)

// Access to the handshake block, whatever carries it. Implemented by ModbusPlcLink; tests
// script a fake. Errors leave the link disconnected when the connection is in doubt.
class PlcRegisters {
 public:
  virtual ~PlcRegisters() = default;
  virtual Status connect() = 0;
  virtual void disconnect() = 0;
  virtual bool connected() const = 0;
  // The PLC's words (0..2, 12..36) in one read of the whole block.
  virtual Result<PlcRequestWords> read_request() = 0;
  // Words 3..11 in one write (function 16), so the PLC never sees done before the result.
  virtual Status write_service_words(const PlcServiceWords& words) = 0;
  virtual std::string address() const = 0;  // "tcp:HOST:PORT" or "rtu:DEVICE@..."
};

struct PlcLinkSettings {
  // Transport, TCP host and port or serial line, unit id, response timeout; `map` unused.
  ModbusSettings link;
  int base_address = 0;  // holding register of word 0 (the request)
  // Whether the PLC writes the part temperature (word 37): the block is then 38 words, else 37
  // and the temperature is not given.
  bool part_temperature = false;
};

// Owns one libmodbus context. Not thread-safe: one thread polls the PLC.
// Never uses MODBUS_ERROR_RECOVERY_LINK (it can block for seconds); the caller reconnects.
// Errors: kInvalidInput for unusable settings, kIo for a refused connection, a timeout
// (link closed: a late reply must not answer the next request) or a lost link (closed), and
// kInvalidInput for a Modbus exception (the link stays: check base_address).
class ModbusPlcLink final : public PlcRegisters {
 public:
  explicit ModbusPlcLink(PlcLinkSettings settings);
  ~ModbusPlcLink() override;
  ModbusPlcLink(const ModbusPlcLink&) = delete;
  ModbusPlcLink& operator=(const ModbusPlcLink&) = delete;

  Status connect() override;
  void disconnect() override;
  bool connected() const override;
  Result<PlcRequestWords> read_request() override;
  Status write_service_words(const PlcServiceWords& words) override;
  std::string address() const override;

 private:
  PlcLinkSettings settings_;
  std::unique_ptr<ModbusContext> ctx_;  // never null
};

}  // namespace gaugeloop
