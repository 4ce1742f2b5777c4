// The gear report: one A4 landscape page of a gear run as a gear checker's lead report lays it
// out (docs/reports.md, "The gear report"): who, when, what and the verdict against the
// drawing's class; a lead chart per tooth gap, both flanks, Z up the face and the deviation
// across, the evaluation range marked; every trace's ISO 1328-1 figures in a table.
#pragma once

#include <filesystem>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Written atomically as PDF, SVG or PNG by the file's extension (check_page_file_name,
// report/cam_report.h). `run` must hold its traces (RunStore::load_gear_run). kInvalidInput for
// another extension or a run without traces; kIo when the file cannot be written.
Status write_gear_report(const StoredGearRun& run, const std::filesystem::path& out);

}  // namespace gaugeloop
