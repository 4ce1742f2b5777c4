// One libmodbus context opened from ModbusSettings, and the errors of its calls turned into
// an ErrorCode and text a person can act on. Internal to acquisition/: the gauge link
// (modbus_gauge.cc) and the PLC link (plc_link.cc) own one each.
#pragma once

#include <cstdint>
#include <string>

#include "acquisition/modbus_gauge.h"
#include "acquisition/register_map.h"
#include "core/result.h"

typedef struct _modbus modbus_t;  // libmodbus stays private to acquisition/

namespace gaugeloop {

// "tcp:HOST:PORT" or "rtu:DEVICE@BAUD/PARITY/unit ID", for messages.
std::string modbus_address(const ModbusSettings& settings);

// The device at the other end of a link, as its errors name it.
struct ModbusPeer {
  std::string name;              // "gauge", "PLC": "cannot connect to the gauge at ..."
  ErrorCode unreachable;         // a refused connection, a lost link, a request while closed
  ErrorCode timeout;             // no reply within the response timeout
  ErrorCode exception;           // an exception reply or a malformed one
  std::string settings_advice;   // follows "<name> address A is not usable: <why>"
  std::string connect_advice;    // follows "cannot connect to the <name> at A: <why>"
  std::string exception_advice;  // follows "<reading ... registers> of the <name> at A: <why>"
};

// Not thread-safe (libmodbus contexts are not): one per thread. `settings` must outlive the
// context (its owner keeps both).
class ModbusContext {
 public:
  ModbusContext(const ModbusSettings& settings, ModbusPeer peer);
  ~ModbusContext() { close(); }
  ModbusContext(const ModbusContext&) = delete;
  ModbusContext& operator=(const ModbusContext&) = delete;

  // Opens the link afresh (closing any open one): TCP or RTU, the unit id, the response
  // timeout, and no error recovery: MODBUS_ERROR_RECOVERY_LINK can block for seconds, the
  // owner reconnects instead. A TCP host is resolved first, as libmodbus would call a name it
  // cannot resolve "Connection refused". Errors: kInvalidInput for a name that does not
  // resolve or settings libmodbus refuses; peer.unreachable when the connection fails or the
  // resolver cannot answer now.
  Status open();
  void close();
  bool is_open() const { return ctx_ != nullptr; }
  std::string address() const { return modbus_address(settings_); }

  // Reads `count` registers of `table` from `first` into `dest`; writes `count` holding
  // registers (function 16) from `src`. Errors, from errno on the line after the call:
  // - peer.timeout, "no reply within N ms": the link is flushed and closed, as a late reply
  //   would otherwise be taken for the answer to the next request;
  // - peer.exception for an exception or malformed reply: flushed, the link stays;
  // - peer.unreachable, "(link lost)", for anything else: closed; also when not open.
  Status read_registers(RegisterTable table, int first, int count, std::uint16_t* dest);
  Status write_registers(int first, int count, const std::uint16_t* src);

 private:
  // The error of the call just made on registers `first`..`first + count - 1`: `err` is errno
  // after it, or EMBMDATA for a reply with too few registers. `verb`: "reading", "writing".
  Error failed(int err, const std::string& verb, RegisterTable table, int first, int count);
  Error not_open() const;

  const ModbusSettings& settings_;
  ModbusPeer peer_;
  modbus_t* ctx_ = nullptr;
};

}  // namespace gaugeloop
