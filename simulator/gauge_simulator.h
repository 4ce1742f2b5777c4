// A virtual gauge amplifier: a Modbus TCP server that reports an LVDT touching a turning lobe.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "compensation/periodic_spline.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "core/result.h"
#include "simulator/faults.h"

typedef struct _modbus modbus_t;
typedef struct _modbus_mapping_t modbus_mapping_t;

namespace gaugeloop {

// Input registers of the simulated amplifier (function 04), 0-based; docs/simulator.md.
namespace sim_registers {
inline constexpr int kReading = 0;       // int32, counts of 0.1 um, high word first (ABCD)
inline constexpr int kStatus = 2;        // bit 0 ready, 1 over-range, 2 under-range, 3 probe missing
inline constexpr int kAngle = 3;         // uint32, C angle in 0.001 deg, [0, 360000), ABCD
inline constexpr int kRevolution = 5;    // uint16 revolution count, wraps
inline constexpr int kSequence = 6;      // uint16 amplifier sample number, wraps
inline constexpr int kReadingFloat = 7;  // float32, reading in mm, ABCD
// The same status as an amplifier with an "ok" value reports it: 0 ok; bit 0 over-range,
// bit 1 under-range, bit 2 probe missing, bit 3 not ready.
inline constexpr int kStatusCode = 9;
inline constexpr int kSnapshotCount = 10;
// Latch buffer: the reading latched at every encoder degree mark.
inline constexpr int kLatchCount = 100;        // uint32, ABCD: marks latched since start
inline constexpr int kLatchRingSize = 102;     // uint16: entries in the ring
inline constexpr int kLatchEntryWords = 103;   // uint16: registers per entry (4)
inline constexpr int kLatchRing = 1000;        // entry k at 1000 + 4k: reading int32 ABCD, degree, status
inline constexpr int kLatchRingEntries = 512;  // 1.4 revolutions: not a multiple of 360 on purpose
// Compact latch ring: the same marks (same count), the reading alone; latch number n is
// machine degree n mod 360, the count having started at degree 0.
inline constexpr int kCompactRingSize = 104;      // uint16: entries in the compact ring
inline constexpr int kFaultMarkCount = 105;       // uint32, ABCD: marks latched with a fault bit, or lost
inline constexpr int kFaultMarkStatus = 107;      // uint16: status of the latest such mark (0: lost, not ready)
inline constexpr int kCompactRing = 4000;         // entry k at 4000 + 2k: reading int32 ABCD
inline constexpr int kCompactRingEntries = 1024;  // the 4-register ring's memory, twice the entries: 2.8 revolutions
inline constexpr int kCount = kCompactRing + 2 * kCompactRingEntries;
}  // namespace sim_registers

struct SimulatorSettings {
  std::string host = "127.0.0.1";
  int port = 0;  // 0: the system picks a free port; read it back with port()
  // Modbus RTU instead of TCP when set: the serial device to serve on (e.g. one end of a
  // socat pty pair), at this line setting and unit id. The simulator holds each reply back
  // for the line time of request and reply at `rtu_baud`, so a pty behaves like the bus.
  std::string rtu_device;
  int rtu_baud = 115200;
  char rtu_parity = 'N';
  int unit_id = 1;
  double speed_rpm = 60.0;           // work spindle speed
  double time_scale = 1.0;           // simulated seconds per wall-clock second
  double sample_rate_hz = 10000.0;   // amplifier update rate; the sample number counts these
  double lobe_error_peak_um = 15.0;  // repeatable form error of the ground lobe, largest |value|
  double noise_rms_um = 0.3;         // gauge noise, Gaussian, per amplifier sample
  double gauge_offset_mm = 0.25;     // reading on the base circle: the gauge is not zeroed
  // The revolution register moves this many degrees after the angle wraps, as amplifiers
  // that update the count on their own cycle do; 0: with the angle.
  double revolution_lag_deg = 0.0;
  std::uint64_t seed = 1;  // noise is a pure function of (seed, sample number)
  // The lobe on the machine, when it was ground (simulator/virtual_grinder.h): what the flat
  // probe reads at each whole cam degree, mm, 0 on the base circle; served instead of the
  // design with the form error above (lobe_error_peak_um is then ignored).
  std::optional<DegreeTable> ground_reading_mm;
  std::vector<FaultSpec> faults;  // scheduled from the first request (simulator/faults.h)
};

// Checks settings; the message names the setting.
Status validate(const SimulatorSettings& settings);

// Runs a Modbus TCP (or RTU) server on its own thread from start() until stop() or destruction.
// The register values are computed from the clock at the moment each request arrives, so
// any number of clients see one spindle. Faults follow a schedule counted in spindle
// revolutions from the first request (docs/simulator.md). Thread-safe: the accessors,
// set_silent and inject may be called from any thread.
class GaugeSimulator {
 public:
  // Builds the lobe from the design and starts serving. Errors: kInvalidInput for bad
  // settings or geometry, kIo when the address cannot be bound.
  static Result<std::unique_ptr<GaugeSimulator>> start(const Part& part, const LiftTable& design,
                                                       const SimulatorSettings& settings);
  ~GaugeSimulator();
  GaugeSimulator(const GaugeSimulator&) = delete;
  GaugeSimulator& operator=(const GaugeSimulator&) = delete;

