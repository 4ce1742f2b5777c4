// Names and the text form of simulator faults.
#include "simulator/faults.h"

#include <charconv>
#include <cmath>

namespace gaugeloop {
namespace {

struct KindName {
  FaultKind kind;
  std::string_view name;
};

constexpr KindName kKinds[] = {
    {FaultKind::kRefuse, "refuse"},
    {FaultKind::kDrop, "drop"},
    {FaultKind::kSilent, "silent"},
    {FaultKind::kException, "exception"},
    {FaultKind::kLate, "late"},
    {FaultKind::kFrozen, "frozen"},
    {FaultKind::kOverRange, "over-range"},
    {FaultKind::kUnderRange, "under-range"},
    {FaultKind::kProbeMissing, "probe-missing"},
    {FaultKind::kAngleJump, "jump"},
    {FaultKind::kSpeedDrift, "drift"},
};

bool parse_number(std::string_view s, double& out) {
  const char* end = s.data() + s.size();
  auto [ptr, ec] = std::from_chars(s.data(), end, out);
  return !s.empty() && ec == std::errc() && ptr == end && std::isfinite(out);
}

}  // namespace

std::string_view fault_kind_name(FaultKind kind) {
  for (const KindName& k : kKinds) {
    if (k.kind == kind) return k.name;
  }
  return "?";
}

bool is_event(FaultKind kind) {
  return kind == FaultKind::kDrop || kind == FaultKind::kLate || kind == FaultKind::kAngleJump;
}

Result<FaultSpec> parse_fault_spec(std::string_view text) {
  auto bad = [&](const std::string& why) {
    std::string kinds;
    for (const KindName& k : kKinds) kinds += (kinds.empty() ? "" : ", ") + std::string(k.name);
    return make_error(ErrorCode::kInvalidInput, "fault `" + std::string(text) + "`: " + why +
                                                    "; write KIND@START[+DURATION][:PARAM] in revolutions, "
                                                    "e.g. over-range@1.5+0.25; kinds: " +
                                                    kinds);
  };
  const size_t at = text.find('@');
  if (at == std::string_view::npos) return bad("no @START");
  FaultSpec f;
  const std::string_view name = text.substr(0, at);
  bool known = false;
  for (const KindName& k : kKinds) {
    if (k.name == name) {
      f.kind = k.kind;
      known = true;
    }
  }
  if (!known) return bad("unknown kind `" + std::string(name) + "`");
  std::string_view rest = text.substr(at + 1);
  if (const size_t colon = rest.find(':'); colon != std::string_view::npos) {
    if (!parse_number(rest.substr(colon + 1), f.param)) return bad("PARAM is not a number");
    rest = rest.substr(0, colon);
  }
  if (const size_t plus = rest.find('+'); plus != std::string_view::npos) {
    if (is_event(f.kind)) return bad("`" + std::string(name) + "` happens once and takes no +DURATION");
    if (!parse_number(rest.substr(plus + 1), f.duration_rev) || f.duration_rev <= 0.0) {
      return bad("DURATION must be a positive number of revolutions");
    }
    rest = rest.substr(0, plus);
  }
  if (!parse_number(rest, f.start_rev) || f.start_rev < 0.0) return bad("START must be revolutions >= 0");
  return f;
}

}  // namespace gaugeloop
