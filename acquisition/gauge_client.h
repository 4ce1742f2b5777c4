// The seam between the poller and a gauge amplifier: one consistent snapshot per call.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

// A gauge status as the poller sees it: GaugeStatusBit flags in the low 16 bits; with
// kGaugeFault, the amplifier's own fault bits that were set (its raw status word's bits, as
// the register map names them) in the high 16 bits.
using GaugeStatus = std::uint32_t;

// Status flags (bits 0-3 are also the simulator's status word; see docs/simulator.md).
enum GaugeStatusBit : std::uint32_t {
  kGaugeReady = 1u << 0,
  kGaugeOverRange = 1u << 1,
  kGaugeUnderRange = 1u << 2,
  kGaugeProbeMissing = 1u << 3,
  kGaugeFault = 1u << 4,  // a fault the amplifier names itself: its bits are in the high half
};

// One reading of the amplifier, taken in one request so the fields belong together.
struct GaugeSnapshot {
  double reading_mm = 0.0;       // LVDT reading, gauge zero (not yet zeroed on the base circle)
  double angle_deg = 0.0;        // work spindle (C) encoder angle, machine frame, [0, 360)
  std::uint16_t revolution = 0;  // encoder revolution count, wraps at 65536
  std::uint16_t sequence = 0;    // amplifier sample number, wraps; unchanged = same sample
  GaugeStatus status = 0;
};

// Names of an amplifier's own status bits, by bit number; an empty name: unnamed.
using StatusBitNames = std::array<std::string, 16>;

// Human-readable list of the faults in a status, e.g. "over-range, probe missing"; the
// amplifier's own fault bits by their names, or as "status bit 5" when unnamed.
std::string describe_gauge_status(GaugeStatus status, const StatusBitNames* bit_names = nullptr);

// True when the status says the reading can be used: ready and no fault.
inline bool gauge_status_ok(GaugeStatus status) {
  return (status & kGaugeReady) != 0 &&
         (status & (kGaugeOverRange | kGaugeUnderRange | kGaugeProbeMissing | kGaugeFault)) == 0;
}

// The amplifier's latch buffer: at each encoder degree mark it latches the reading into a
// ring of `ring_size` entries; `write_count` counts every latch since the amplifier started
// (wrapping at 2^32), so entry i lives in slot i % ring_size until overwritten.
struct LatchState {
  std::uint32_t write_count = 0;
  int ring_size = 0;
  int entries_per_read = 31;  // most entries one request can carry (125 registers)
  // Compact entries (register_map.h, LatchSpec): latch number n is machine degree n mod 360,
  // counted from the encoder's index pulse; entries carry no degree.
  bool degree_implied = false;
  // The amplifier's fault mark counter, when it has one: marks latched since start with a
  // status that was not ready or had a fault bit, wrapping at 2^32; and the status
  // (GaugeStatusBit flags) of the latest such mark, when it reports that.
  std::optional<std::uint32_t> fault_count;
  std::optional<GaugeStatus> fault_status;
};

// One latched entry: the reading at a whole machine degree of C.
struct LatchedSample {
  double reading_mm = 0.0;
  int degree = 0;          // machine degree 0..359 at which it latched; -1: implied by the latch number
  GaugeStatus status = 0;  // at that moment (kGaugeReady when the entry has none)
};

// A link to one gauge amplifier. Not thread-safe: one per thread.
// Errors: kGaugeUnreachable (no connection, or it dropped), kGaugeTimeout (no reply in time),
// kGaugeProtocol (exception reply or malformed data). After any error the caller should
// disconnect() and connect() again before the next read.
class GaugeClient {
 public:
  virtual ~GaugeClient() = default;
  virtual Status connect() = 0;
  virtual void disconnect() = 0;
  virtual bool connected() const = 0;
  virtual Result<GaugeSnapshot> read_snapshot() = 0;
  // Latched mode (amplifiers with an encoder-triggered hold input).
  virtual Result<LatchState> read_latch_state() = 0;
  // Entries in slots first_slot .. first_slot + count - 1, in one request where the map
  // allows; the caller keeps the range inside the ring.
  virtual Result<std::vector<LatchedSample>> read_latched(int first_slot, int count) = 0;
  // Where the gauge is, for messages: "tcp:127.0.0.1:1502".
  virtual std::string address() const = 0;
  // A status in the amplifier's own words, for messages (its register map names its bits).
  virtual std::string describe_status(GaugeStatus status) const { return describe_gauge_status(status); }
};

}  // namespace gaugeloop
