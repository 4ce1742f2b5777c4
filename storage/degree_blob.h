// Compact form of per-degree tables as kept from schema version 2 on: 360 big-endian signed
// 32-bit integers per table, in units of 0.1 nm (1e-7 mm = 1e-4 um). Internal to storage/
// (and its tests). docs/storage.md explains the layout and the views that decode it in SQL.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>

#include "core/result.h"
#include "core/run.h"

namespace gaugeloop::storage_internal {

// Bytes one table takes: 360 x 4.
inline constexpr std::size_t kDegreeBlobBytes = static_cast<std::size_t>(kDegreesPerRevolution) * 4;

// Counts per unit of the table's values: a table in mm is stored as value * 1e7, one in um as
// value * 1e4. Either way one count is 0.1 nm, and a value comes back to within 0.05 nm.
inline constexpr double kCountsPerMm = 1e7;
inline constexpr double kCountsPerUm = 1e4;

// The largest magnitude a table can hold, in its own unit (about 214.7 mm or 214,748 um).
double degree_blob_limit(double counts_per_unit);

// Appends the table to `blob`, rounding each value to the nearest count.
// kInvalidInput, naming `what` and the degree, for a non-finite value or one out of range.
Status append_degree_blob(const DegreeTable& table, double counts_per_unit, std::string_view what, std::string& blob);

// Reads the table that starts `offset` bytes into `blob`. kInvalidInput if the blob is too
// short to hold it.
Result<DegreeTable> read_degree_blob(std::string_view blob, std::size_t offset, double counts_per_unit);

// The checksum a run's stored per-degree BLOBs carry from schema 19 on (run_tables.checksum,
// run_raw.checksum): FNV-1a 64 over `parts` in order, each preceded by its length (8 bytes,
// little-endian; all ones for an absent part, a NULL column), so that where one part ends
// counts. The unsigned value's bits as an int64, as SQLite keeps an INTEGER.
std::int64_t blobs_checksum(std::initializer_list<std::optional<std::string_view>> parts);

// run_raw.checksum: over amplifier_revolutions (its text) and lift.
inline std::int64_t raw_checksum(std::string_view amplifier_revolutions, std::string_view lift) {
  return blobs_checksum({amplifier_revolutions, lift});
}

// run_tables.checksum: over design_lift, mean_lift, spread, error, correction and
// residual_error (empty: NULL), in that order.
inline std::int64_t tables_checksum(const std::array<std::string_view, 5>& tables,
                                    std::optional<std::string_view> residual_error) {
  return blobs_checksum({tables[0], tables[1], tables[2], tables[3], tables[4], residual_error});
}

}  // namespace gaugeloop::storage_internal
