// Text form of a per-degree table as kept in run_revolutions.lift_mm.
#include "storage/degree_json.h"

#include <array>
#include <cassert>
#include <charconv>
#include <cmath>
#include <cstddef>

#include <nlohmann/json.hpp>

namespace gaugeloop::storage_internal {

std::string numbers_to_json(std::span<const double> values) {
  std::string json;
  json.reserve(values.size() * 10 + 2);
  json += '[';
  // Wide enough for any finite double in fixed notation (up to 309 integer digits).
  std::array<char, 400> buffer{};
  for (std::size_t i = 0; i < values.size(); ++i) {
    assert(std::isfinite(values[i]));
    if (i != 0) json += ',';
    const auto [end, ec] =
        std::to_chars(buffer.data(), buffer.data() + buffer.size(), values[i], std::chars_format::fixed, kJsonDecimals);
    assert(ec == std::errc());
    json.append(buffer.data(), end);
  }
  json += ']';
  return json;
}

std::string degree_table_to_json(const DegreeTable& table) { return numbers_to_json(table); }

Result<DegreeTable> degree_table_from_json(std::string_view text) {
  const nlohmann::json parsed = nlohmann::json::parse(text, /*cb=*/nullptr,
                                                      /*allow_exceptions=*/false);
  if (parsed.is_discarded()) {
    return make_error(ErrorCode::kInvalidInput, "not valid JSON");
  }
  if (!parsed.is_array() || parsed.size() != static_cast<std::size_t>(kDegreesPerRevolution)) {
    return make_error(
        ErrorCode::kInvalidInput,
        "expected a JSON array of " + std::to_string(kDegreesPerRevolution) + " numbers, found " +
            (parsed.is_array() ? "an array of " + std::to_string(parsed.size()) : std::string(parsed.type_name())));
  }
  DegreeTable table{};
  for (std::size_t i = 0; i < table.size(); ++i) {
    const nlohmann::json& item = parsed[i];
    if (!item.is_number()) {
      return make_error(ErrorCode::kInvalidInput,
                        "element " + std::to_string(i) + " is a " + item.type_name() + ", not a number");
    }
    table[i] = item.get<double>();
    if (!std::isfinite(table[i])) {
      return make_error(ErrorCode::kInvalidInput, "element " + std::to_string(i) + " is out of range");
    }
  }
  return table;
}

Result<std::vector<double>> numbers_from_json(std::string_view text) {
  const nlohmann::json parsed = nlohmann::json::parse(text, /*cb=*/nullptr,
                                                      /*allow_exceptions=*/false);
  if (parsed.is_discarded() || !parsed.is_array()) {
    return make_error(ErrorCode::kInvalidInput, "not a JSON array");
  }
  std::vector<double> out;
  out.reserve(parsed.size());
  for (std::size_t i = 0; i < parsed.size(); ++i) {
    if (!parsed[i].is_number()) {
      return make_error(ErrorCode::kInvalidInput, "element " + std::to_string(i) + " is not a number");
    }
    out.push_back(parsed[i].get<double>());
    if (!std::isfinite(out.back())) {
      return make_error(ErrorCode::kInvalidInput, "element " + std::to_string(i) + " is out of range");
    }
  }
  return out;
}

}  // namespace gaugeloop::storage_internal
