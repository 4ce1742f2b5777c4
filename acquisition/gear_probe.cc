// The grinder's flank probe for gears over libmodbus (modbus_context.cc makes the calls).
#include "acquisition/gear_probe.h"

#include <array>
#include <cmath>
#include <utility>

#include "acquisition/modbus_context.h"
#include "core/gear_probe_registers.h"
#include "core/number_text.h"

namespace gaugeloop {
namespace {

namespace r = gear_probe_registers;

ModbusPeer probe_peer() {
  return ModbusPeer{
      "gear probe",
      ErrorCode::kGaugeUnreachable,
      ErrorCode::kGaugeTimeout,
      ErrorCode::kGaugeProtocol,
      "; give the machine's host name or address and port (--gauge HOST:PORT)",
      "; check the address, the port and that the machine's Modbus server is enabled",
      "; check --base-address against the machine's gear probe block",
  };
}

std::uint16_t high(std::int32_t v) { return static_cast<std::uint16_t>(static_cast<std::uint32_t>(v) >> 16); }
std::uint16_t low(std::int32_t v) { return static_cast<std::uint16_t>(static_cast<std::uint32_t>(v) & 0xFFFFu); }
std::int32_t int32_of(std::uint16_t high_word, std::uint16_t low_word) {
  return static_cast<std::int32_t>((static_cast<std::uint32_t>(high_word) << 16) | low_word);
}

// "no contact, out of reach" for the bits set.
std::string status_text(std::uint16_t status) {
  std::string out;
  for (const auto& [bit, name] :
       {std::pair{r::kNoContact, "no contact"}, std::pair{r::kOverRange, "over range"},
        std::pair{r::kOutOfReach, "out of reach"}, std::pair{r::kProbeFault, "probe fault"}}) {
    if ((status & bit) != 0) out += (out.empty() ? "" : ", ") + std::string(name);
  }
  if (out.empty()) out = "status " + std::to_string(status);
  return out;
}

}  // namespace

GearProbe::GearProbe(GearProbeSettings settings, Clock& clock)
    : settings_(std::move(settings)),
      clock_(clock),
      ctx_(std::make_unique<ModbusContext>(settings_.link, probe_peer())) {}

GearProbe::~GearProbe() = default;

std::string GearProbe::address() const { return ctx_->address(); }

Status GearProbe::connect() { return ctx_->open(); }

Result<ProbedPoint> GearProbe::measure_once(int gap, Flank flank, double z_mm) {
  const std::string point = "gap " + std::to_string(gap) + ", " + std::string(flank_name(flank)) + " flank, Z " +
                            format_fixed(z_mm, 4) + " mm";
  const double z_units = std::round(z_mm / r::kZUnitMm);
  if (gap < 1 || gap > 65535 || !std::isfinite(z_mm) || std::abs(z_units) > 2147483647.0) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot ask the gear probe for " + point + ": the gap must be 1 to 65535 and Z within +-214 mm");
  }
  if (!ctx_->is_open()) {
    if (Status s = ctx_->open(); !s) return s.error();
    in_step_ = false;
  }
  if (!in_step_) {
    // The machine keeps its answer word across our sessions (and we may have been restarted):
    // start after what it holds, so that an old answer is never taken for the new point's.
    std::uint16_t held = 0;
    if (Status s = ctx_->read_registers(RegisterTable::kHolding, settings_.base_address + r::kAnswerSequence, 1, &held);
        !s) {
      return make_error(s.error().code, point + ": " + s.error().message);
    }
    sequence_ = held;
    in_step_ = true;
  }
  sequence_ = static_cast<std::uint16_t>(sequence_ + 1);
  if (sequence_ == 0) sequence_ = 1;  // 0 is what an idle machine's answer word holds
  const auto z = static_cast<std::int32_t>(z_units);
  const std::array<std::uint16_t, r::kRequestWords> request{sequence_, static_cast<std::uint16_t>(gap),
                                                            static_cast<std::uint16_t>(flank == Flank::kLeft ? 0 : 1),
                                                            high(z), low(z)};
  if (Status s = ctx_->write_registers(settings_.base_address + r::kRequestSequence, r::kRequestWords, request.data());
      !s) {
    return make_error(s.error().code, point + ": " + s.error().message);
  }
  const Clock::time_point deadline = clock_.now() + settings_.point_timeout;
  std::array<std::uint16_t, r::kAnswerWords> answer{};
  for (;;) {
    if (Status s = ctx_->read_registers(RegisterTable::kHolding, settings_.base_address + r::kAnswerSequence,
                                        r::kAnswerWords, answer.data());
        !s) {
      return make_error(s.error().code, point + ": " + s.error().message);
    }
    if (answer[0] == sequence_) break;
    if (clock_.now() >= deadline) {
      return make_error(ErrorCode::kGaugeTimeout,
                        "the gear probe at " + address() + " did not measure " + point + " within " +
                            std::to_string(settings_.point_timeout.count()) + " ms: register " +
                            std::to_string(settings_.base_address + r::kAnswerSequence) + " (answer sequence) holds " +
                            std::to_string(answer[0]) + " where " + std::to_string(sequence_) +
                            " was asked; check the probe cycle on the machine");
    }
    clock_.sleep_for(settings_.answer_poll);
  }
  const std::uint16_t status = answer[r::kStatus - r::kAnswerSequence];
  if (status != 0) {
    return make_error(ErrorCode::kIncompleteRun, "the gear probe at " + address() + " could not measure " + point +
                                                     ": " + status_text(status) + " (register " +
                                                     std::to_string(settings_.base_address + r::kStatus) + ")");
  }
  ProbedPoint p;
  p.deviation_um =
      int32_of(answer[r::kDeviation - r::kAnswerSequence], answer[r::kDeviation - r::kAnswerSequence + 1]) *
      r::kDeviationUnitUm;
  p.z_mm = int32_of(answer[r::kZMeasured - r::kAnswerSequence], answer[r::kZMeasured - r::kAnswerSequence + 1]) *
           r::kZUnitMm;
  ++points_;
  return p;
}

