// A gear run's ISO 1328-1 figures as characteristics, the form the AQDEF export and SPC take
// runs in (keys "lead.", core/tolerance.h): the worst flank's F_beta judged against the run's
// F_betaT (the drawing's class), then the means, then every trace's F_beta (judged likewise),
// f_f_beta and f_H_beta. f_f_beta and f_H_beta are not judged: their tolerances are not applied.
#pragma once

#include "storage/run_store.h"

namespace gaugeloop {

// The run as a RunSummary of its own id, part, machine, serial, operator, start and verdict
// (lobe 1: a gear is one feature), with its characteristics; `g` must hold its traces
// (RunStore::load_gear_run).
RunCharacteristics gear_run_characteristics(const StoredGearRun& g);

}  // namespace gaugeloop
