// A gear run's ISO 1328-1 figures as characteristics.
#include "report/gear_characteristics.h"

#include <cmath>
#include <string>

namespace gaugeloop {

GearProfileFigures gear_profile_figures(const GearRunRecord& r) {
  GearProfileFigures f;
  for (const GearProfileRecord& p : r.profiles) {
    if (p.total_um >= f.total_max_um) {
      f.total_max_um = p.total_um;
      f.tolerance_class = p.tolerance_class;
    }
    f.total_mean_um += p.total_um;
    f.form_mean_um += p.form_um;
    f.slope_mean_abs_um += std::abs(p.slope_um);
  }
  if (!r.profiles.empty()) {
    const double n = static_cast<double>(r.profiles.size());
    f.total_mean_um /= n;
    f.form_mean_um /= n;
    f.slope_mean_abs_um /= n;
  }
  return f;
}

RunCharacteristics gear_run_characteristics(const StoredGearRun& g) {
  const GearRunRecord& r = g.record;
  RunCharacteristics out;
  RunSummary& s = out.run;
  s.id = g.id;
  s.started_utc = r.started_utc;
  s.machine = r.machine;
  s.part = r.part;
  s.lobe = 1;
  s.status = g.pushed_version ? "pushed" : "measured";
  s.nc_file = r.nc_file;
  s.note = r.note;
  s.serial = r.serial;
  s.operator_name = r.operator_name;
  s.verdict = r.verdict;
  // F_beta is a band's width: 0 at best, its tolerance the upper limit alone.
  Limits total;
  total.upper = r.total_tolerance_um;
  std::vector<Characteristic>& c = out.characteristics;
  c.push_back(single_characteristic("lead.F_beta", "um", r.total_max_um, total));
  c.push_back(single_characteristic("lead.F_beta.mean", "um", r.total_mean_um, {}));
  c.push_back(single_characteristic("lead.f_f_beta.mean", "um", r.form_mean_um, {}));
  c.push_back(single_characteristic("lead.f_H_beta.mean_abs", "um", r.slope_mean_abs_um, {}));
  for (const GearTraceRecord& t : r.traces) {
    const std::string trace = "." + std::to_string(t.gap) + "." + t.flank;
    c.push_back(single_characteristic("lead.F_beta" + trace, "um", t.total_um, total));
    c.push_back(single_characteristic("lead.f_f_beta" + trace, "um", t.form_um, {}));
    c.push_back(single_characteristic("lead.f_H_beta" + trace, "um", t.slope_um, {}));
  }
  // The profiles, when measured: F_alpha judged against the class's F_alphaT as F_beta is.
  if (!r.profiles.empty()) {
    Limits profile_total;
    profile_total.upper = r.profile_tolerance_um;
    const GearProfileFigures p = gear_profile_figures(r);
    c.push_back(single_characteristic("profile.F_alpha", "um", p.total_max_um, profile_total));
    c.push_back(single_characteristic("profile.F_alpha.mean", "um", p.total_mean_um, {}));
    c.push_back(single_characteristic("profile.f_f_alpha.mean", "um", p.form_mean_um, {}));
    c.push_back(single_characteristic("profile.f_H_alpha.mean_abs", "um", p.slope_mean_abs_um, {}));
    for (const GearProfileRecord& t : r.profiles) {
      const std::string trace = "." + std::to_string(t.gap) + "." + t.flank;
      c.push_back(single_characteristic("profile.F_alpha" + trace, "um", t.total_um, profile_total));
      c.push_back(single_characteristic("profile.f_f_alpha" + trace, "um", t.form_um, {}));
      c.push_back(single_characteristic("profile.f_H_alpha" + trace, "um", t.slope_um, {}));
    }
  }
  return out;
}

}  // namespace gaugeloop
