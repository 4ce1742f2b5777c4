// Gear part files.
#include "config/gear_file.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "compensation/gear_coupling.h"
#include "config/part_file.h"
#include "config/toml_reader.h"
#include "core/number_text.h"
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
    g.allow_only({"normal_module_mm", "teeth", "pressure_angle_deg", "helix_angle_deg", "hand", "face_width_mm",
                  "tolerance_class", "worm", "stroke"});
    GearGeometry& gg = out.part.gear;
    gg.normal_module_mm = g.number("normal_module_mm", std::nullopt, 0.0, 50.0, true);
    gg.teeth = static_cast<int>(g.integer("teeth", std::nullopt, 5, 1000));
    gg.pressure_angle_deg = g.number("pressure_angle_deg", 20.0, 5.0, 45.0);
    gg.helix_angle_deg = g.number("helix_angle_deg", std::nullopt, 0.0, 60.0);
    gg.hand = read_hand(g, "hand");
    gg.face_width_mm = g.number("face_width_mm", std::nullopt, 0.0, 2000.0, true);
    if (g.has("tolerance_class")) out.tolerance_class = static_cast<int>(g.integer("tolerance_class", 0, 1, 11));
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

namespace {

// The cells of one CSV line, blanks around each trimmed.
std::vector<std::string> cells_of(std::string_view line) {
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
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

// A CSV table whose header names every one of `names` once, in any order, and no other: calls
// `row` with each data line's number and its cells in the order of `names`. Blank lines and
// lines starting with '#' are skipped. kInvalidInput naming the line for an unknown, repeated or
// missing column, a row of another length, an empty table; `row`'s errors as it gives them.
Status for_each_row(std::string_view text, std::string_view source_name, const std::vector<std::string>& names,
                    std::string_view what,
                    const std::function<Status(int line_no, const std::vector<std::string>& cells)>& row) {
  std::vector<std::size_t> order;  // file column -> index in names
  int line_no = 0;
  auto fail = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ":" + std::to_string(line_no) + ": " + why);
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
        if (it == names.end()) return fail("unknown column `" + c + "`; the columns are " + joined(names));
        const auto index = static_cast<std::size_t>(it - names.begin());
        if (std::find(order.begin(), order.end(), index) != order.end()) {
          return fail("column `" + c + "` is given twice");
        }
        order.push_back(index);
      }
      if (order.size() != names.size()) {
        return fail("the header must name all " + std::to_string(names.size()) + " columns " + joined(names) + " (" +
                    std::string(what) + ")");
      }
      continue;
    }
    if (cells.size() != order.size()) {
      return fail(std::to_string(cells.size()) + " values, the header names " + std::to_string(order.size()));
    }
    std::vector<std::string> ordered(names.size());
    for (std::size_t c = 0; c < cells.size(); ++c) ordered[order[c]] = cells[c];
    if (Status r = row(line_no, ordered); !r) return r;
  }
  if (order.empty()) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ": empty; expected a header line naming " +
                                                    joined(names) + " and " + std::string(what));
  }
  return {};
}

// Cell `c` of `cells` as a finite number, or kInvalidInput naming the line and column.
Result<double> number_cell(std::string_view source_name, int line_no, const std::vector<std::string>& names,
                           const std::vector<std::string>& cells, std::size_t c) {
  char* end = nullptr;
  const double v = std::strtod(cells[c].c_str(), &end);
  if (cells[c].empty() || end != cells[c].c_str() + cells[c].size() || !std::isfinite(v)) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ":" + std::to_string(line_no) + ": column " +
                                                    names[c] + ": `" + cells[c] + "` is not a number");
  }
  return v;
}

}  // namespace

Result<StrokeAxisErrors> parse_axis_errors_csv(std::string_view text, std::string_view source_name) {
  StrokeAxisErrors out;
  out.source = std::string(source_name);
  const std::vector<std::string> names{"z_mm", "y_error_um", "z_error_um", "b_error_deg", "c_error_deg"};
  std::vector<std::vector<double>*> columns{&out.z_mm, &out.y_error_um, &out.z_error_um, &out.b_error_deg,
                                            &out.c_error_deg};
  Status read = for_each_row(text, source_name, names, "one row per Z; an axis without errors: a column of zeros",
                             [&](int line_no, const std::vector<std::string>& cells) -> Status {
                               for (std::size_t c = 0; c < cells.size(); ++c) {
                                 Result<double> v = number_cell(source_name, line_no, names, cells, c);
                                 if (!v) return v.error();
                                 columns[c]->push_back(*v);
                               }
                               return {};
                             });
  if (!read) return read.error();
  return out;
}

