// What a record must satisfy before a single row of it is written: runs, pushes, pending
// tables and time bounds. Internal to storage/.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop::storage_internal {

// kInvalidInput "run not stored: <why>".
Error run_refused(const std::string& why);

// "NaN", "+infinity" or "-infinity".
std::string describe_non_finite(double value);

// Every contract RunRecord states (times, names, revolutions, finite tables and figures,
// ground_with, geometry). kInvalidInput naming the table, column and degree at fault.
Status check_run_record(const RunRecord& run);

// What a push or a pending table says about its table: counts not negative, figures finite
// (command_error_um also not below 0). `what` opens the message: "cannot record NC file
// /nc/A.SPF for run 3".
Status check_table_figures(const std::string& what, const TableFacts& table);

// A push to record for `run_id`: a file, a well-formed time if any, a version not negative
// and its table figures.
Status check_push(std::int64_t run_id, const NcPush& push);

// kInvalidInput: "<what> '<value>' is not an ISO 8601 UTC time like 2026-11-22T02:34:44Z".
Error bad_bound(std::string_view what, const std::string& value);

// Empty (no bound) or an ISO 8601 UTC time.
bool is_time_bound(std::string_view s);

}  // namespace gaugeloop::storage_internal