  void stop();
  int port() const { return port_; }  // TCP only
  const SimulatorSettings& settings() const { return settings_; }
  std::int64_t requests_served() const { return requests_.load(); }

  // The repeatable form error of the simulated lobe (built in, or that of the ground lobe
  // given) against the design, at a cam angle (deg), in um.
  double lobe_error_um(double cam_angle_deg) const;
  // What the gauge would read at a cam angle without noise or gauge offset, in mm.
  double true_lift_mm(double cam_angle_deg) const;

  // The next part is on the machine: from the next request on the gauge reads this ground
  // lobe (as SimulatorSettings::ground_reading_mm). The latch ring keeps what it latched on
  // the part before, as an amplifier's would. Errors: kInvalidInput naming the cam degree.
  Status load_ground_part(const DegreeTable& reading_mm);

  // Stops (or resumes) answering at once, whatever the schedule says.
  void set_silent(bool silent) { silent_.store(silent); }
  // Adds a fault to the schedule; its start counts from the first request, like the others.
  void inject(const FaultSpec& fault);

 private:
  // What the schedule asks of the server at one moment.
  struct FaultState {
    bool refuse = false;
    bool silent = false;
    bool frozen = false;
    int exception = 0;         // Modbus exception code; 0: none
    std::uint16_t status = 0;  // amplifier status bits to set
    double drift_turns = 0.0;  // turns gained from speed drift so far
    double angle_offset_deg = 0.0;
    bool drop = false;  // events due, delivered to the request that sees them
    int late_ms = 0;
  };

  GaugeSimulator(const Part& part, const SimulatorSettings& settings, PeriodicSpline lift);
  Status listen();
  void close_listener();
  void serve();
  void serve_rtu();
  // The schedule at time `now_ns`; marks events as delivered when `deliver` is set.
  FaultState fault_state(std::int64_t now_ns, bool deliver);
  void update_registers(std::int64_t now_ns, const FaultState& faults);

  Part part_;
  SimulatorSettings settings_;
  PeriodicSpline lift_;  // flat-probe reading of the design lobe, cam frame
  // Flat-probe reading of the ground lobe, when given; swapped whole by load_ground_part.
  std::shared_ptr<const PeriodicSpline> ground() const;
  double true_lift_mm(const PeriodicSpline* ground, double cam_angle_deg) const;
  mutable std::mutex ground_mutex_;
  std::shared_ptr<const PeriodicSpline> ground_;
  double max_d1_ = 1.0;
  double max_d2_ = 1.0;
  double error_scale_ = 0.0;
  modbus_t* ctx_ = nullptr;
  modbus_mapping_t* mapping_ = nullptr;
  int listen_fd_ = -1;
  int wake_fd_ = -1;
  int port_ = 0;
  std::thread thread_;
  std::atomic<std::int64_t> requests_{0};
  std::atomic<bool> silent_{false};
  std::int64_t start_ns_ = 0;
  std::int64_t first_request_ns_ = -1;   // serve thread only: zero of the fault schedule
  std::int64_t latched_marks_ = 0;       // serve thread only
  std::int64_t fault_marks_ = 0;         // serve thread only: marks latched with a fault bit, or lost
  std::uint16_t fault_mark_status_ = 0;  // serve thread only
  bool was_frozen_ = false;              // serve thread only
  std::int64_t noise_origin_mark_ = -1;  // serve thread only: mark 0 of the latched noise

  std::mutex faults_mutex_;
  std::vector<FaultSpec> faults_;
  std::vector<bool> delivered_;  // per fault: event delivered
};

}  // namespace gaugeloop
