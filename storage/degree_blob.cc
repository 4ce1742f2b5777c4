// Compact form of per-degree tables: 360 big-endian int32 counts of 0.1 nm.
#include "storage/degree_blob.h"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>

namespace gaugeloop::storage_internal {

double degree_blob_limit(double counts_per_unit) { return static_cast<double>(INT32_MAX) / counts_per_unit; }

std::int64_t blobs_checksum(std::initializer_list<std::optional<std::string_view>> parts) {
  std::uint64_t h = 14695981039346656037ULL;
  const auto add = [&h](unsigned char byte) {
    h ^= byte;
    h *= 1099511628211ULL;
  };
  for (const std::optional<std::string_view>& part : parts) {
    const std::uint64_t length = part ? part->size() : ~std::uint64_t{0};
    for (int i = 0; i < 8; ++i) add(static_cast<unsigned char>(length >> (8 * i)));
    if (part) {
      for (char c : *part) add(static_cast<unsigned char>(c));
    }
  }
  std::int64_t out = 0;
  static_assert(sizeof out == sizeof h);
  std::memcpy(&out, &h, sizeof out);
  return out;
}

Status append_degree_blob(const DegreeTable& table, double counts_per_unit, std::string_view what, std::string& blob) {
  blob.reserve(blob.size() + kDegreeBlobBytes);
  const double limit = static_cast<double>(INT32_MAX);
  for (std::size_t deg = 0; deg < table.size(); ++deg) {
    const double counts = std::round(table[deg] * counts_per_unit);
    if (!(std::abs(counts) <= limit)) {  // also catches NaN
      char value[64];
      std::snprintf(value, sizeof value, "%g", table[deg]);
      char bound[64];
      std::snprintf(bound, sizeof bound, "%.1f", degree_blob_limit(counts_per_unit));
      return make_error(ErrorCode::kInvalidInput, std::string(what) + " at degree " + std::to_string(deg) + " is " +
                                                      value + ", outside the +-" + bound +
                                                      " the run database keeps; the computation that produced it "
                                                      "failed, nothing was written");
    }
    // Two's complement, most significant byte first: the views decode it from hex() in SQL.
    const auto bits = static_cast<std::uint32_t>(static_cast<std::int32_t>(counts));
    blob.push_back(static_cast<char>((bits >> 24) & 0xffu));
    blob.push_back(static_cast<char>((bits >> 16) & 0xffu));
    blob.push_back(static_cast<char>((bits >> 8) & 0xffu));
    blob.push_back(static_cast<char>(bits & 0xffu));
  }
  return {};
}

Result<DegreeTable> read_degree_blob(std::string_view blob, std::size_t offset, double counts_per_unit) {
  if (offset > blob.size() || blob.size() - offset < kDegreeBlobBytes) {
    return make_error(ErrorCode::kInvalidInput, "the blob holds " + std::to_string(blob.size()) +
                                                    " bytes, too few for a table at byte " + std::to_string(offset));
  }
  DegreeTable table{};
  const auto* p = reinterpret_cast<const unsigned char*>(blob.data()) + offset;
  for (std::size_t deg = 0; deg < table.size(); ++deg, p += 4) {
    const std::uint32_t bits =
        (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
    table[deg] = static_cast<double>(static_cast<std::int32_t>(bits)) / counts_per_unit;
  }
  return table;
}

}  // namespace gaugeloop::storage_internal