Result<std::vector<LeadTrace>> parse_lead_traces_csv(std::string_view text, std::string_view source_name) {
  const std::vector<std::string> names{"gap", "flank", "z_mm", "deviation_um"};
  std::vector<LeadTrace> traces;
  std::vector<int> last_line;  // per trace: the line of its last point, for messages
  Status read =
      for_each_row(text, source_name, names, "one row per point of a trace",
                   [&](int line_no, const std::vector<std::string>& cells) -> Status {
                     auto fail = [&](const std::string& why) {
                       return make_error(ErrorCode::kInvalidInput,
                                         std::string(source_name) + ":" + std::to_string(line_no) + ": " + why);
                     };
                     char* end = nullptr;
                     const long gap = std::strtol(cells[0].c_str(), &end, 10);
                     if (cells[0].empty() || end != cells[0].c_str() + cells[0].size() || gap < 1 || gap > 1000) {
                       return fail("column gap: `" + cells[0] + "` is not a tooth gap number (1 to 1000)");
                     }
                     Flank flank = Flank::kLeft;
                     if (cells[1] == "left" || cells[1] == "L" || cells[1] == "l") {
                       flank = Flank::kLeft;
                     } else if (cells[1] == "right" || cells[1] == "R" || cells[1] == "r") {
                       flank = Flank::kRight;
                     } else {
                       return fail("column flank: `" + cells[1] + "`; expected left or right (L, R)");
                     }
                     Result<double> z = number_cell(source_name, line_no, names, cells, 2);
                     if (!z) return z.error();
                     Result<double> d = number_cell(source_name, line_no, names, cells, 3);
                     if (!d) return d.error();
                     auto it = std::find_if(traces.begin(), traces.end(),
                                            [&](const LeadTrace& t) { return t.gap == gap && t.flank == flank; });
                     if (it == traces.end()) {
                       traces.push_back(LeadTrace{static_cast<int>(gap), flank, {}, {}});
                       last_line.push_back(0);
                       it = traces.end() - 1;
                     }
                     const std::size_t i = static_cast<std::size_t>(it - traces.begin());
                     if (!it->z_mm.empty() && !(*z > it->z_mm.back())) {
                       return fail("gap " + std::to_string(gap) + ", " + std::string(flank_name(flank)) + " flank: Z " +
                                   cells[2] + " mm does not increase after line " + std::to_string(last_line[i]) +
                                   " (the points of a trace go up the face)");
                     }
                     it->z_mm.push_back(*z);
                     it->deviation_um.push_back(*d);
                     last_line[i] = line_no;
                     return {};
                   });
  if (!read) return read.error();
  if (traces.empty()) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ": no lead trace (a header and no rows)");
  }
  return traces;
}

Result<BallbarCircle> parse_ballbar_csv(std::string_view text, std::string_view source_name, double radius_mm) {
  const std::vector<std::string> names{"angle_deg", "radial_um"};
  BallbarCircle b;
  b.radius_mm = radius_mm;
  Status read = for_each_row(text, source_name, names, "one row per point of the circle",
                             [&](int line_no, const std::vector<std::string>& cells) -> Status {
                               Result<double> a = number_cell(source_name, line_no, names, cells, 0);
                               if (!a) return a.error();
                               Result<double> r = number_cell(source_name, line_no, names, cells, 1);
                               if (!r) return r.error();
                               b.angle_deg.push_back(*a);
                               b.radial_um.push_back(*r);
                               return {};
                             });
  if (!read) return read.error();
  return b;
}

Result<BallbarCircle> read_ballbar_csv(const std::filesystem::path& path, double radius_mm) {
  Result<std::string> text = read_regular_file(path, "ballbar circle");
  if (!text) return text.error();
  return parse_ballbar_csv(without_utf8_bom(*text), path.string(), radius_mm);
}

