// Gear part files.
#include "config/gear_file.h"

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

Result<GearPartFile> read_gear_part_file(const std::filesystem::path& path) {
  Result<std::string> text = read_regular_file(path, "gear part file");
  if (!text) return text.error();
  return parse_gear_part_toml(without_utf8_bom(*text), path.string());
}

}  // namespace gaugeloop
