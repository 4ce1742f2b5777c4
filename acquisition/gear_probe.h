// The grinder's flank probe for gears over Modbus TCP or RTU (core/gear_probe_registers.h): one
// point at a time, gaugeloop asks for a gap, a flank and a height Z on the face, the machine
// moves the probe there and answers the deviation it found. A lead trace is the points of one
// flank across the face. docs/gears.md, "The flank probe".
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "acquisition/modbus_gauge.h"
#include "core/clock.h"
#include "core/gear.h"
#include "core/result.h"

namespace gaugeloop {

class ModbusContext;  // libmodbus stays private to acquisition/ (modbus_context.h)

struct GearProbeSettings {
  // Transport, TCP host and port or serial line, unit id, response timeout; `map` unused.
  ModbusSettings link;
  int base_address = 0;  // holding register of word 0 of the block
  // How long the machine may take for one point (moving the probe to the gap and height, and
  // touching): a point not answered by then is an error naming it.
  std::chrono::milliseconds point_timeout{5000};
  std::chrono::milliseconds answer_poll{1};  // between reads of the answer words
  int reconnects = 2;                        // a link lost mid-trace is opened again this often before the lead fails
};

struct ProbedPoint {
  double z_mm = 0.0;  // where the probe touched (the machine's measured Z)
  double deviation_um = 0.0;
};

// Not thread-safe: one thread measures. Never uses MODBUS_ERROR_RECOVERY_LINK; reconnects
// itself.
class GearProbe {
 public:
  explicit GearProbe(GearProbeSettings settings, Clock& clock = real_clock());
  ~GearProbe();
  GearProbe(const GearProbe&) = delete;
  GearProbe& operator=(const GearProbe&) = delete;

  Status connect();
  std::string address() const;

  // One point: the request written in one write (sequence, gap, flank, Z), then the answer
  // words read until they answer that sequence. The first request of a connection follows the
  // sequence the machine's answer word holds, so a stale answer is never taken for a new one. Errors, each naming the
  // point (gap, flank, Z) and the probe's address: kInvalidInput for a gap outside 1..65535 or a Z beyond +-214 mm;
  // kGaugeTimeout when the machine has not answered within point_timeout (saying which
  // sequence the answer word still holds); kIncompleteRun for a status with a fault bit (named:
  // no contact, over range, out of reach, probe fault); kGaugeUnreachable for a lost link (closed)
  // and kGaugeProtocol for a Modbus exception (check base_address).
  Result<ProbedPoint> measure_point(int gap, Flank flank, double z_mm);

  // The lead of each gap in `gaps`, left flank then right, at each height in `z_mm`
  // (increasing); each trace aligned on its tooth as a checker aligns it (its mean taken out:
  // the probe's zero and the tooth's thickness are not lead). A link lost between points is
  // opened again (settings.reconnects times in all) and the point asked again. Errors:
  // measure_point's; kInvalidInput for no gap or fewer than 3 heights, or heights not
  // increasing.
  Result<std::vector<LeadTrace>> measure_lead(const std::vector<int>& gaps, const std::vector<double>& z_mm);

  int points_measured() const { return points_; }
  int reconnects() const { return reconnects_; }

 private:
  Result<ProbedPoint> measure_once(int gap, Flank flank, double z_mm);

  GearProbeSettings settings_;
  Clock& clock_;
  std::unique_ptr<ModbusContext> ctx_;  // never null
  std::uint16_t sequence_ = 0;
  bool in_step_ = false;  // sequence_ follows the machine's answer word (read once a connection)
  int points_ = 0;
  int reconnects_ = 0;
};

}  // namespace gaugeloop
