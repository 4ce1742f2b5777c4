// The virtual gear grinder's flank probe: a Modbus TCP server holding the gear probe block
// (core/gear_probe_registers.h). When gaugeloop writes a request it measures the point on the
// gear on the machine (simulator/gear_grinder.h: probed_deviation_um) and writes the answer, as
// the machine's probe cycle would; faults a test sets (a stalled cycle, status bits, a dropped
// link) stand for what a real machine does. docs/gears.md, "The flank probe".
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "core/result.h"
#include "simulator/gear_grinder.h"

typedef struct _modbus modbus_t;
typedef struct _modbus_mapping_t modbus_mapping_t;

namespace gaugeloop {

struct GearProbeSimulatorSettings {
  std::string host = "127.0.0.1";
  int port = 0;          // 0: the system picks a free port; read it back with port()
  int base_address = 0;  // holding register of word 0 of the block
};

// Serves the block on its own thread from start() until stop() or destruction. Thread-safe:
// every method may be called from any thread.
class GearProbeSimulator {
 public:
  // Errors: kInvalidInput for a bad host or base address, kIo when the address cannot be bound.
  static Result<std::unique_ptr<GearProbeSimulator>> start(const GearProbeSimulatorSettings& settings);
  ~GearProbeSimulator();
  GearProbeSimulator(const GearProbeSimulator&) = delete;
  GearProbeSimulator& operator=(const GearProbeSimulator&) = delete;

  void stop();
  int port() const { return port_; }

  // The gear on the machine from the next request on, and the number of this measurement (the
  // checker's noise: probed_deviation_um). Before any: every point answers probe fault.
  void load_gear(GroundGear gear, std::uint64_t measurement);
  // Faults: the probe cycle stops answering (the answer words stay); every answer from now on
  // carries these status bits (0: none); every client connection is closed once (returns when
  // the server has closed them).
  void set_stalled(bool stalled);
  void set_status(std::uint16_t status);
  void drop_connections();

  std::int64_t points_answered() const { return answered_.load(); }

 private:
  explicit GearProbeSimulator(GearProbeSimulatorSettings settings);
  void serve();
  // Answers the request in the block if it is new; under mutex_.
  void answer_request();

  GearProbeSimulatorSettings settings_;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;  // guarded by mutex_
  int listen_fd_ = -1;
  int wake_fd_ = -1;
  int port_ = 0;
  std::thread thread_;
  std::atomic<bool> stopping_{false};
  std::int64_t drops_asked_ = 0;  // guarded by mutex_
  std::int64_t drops_done_ = 0;   // guarded by mutex_
  std::condition_variable dropped_;
  std::atomic<std::int64_t> answered_{0};
  mutable std::mutex mutex_;
  std::optional<GroundGear> gear_;  // guarded by mutex_
  std::uint64_t measurement_ = 0;   // guarded by mutex_
  bool stalled_ = false;            // guarded by mutex_
  std::uint16_t status_ = 0;        // guarded by mutex_
};

}  // namespace gaugeloop
