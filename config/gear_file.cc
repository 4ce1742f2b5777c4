// Gear part files.
#include "config/gear_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

#include "compensation/gear_coupling.h"
#include "config/part_file.h"
#include "config/toml_reader.h"
#include "core/text_file.h"

namespace gaugeloop {
namespace {

Hand read_hand(TomlReader& r, std::string_view key) {
  const std::string name = r.choice(key, "right", {"right", "left"});
  return hand_from_name(name).value_or(Hand::kRight);
}

// The line of the key validate's message names ("[gear.worm] starts = 0: ..."), else the file.
std::string where_validate_points(const toml::table& top, std::string_view source, const std::string& message) {
  for (const auto& [path, table] :
       {std::pair<std::string, std::string>{"[gear.worm] ", "worm"}, {"[gear.stroke] ", "stroke"}, {"[gear] ", ""}}) {
    if (message.rfind(path, 0) != 0) continue;
    const std::string key = message.substr(path.size(), message.find(' ', path.size()) - path.size());
    const toml::node* node = top["gear"].node();
    if (node != nullptr && !table.empty()) node = node->as_table() ? node->as_table()->get(table) : nullptr;
    if (node != nullptr && node->as_table()) node = node->as_table()->get(key);
    const auto line = node != nullptr ? node->source().begin.line : 0;
    return std::string(source) + (line > 0 ? ":" + std::to_string(line) : std::string());
  }
  return std::string(source);
}

}  // namespace

Result<GearPartFile> parse_gear_part_toml(std::string_view text, std::string_view source_name) {
  Result<toml::table> parsed = parse_toml(text, source_name);
  if (!parsed) return parsed.error();
  const toml::table& table = *parsed;
  TomlReader r(table, source_name);
  r.allow_only({"name", "nc_program", "gear"});
  GearPartFile out;
  out.name = r.text("name", std::nullopt);
  out.nc_program = r.text("nc_program", std::nullopt);
  if (!r.error && !valid_program_name(out.nc_program)) {
    r.fail(r.where("nc_program") + ": `" + out.nc_program +
           "` is not a valid NC program name; use up to 24 letters, digits and '_', starting with a letter");
  }
  const toml::table* gear = r.subtable("gear");
  if (gear == nullptr && !r.error) r.fail(std::string(source_name) + ": no [gear] section (docs/gears.md)");
  if (gear != nullptr && !r.error) {
    TomlReader g(*gear, source_name, "gear.");
    g.allow_only({"normal_module_mm", "teeth", "pressure_angle_deg", "helix_angle_deg", "hand", "face_width_mm", "worm",
                  "stroke"});
    GearGeometry& gg = out.part.gear;
    gg.normal_module_mm = g.number("normal_module_mm", std::nullopt, 0.0, 50.0, true);
    gg.teeth = static_cast<int>(g.integer("teeth", std::nullopt, 5, 1000));
    gg.pressure_angle_deg = g.number("pressure_angle_deg", 20.0, 5.0, 45.0);
    gg.helix_angle_deg = g.number("helix_angle_deg", std::nullopt, 0.0, 60.0);
    gg.hand = read_hand(g, "hand");
    gg.face_width_mm = g.number("face_width_mm", std::nullopt, 0.0, 2000.0, true);
    const toml::table* worm = g.subtable("worm");
    if (worm == nullptr && !g.error) g.fail(std::string(source_name) + ": no [gear.worm] section (docs/gears.md)");
    if (worm != nullptr && !g.error) {
      TomlReader w(*worm, source_name, "gear.worm.");
      w.allow_only({"starts", "pitch_diameter_mm", "lead_angle_deg", "hand"});
      out.part.worm.starts = static_cast<int>(w.integer("starts", std::nullopt, 1, 10));
      out.part.worm.pitch_diameter_mm = w.number("pitch_diameter_mm", std::nullopt, 0.0, 2000.0, true);
      out.part.worm.lead_angle_deg = w.number("lead_angle_deg", 0.0, 0.0, 45.0);
      out.part.worm.hand = read_hand(w, "hand");
      if (w.error) g.fail(w.error->message);
    }
    const toml::table* stroke = g.subtable("stroke");
    if (stroke == nullptr && !g.error) g.fail(std::string(source_name) + ": no [gear.stroke] section (docs/gears.md)");
    if (stroke != nullptr && !g.error) {
      TomlReader s(*stroke, source_name, "gear.stroke.");
      s.allow_only({"z_start_mm", "z_end_mm", "spline_step_mm"});
      out.part.stroke.z_start_mm = s.number("z_start_mm", std::nullopt, -5000.0, 5000.0);
      out.part.stroke.z_end_mm = s.number("z_end_mm", std::nullopt, -5000.0, 5000.0);
      out.part.stroke.spline_step_mm = s.number("spline_step_mm", 1.0, 0.0, 1000.0, true);
      if (s.error) g.fail(s.error->message);
    }
    if (g.error) r.fail(g.error->message);
  }
  if (r.error) return *r.error;
  if (Status s = validate(out.part); !s) {
    return make_error(ErrorCode::kInvalidInput,
                      where_validate_points(table, source_name, s.error().message) + ": " + s.error().message);
  }
  return out;
}

Result<StrokeAxisErrors> parse_axis_errors_csv(std::string_view text, std::string_view source_name) {
  StrokeAxisErrors out;
  out.source = std::string(source_name);
  const std::vector<std::string> names{"z_mm", "y_error_um", "z_error_um", "b_error_deg", "c_error_deg"};
  std::vector<std::vector<double>*> columns{&out.z_mm, &out.y_error_um, &out.z_error_um, &out.b_error_deg,
                                            &out.c_error_deg};
  std::vector<int> order;  // file column -> our column
  int line_no = 0;
  auto fail = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ":" + std::to_string(line_no) + ": " + why);
  };
  auto cells_of = [](std::string_view line) {
    std::vector<std::string> cells;
    std::size_t pos = 0;
    while (true) {
      const std::size_t comma = line.find(',', pos);
      std::string cell(line.substr(pos, comma == std::string_view::npos ? std::string_view::npos : comma - pos));
      while (!cell.empty() && (cell.back() == ' ' || cell.back() == '\r' || cell.back() == '\t')) cell.pop_back();
      while (!cell.empty() && (cell.front() == ' ' || cell.front() == '\t')) cell.erase(cell.begin());
      cells.push_back(cell);
      if (comma == std::string_view::npos) break;
      pos = comma + 1;
    }
    return cells;
  };
  std::size_t pos = 0;
  while (pos <= text.size()) {
    const std::size_t nl = text.find('\n', pos);
    std::string_view line = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.find_first_not_of(" \t") == std::string_view::npos || line.front() == '#') continue;
    const std::vector<std::string> cells = cells_of(line);
    if (order.empty()) {
      for (const std::string& c : cells) {
        const auto it = std::find(names.begin(), names.end(), c);
        if (it == names.end()) {
          return fail("unknown column `" + c +
                      "`; the columns are z_mm, y_error_um, z_error_um, b_error_deg, "
                      "c_error_deg");
        }
        if (std::find(order.begin(), order.end(), it - names.begin()) != order.end()) {
          return fail("column `" + c + "` is given twice");
        }
        order.push_back(static_cast<int>(it - names.begin()));
      }
      if (order.size() != names.size()) {
        return fail(
            "the header must name all five columns z_mm, y_error_um, z_error_um, b_error_deg, c_error_deg "
            "(an axis without errors: a column of zeros)");
      }
      continue;
    }
    if (cells.size() != order.size()) {
      return fail(std::to_string(cells.size()) + " values, the header names " + std::to_string(order.size()));
    }
    for (std::size_t c = 0; c < cells.size(); ++c) {
      char* end = nullptr;
      const double v = std::strtod(cells[c].c_str(), &end);
      if (cells[c].empty() || end != cells[c].c_str() + cells[c].size() || !std::isfinite(v)) {
        return fail("column " + names[static_cast<std::size_t>(order[c])] + ": `" + cells[c] + "` is not a number");
      }
      columns[static_cast<std::size_t>(order[c])]->push_back(v);
    }
  }
  if (order.empty()) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) +
                                                    ": empty; expected a header line naming "
                                                    "z_mm, y_error_um, z_error_um, b_error_deg, "
                                                    "c_error_deg and one row per Z");
  }
  return out;
}

Result<StrokeAxisErrors> read_axis_errors_csv(const std::filesystem::path& path) {
  Result<std::string> text = read_regular_file(path, "axis error table");
  if (!text) return text.error();
  return parse_axis_errors_csv(without_utf8_bom(*text), path.string());
}

Result<GearPartFile> read_gear_part_file(const std::filesystem::path& path) {
  Result<std::string> text = read_regular_file(path, "gear part file");
  if (!text) return text.error();
  return parse_gear_part_toml(without_utf8_bom(*text), path.string());
}

Result<bool> is_gear_part_file(const std::filesystem::path& path) {
  Result<std::string> text = read_regular_file(path, "part file");
  if (!text) return text.error();
  Result<toml::table> parsed = parse_toml(without_utf8_bom(*text), path.string());
  if (!parsed) return parsed.error();
  return parsed->contains("gear");
}

}  // namespace gaugeloop
