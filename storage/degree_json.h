// Text form of a per-degree table as schema version 1 kept it in run_revolutions.lift_mm: a
// JSON array of 360 numbers with 6 decimals (read when migrating to version 2), and small JSON
// number arrays of version 2. Internal to storage/ (and its tests).
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "core/run.h"

namespace gaugeloop::storage_internal {

// Decimals kept: lifts in mm come back to within 0.5e-6 mm (half a unit of the last place).
inline constexpr int kJsonDecimals = 6;

// "[0.000000,0.001250,...]": kJsonDecimals in fixed notation, no spaces, independent of the C
// locale. Precondition: every value is finite.
std::string numbers_to_json(std::span<const double> values);

// "[0.000000,0.001250,...]": fixed notation, no spaces, independent of the C locale.
// Precondition: every value is finite (a JSON number cannot hold NaN or infinity).
std::string degree_table_to_json(const DegreeTable& table);

// Reads a JSON array of exactly 360 finite numbers (any JSON number syntax, any spacing, so a
// hand-edited row still reads). kInvalidInput otherwise, saying what is wrong.
Result<DegreeTable> degree_table_from_json(std::string_view text);

// Reads a JSON array of finite numbers of any length. kInvalidInput otherwise.
Result<std::vector<double>> numbers_from_json(std::string_view text);

}  // namespace gaugeloop::storage_internal
