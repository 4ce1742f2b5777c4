// A virtual PLC: a Modbus TCP server holding the handshake block (core/plc_registers.h), and a
// C++ API with which a test or the `sim` command plays the PLC's side of the handshake.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "core/plc_registers.h"
#include "core/result.h"

typedef struct _modbus modbus_t;
typedef struct _modbus_mapping_t modbus_mapping_t;

namespace gaugeloop {

struct PlcSimulatorSettings {
  std::string host = "127.0.0.1";
  int port = 0;          // 0: the system picks a free port; read it back with port()
  int base_address = 0;  // holding register of the request word
  int unit_id = 1;       // answered whatever the request's unit id (as most PLCs do over TCP)
  // A PLC program with the part temperature word (37): 38 registers; false: the 37 of a
  // program written before it (a read of word 37 is then exception 2).
  bool part_temperature = true;
};

// Serves the block's holding registers, base_address .. base_address + 37 (+ 36 without the
// part temperature; nothing else:
// other addresses get exception 2, illegal data address) on its own thread from start() until
// stop() or destruction. Thread-safe: every method may be called from any thread. Each write
// by a client wakes the waiters, so tests wait on state, never on time.
class PlcSimulator {
 public:
  // Errors: kInvalidInput for a bad host or base address, kIo when the address cannot be bound.
  static Result<std::unique_ptr<PlcSimulator>> start(const PlcSimulatorSettings& settings);
  ~PlcSimulator();
  PlcSimulator(const PlcSimulator&) = delete;
  PlcSimulator& operator=(const PlcSimulator&) = delete;

  void stop();
  int port() const { return port_; }

  // The PLC's side: part and lobe number first, then the request bit (one write each, as a
  // PLC program sets them in order).
  // `ground_with`: word 12, the table version that ground the part (plc_registers.h).
  void request(std::uint16_t part_number, std::uint16_t lobe, std::uint16_t ground_with = 0);
  // Words 13-36: the serial number and the operator as the PLC writes them (encode_plc_text:
  // two bytes a word, high byte first, NUL after the text; "" zeroes the words). The bytes go
  // as they are, so a test can write one the service must refuse. kInvalidInput, nothing
  // written, when a text is longer than its words hold (32 and 16 characters). Set them
  // before request(), as a PLC program does.
  Status set_identity(std::string_view serial, std::string_view operator_name);
  // Word 37: the part's temperature, deg C, as the PLC writes it (encode_plc_part_temperature:
  // 0.1 deg C an increment; empty writes "not given", 0x8000, as a fresh simulator holds).
  // Values the service refuses (beyond -40.0..150.0) are written as they are, for a test.
  // kInvalidInput, nothing written, for a value not finite or beyond the int16 word. Set it
  // before request(), as a PLC program does.
  Status set_part_temperature_c(std::optional<double> temperature_c);
  void clear_request();
  PlcRequestWords plc_words() const;
  // The service's words as last written.
  PlcServiceWords service_words() const;
  std::int64_t service_writes() const;

  // Blocks until `done(words)` holds for the service's words, or `timeout` has passed (then
  // nullopt). Checked at once and after every write by the client.
  std::optional<PlcServiceWords> wait_until(const std::function<bool(const PlcServiceWords&)>& done,
                                            std::chrono::milliseconds timeout) const;
  // Done or fault raised: the cycle's outcome.
  std::optional<PlcServiceWords> wait_for_outcome(std::chrono::milliseconds timeout) const;

  // Link faults: close every client connection (the link drops mid-cycle); refuse or accept
  // connections from now on. Each returns once the server thread has done it.
  void drop_connections();
  void set_refusing(bool refusing);

 private:
  explicit PlcSimulator(PlcSimulatorSettings settings);
  Status listen();
  void serve();
  void wake() const;
  // Asks the server thread for a link change (set by `apply`) and waits until it is done.
  void change_link(const std::function<void()>& apply);

  PlcSimulatorSettings settings_;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;  // guarded by mutex_
  int listen_fd_ = -1;
  int wake_fd_ = -1;
  int port_ = 0;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  std::atomic<bool> drop_{false};
  std::atomic<bool> refusing_{false};
  std::atomic<std::int64_t> link_requests_{0};  // link changes asked for

  mutable std::mutex mutex_;
  mutable std::condition_variable written_;
  std::int64_t writes_ = 0;        // guarded by mutex_
  std::int64_t link_changes_ = 0;  // guarded by mutex_: drops and refusal changes carried out
};

}  // namespace gaugeloop
