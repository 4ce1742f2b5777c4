// A gear run's ISO 1328-1 figures as characteristics, the form the AQDEF export and SPC take
// runs in (keys "lead." and "profile.", core/tolerance.h): the worst flank's F_beta judged against
// the run's F_betaT (the drawing's class), then the means, then every trace's F_beta (judged
// likewise), f_f_beta and f_H_beta; then, for a gear whose profiles were measured, the same of
// F_alpha (against F_alphaT), f_f_alpha and f_H_alpha. The form and slope deviations are not
// judged: their tolerances are not applied.
#pragma once

#include "storage/run_store.h"

namespace gaugeloop {

// What ISO 1328-1 makes of a gear run's profiles together: F_alpha's maximum (its flank's class)
// and mean, the means of f_f_alpha and |f_H_alpha|. All 0 when it has none.
struct GearProfileFigures {
  double total_max_um = 0.0;
  double total_mean_um = 0.0;
  double form_mean_um = 0.0;
  double slope_mean_abs_um = 0.0;
  int tolerance_class = 0;  // of the worst profile; 0: none measured
};
GearProfileFigures gear_profile_figures(const GearRunRecord& r);

// The run as a RunSummary of its own id, part, machine, serial, operator, start and verdict
// (lobe 1: a gear is one feature), with its characteristics; `g` must hold its traces
// (RunStore::load_gear_run).
RunCharacteristics gear_run_characteristics(const StoredGearRun& g);

}  // namespace gaugeloop
