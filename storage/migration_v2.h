// Version 2 of the run database: what its migration does beyond SQL (storage/migrations.cc
// lists it). Internal to storage/.
#pragma once

#include <string>

#include "core/result.h"

namespace gaugeloop::storage_internal {

struct Connection;

// The SQL run after the conversion: the version-1 tables dropped, and the views that decode the
// per-degree BLOBs into rows (run_samples, run_profile, run_harmonics). Part of the released
// migration 2: the SQL it produces must never change (Schema.ViewsDecodeNegativeAndExtremeValues
// AsTheStoreDoes pins what it decodes).
std::string schema_v2_after();

// Moves the version-1 rows (JSON raw revolutions, one profile row per degree) into the compact
// tables run_raw and run_tables, run by run. A run whose rows do not add up is refused
// (kStorage) by id, with what to do.
Status convert_v1_rows(Connection& conn);

}  // namespace gaugeloop::storage_internal
