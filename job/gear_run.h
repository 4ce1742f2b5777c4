// A measured gear judged and kept: each lead trace's ISO 1328-1 figures (total, form and slope
// helix deviation and the flank tolerance class), the gear's summary, and its verdict against
// the class the drawing asks for, as the record the run database keeps (docs/gears.md, "Gear
// runs").
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "compensation/gear_lead.h"
#include "core/gear.h"
#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Where a measured gear comes from and what it was ground with.
struct GearRunOrigin {
  std::string part_name;
  std::optional<int> required_class;  // the part's tolerance_class; empty: not judged
  std::string machine;
  std::string source;  // the checker, or the file its traces were read from
  std::string serial;
  std::string operator_name;
  std::string note;
  std::filesystem::path nc_file;           // the stroke program it was ground from
  std::optional<int> ground_with_version;  // that program's version; empty: not known
  std::string started_utc;                 // empty: now
};

// The record of a gear measured as `traces` (leads) and `profiles` (none: not measured): every
// trace's figures, F_beta's maximum and mean, the means of f_f_beta and |f_H_beta|, the worst
// flank's class, each profile's F_alpha, f_f_alpha, f_H_alpha and class, and the verdict (in when
// every flank's F_beta, and every profile's F_alpha, is within the required class's tolerance).
// kInvalidInput for no trace, or lead_figures' or profile_figures' error with the gap and flank
// of the trace it could not evaluate.
Result<GearRunRecord> judge_gear(const GearPart& part, const std::vector<LeadTrace>& traces,
                                 const GearRunOrigin& origin, const std::vector<ProfileTrace>& profiles = {});

}  // namespace gaugeloop