Result<BallbarTest> parse_ballbar_test_csv(std::string_view text, std::string_view source_name, double radius_mm,
                                           double feed_mm_per_min) {
  BallbarTest t;
  t.radius_mm = radius_mm;
  t.feed_mm_per_min = feed_mm_per_min;
  // The comments that give the circle's radius and feed.
  int line_no = 0;
  for (std::size_t pos = 0; pos <= text.size();) {
    const std::size_t nl = text.find('\n', pos);
    std::string_view line = text.substr(pos, nl == std::string_view::npos ? std::string_view::npos : nl - pos);
    pos = nl == std::string_view::npos ? text.size() + 1 : nl + 1;
    ++line_no;
    for (const auto& [key, field] : {std::pair<std::string_view, double*>{"# radius_mm:", &t.radius_mm},
                                     std::pair<std::string_view, double*>{"# feed_mm_per_min:", &t.feed_mm_per_min}}) {
      if (line.rfind(key, 0) != 0) continue;
      std::string v(line.substr(key.size()));
      v.erase(0, v.find_first_not_of(" \t"));
      while (!v.empty() && (v.back() == '\r' || v.back() == ' ')) v.pop_back();
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      if (v.empty() || end != v.c_str() + v.size() || !(x > 0.0) || !std::isfinite(x)) {
        return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ":" + std::to_string(line_no) + ": `" +
                                                        std::string(line) + "`: expected a positive number");
      }
      *field = x;
    }
  }
  t.ccw.radius_mm = t.cw.radius_mm = t.radius_mm;
  const std::vector<std::string> names{"direction", "angle_deg", "radial_um"};
  Status read = for_each_row(text, source_name, names, "one row per point, ccw or cw",
                             [&](int line, const std::vector<std::string>& cells) -> Status {
                               BallbarCircle* c = cells[0] == "ccw" ? &t.ccw : cells[0] == "cw" ? &t.cw : nullptr;
                               if (c == nullptr) {
                                 return make_error(ErrorCode::kInvalidInput,
                                                   std::string(source_name) + ":" + std::to_string(line) +
                                                       ": column direction: `" + cells[0] + "`; expected ccw or cw");
                               }
                               Result<double> a = number_cell(source_name, line, names, cells, 1);
                               if (!a) return a.error();
                               Result<double> r = number_cell(source_name, line, names, cells, 2);
                               if (!r) return r.error();
                               c->angle_deg.push_back(*a);
                               c->radial_um.push_back(*r);
                               return {};
                             });
  if (!read) return read.error();
  return t;
}

Result<BallbarTest> read_ballbar_test_csv(const std::filesystem::path& path, double radius_mm, double feed_mm_per_min) {
  Result<std::string> text = read_regular_file(path, "ballbar test");
  if (!text) return text.error();
  return parse_ballbar_test_csv(without_utf8_bom(*text), path.string(), radius_mm, feed_mm_per_min);
}

std::string ballbar_test_csv(const BallbarTest& t, std::string_view title) {
  std::string out = "# " + std::string(title) + "\n# radius_mm: " + format_fixed(t.radius_mm, 3) +
                    "\n# feed_mm_per_min: " + format_fixed(t.feed_mm_per_min, 1) + "\ndirection,angle_deg,radial_um\n";
  for (const auto& [name, c] : {std::pair<const char*, const BallbarCircle*>{"ccw", &t.ccw},
                                std::pair<const char*, const BallbarCircle*>{"cw", &t.cw}}) {
    for (std::size_t i = 0; i < c->angle_deg.size(); ++i) {
      out += std::string(name) + "," + format_fixed(c->angle_deg[i], 3) + "," + format_fixed(c->radial_um[i], 2) + "\n";
    }
  }
  return out;
}

Result<std::vector<LeadTrace>> read_lead_traces_csv(const std::filesystem::path& path) {
  Result<std::string> text = read_regular_file(path, "lead traces");
  if (!text) return text.error();
  return parse_lead_traces_csv(without_utf8_bom(*text), path.string());
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
