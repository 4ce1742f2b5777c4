// A measured gear judged and kept.
#include "job/gear_run.h"

#include <algorithm>
#include <cmath>

#include "compensation/gear_coupling.h"
#include "core/utc_time.h"

namespace gaugeloop {

Result<GearRunRecord> judge_gear(const GearPart& part, const std::vector<LeadTrace>& traces,
                                 const GearRunOrigin& origin, const std::vector<ProfileTrace>& profiles) {
  if (traces.empty()) {
    return make_error(ErrorCode::kInvalidInput, "gear of part " + origin.part_name + ": no lead trace to judge");
  }
  const double d = gear_coupling(part).gear_pitch_diameter_mm;
  const double b = part.gear.face_width_mm;
  GearRunRecord r;
  r.started_utc = origin.started_utc.empty() ? utc_now() : origin.started_utc;
  r.machine = origin.machine;
  r.part = origin.part_name;
  r.source = origin.source;
  r.serial = origin.serial;
  r.operator_name = origin.operator_name;
  r.note = origin.note;
  r.nc_file = origin.nc_file.string();
  r.ground_with_version = origin.ground_with_version;
  r.required_class = origin.required_class;
  for (const LeadTrace& t : traces) {
    Result<LeadFigures> f = lead_figures(t, part.gear);
    if (!f) {
      return make_error(f.error().code, "gap " + std::to_string(t.gap) + ", " + std::string(flank_name(t.flank)) +
                                            " flank: " + f.error().message);
    }
    GearTraceRecord tr;
    tr.gap = t.gap;
    tr.flank = std::string(flank_name(t.flank));
    tr.total_um = f->total_um;
    tr.form_um = f->form_um;
    tr.slope_um = f->slope_um;
    tr.tolerance_class = helix_tolerance_class(f->total_um, d, b);
    tr.from_mm = f->from_mm;
    tr.to_mm = f->to_mm;
    tr.z_mm = t.z_mm;
    tr.deviation_um = t.deviation_um;
    r.total_max_um = std::max(r.total_max_um, tr.total_um);
    r.total_mean_um += tr.total_um;
    r.form_mean_um += tr.form_um;
    r.slope_mean_abs_um += std::abs(tr.slope_um);
    r.traces.push_back(std::move(tr));
  }
  const double n = static_cast<double>(traces.size());
  r.total_mean_um /= n;
  r.form_mean_um /= n;
  r.slope_mean_abs_um /= n;
  r.tolerance_class = helix_tolerance_class(r.total_max_um, d, b);
  double profile_max_um = 0.0;
  for (const ProfileTrace& t : profiles) {
    Result<ProfileFigures> f = profile_figures(t, part.gear);
    if (!f) {
      return make_error(f.error().code, "profile of gap " + std::to_string(t.gap) + ", " +
                                            std::string(flank_name(t.flank)) + " flank: " + f.error().message);
    }
    GearProfileRecord pr;
    pr.gap = t.gap;
    pr.flank = std::string(flank_name(t.flank));
    pr.total_um = f->total_um;
    pr.form_um = f->form_um;
    pr.slope_um = f->slope_um;
    pr.tolerance_class = profile_tolerance_class(f->total_um, part.gear.normal_module_mm, d);
    pr.from_roll_mm = f->from_mm;
    pr.to_roll_mm = f->to_mm;
    pr.roll_mm = t.roll_mm;
    pr.deviation_um = t.deviation_um;
    profile_max_um = std::max(profile_max_um, pr.total_um);
    r.profiles.push_back(std::move(pr));
  }
  if (r.required_class) {
    r.total_tolerance_um = helix_tolerance_um(*r.required_class, d, b);
    bool in = r.total_max_um <= *r.total_tolerance_um;
    if (!r.profiles.empty()) {
      r.profile_tolerance_um = profile_tolerance_um(*r.required_class, part.gear.normal_module_mm, d);
      in = in && profile_max_um <= *r.profile_tolerance_um;
    }
    r.verdict = in ? Verdict::kIn : Verdict::kOut;
  }
  return r;
}

}  // namespace gaugeloop
