// Parsing and validation of design lift tables.
#include "core/lift_table.h"

#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>
#include <system_error>

#include "core/text_file.h"

namespace gaugeloop {
namespace {

std::string_view trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t' || s.back() == '\r')) s.remove_suffix(1);
  return s;
}

// Parses a whole field as a double; false on trailing garbage or an empty field.
bool parse_double(std::string_view field, double& out) {
  field = trim(field);
  if (field.empty()) return false;
  if (field.front() == '+') field.remove_prefix(1);
  const char* end = field.data() + field.size();
  auto [ptr, ec] = std::from_chars(field.data(), end, out);
  return ec == std::errc() && ptr == end;
}

std::string where(std::string_view source, int line) { return std::string(source) + ":" + std::to_string(line); }

std::string fmt_deg(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace

Result<LiftTable> parse_lift_table_csv(std::string_view text, std::string_view source_name,
                                       const LiftTableLimits& limits) {
  text = without_utf8_bom(text);  // spreadsheet programs write one
  LiftTable table;
  table.source = std::string(source_name);
  std::vector<int> lines;  // source line of each point, for messages
  int line_no = 0;
  bool seen_data_or_header = false;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view line = trim(text.substr(pos, nl - pos));
    pos = nl + 1;
    ++line_no;
    if (line.empty() || line.front() == '#') continue;
    size_t comma = line.find(',');
    if (comma == std::string_view::npos || line.find(',', comma + 1) != std::string_view::npos) {
      return make_error(
          ErrorCode::kInvalidInput,
          where(source_name, line_no) + ": expected two columns `angle_deg,lift_mm`, got `" + std::string(line) + "`");
    }
    std::string_view a = trim(line.substr(0, comma));
    std::string_view l = trim(line.substr(comma + 1));
    if (!seen_data_or_header && a == "angle_deg" && l == "lift_mm") {
      seen_data_or_header = true;
      continue;
    }
    seen_data_or_header = true;
    double angle = 0.0;
    double lift = 0.0;
    // from_chars accepts "nan" and "inf"; they are rejected below with their own message.
    if (!parse_double(a, angle)) {
      return make_error(ErrorCode::kInvalidInput,
                        where(source_name, line_no) + ": angle `" + std::string(a) + "` is not a number");
    }
    if (!parse_double(l, lift)) {
      return make_error(ErrorCode::kInvalidInput,
                        where(source_name, line_no) + ": lift `" + std::string(l) + "` is not a number");
    }
    if (!std::isfinite(angle) || !std::isfinite(lift)) {
      return make_error(
          ErrorCode::kInvalidInput,
          where(source_name, line_no) + ": NaN or infinity in the table; every angle and lift must be a finite number");
    }
    if (angle < 0.0 || angle >= 360.0) {
      return make_error(ErrorCode::kInvalidInput, where(source_name, line_no) + ": angle " + fmt_deg(angle) +
                                                      " deg is outside one turn; give angles in [0, 360)");
    }
    if (!table.angle_deg.empty()) {
      double prev = table.angle_deg.back();
      if (angle == prev) {
        return make_error(ErrorCode::kInvalidInput, where(source_name, line_no) + ": duplicate angle " +
                                                        fmt_deg(angle) + " deg (also on line " +
                                                        std::to_string(lines.back()) + ")");
      }
      if (angle < prev) {
        return make_error(ErrorCode::kInvalidInput, where(source_name, line_no) + ": angle " + fmt_deg(angle) +
                                                        " deg comes after " + fmt_deg(prev) +
                                                        " deg; sort the table by angle");
      }
      if (angle - prev > limits.max_gap_deg) {
        return make_error(ErrorCode::kInvalidInput, where(source_name, line_no) + ": gap of " + fmt_deg(angle - prev) +
                                                        " deg from " + fmt_deg(prev) + " deg to " + fmt_deg(angle) +
                                                        " deg is wider than the " + fmt_deg(limits.max_gap_deg) +
                                                        " deg allowed");
      }
    }
    table.angle_deg.push_back(angle);
    table.lift_mm.push_back(lift);
    lines.push_back(line_no);
  }
  if (table.angle_deg.size() < 4) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(source_name) + ": " + std::to_string(table.angle_deg.size()) +
                          " points; a lift table needs at least 4 points covering the whole turn");
  }
  const double wrap_gap = table.angle_deg.front() + 360.0 - table.angle_deg.back();
  if (wrap_gap > limits.max_gap_deg) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(source_name) + ": the table does not cover the turn: it runs from " +
                          fmt_deg(table.angle_deg.front()) + " to " + fmt_deg(table.angle_deg.back()) +
                          " deg, leaving a gap of " + fmt_deg(wrap_gap) + " deg across 360 (limit " +
                          fmt_deg(limits.max_gap_deg) + " deg)");
  }
  return table;
}

Result<LiftTable> read_lift_table_csv(const std::filesystem::path& path, const LiftTableLimits& limits) {
  Result<std::string> text = read_regular_file(path, "lift table");
  if (!text) {
    Error e = text.error();
    e.message += " (the `lift_table` path in the part file)";
    return e;
  }
  return parse_lift_table_csv(*text, path.string(), limits);
}

}  // namespace gaugeloop