Result<ProbedPoint> GearProbe::measure_point(int gap, Flank flank, double z_mm) {
  for (;;) {
    Result<ProbedPoint> p = measure_once(gap, flank, z_mm);
    // A lost link closes the context: open it again and ask the point again, a few times.
    if (p || p.error().code != ErrorCode::kGaugeUnreachable || reconnects_ >= settings_.reconnects) return p;
    ++reconnects_;
  }
}

Result<std::vector<LeadTrace>> GearProbe::measure_lead(const std::vector<int>& gaps, const std::vector<double>& z_mm) {
  if (gaps.empty() || z_mm.size() < 3) {
    return make_error(ErrorCode::kInvalidInput, "a lead needs a tooth gap and 3 or more heights across the face");
  }
  for (std::size_t i = 1; i < z_mm.size(); ++i) {
    if (!(z_mm[i] > z_mm[i - 1])) {
      return make_error(ErrorCode::kInvalidInput, "the heights of a lead must increase: " + format_fixed(z_mm[i], 4) +
                                                      " mm follows " + format_fixed(z_mm[i - 1], 4) + " mm");
    }
  }
  std::vector<LeadTrace> out;
  for (int gap : gaps) {
    for (Flank f : {Flank::kLeft, Flank::kRight}) {
      LeadTrace t;
      t.gap = gap;
      t.flank = f;
      for (double z : z_mm) {
        Result<ProbedPoint> p = measure_point(gap, f, z);
        if (!p) return p.error();
        if (!t.z_mm.empty() && !(p->z_mm > t.z_mm.back())) {
          return make_error(ErrorCode::kGaugeProtocol,
                            "the gear probe at " + address() + " touched gap " + std::to_string(gap) + ", " +
                                std::string(flank_name(f)) + " flank at Z " + format_fixed(p->z_mm, 4) +
                                " mm, not above the point before it (" + format_fixed(t.z_mm.back(), 4) +
                                " mm); check the machine's measured Z (register " +
                                std::to_string(settings_.base_address + gear_probe_registers::kZMeasured) + ")");
        }
        t.z_mm.push_back(p->z_mm);
        t.deviation_um.push_back(p->deviation_um);
      }
      align_on_tooth(t);
      out.push_back(std::move(t));
    }
  }
  return out;
}

}  // namespace gaugeloop
