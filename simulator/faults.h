// Faults the simulated amplifier can put on the link or in its readings, on a schedule.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

enum class FaultKind {
  kRefuse,        // close the listening socket and every connection: connection refused
  kDrop,          // event: close the connection that sent the next request, without a reply
  kSilent,        // read requests, never reply: response timeout
  kException,     // reply with Modbus exception `param` (default 6, server busy)
  kLate,          // event: reply to the next request `param` ms late (default 300)
  kFrozen,        // the amplifier stops: registers, sample number and latch count stand still
  kOverRange,     // status over-range (snapshot and latched entries)
  kUnderRange,    // status under-range
  kProbeMissing,  // status probe missing
  kAngleJump,     // event: the encoder angle jumps by `param` degrees (default 30), for good
  kSpeedDrift,    // the spindle runs `param` percent faster (default 5) while active
};

std::string_view fault_kind_name(FaultKind kind);

// A fault scheduled in spindle revolutions counted from the first request the simulator
// answers, so a test or an operator can place it inside a run. Events happen once, at
// `start_rev`; conditions hold from `start_rev` for `duration_rev` (negative: for good).
struct FaultSpec {
  FaultKind kind = FaultKind::kSilent;
  double start_rev = 0.0;
  double duration_rev = -1.0;
  double param = 0.0;  // 0: the kind's default
};

bool is_event(FaultKind kind);

// Parses KIND@START[+DURATION][:PARAM], e.g. "over-range@1.5+0.25", "jump@2:30", "late@2:300",
// "silent@2". Kinds: refuse, drop, silent, exception, late, frozen, over-range, under-range,
// probe-missing, jump, drift. Errors say what is wrong and list the kinds.
Result<FaultSpec> parse_fault_spec(std::string_view text);

}  // namespace gaugeloop
