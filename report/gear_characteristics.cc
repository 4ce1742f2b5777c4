// A gear run's ISO 1328-1 figures as characteristics.
#include "report/gear_characteristics.h"

#include <string>

namespace gaugeloop {

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
  return out;
}

}  // namespace gaugeloop
