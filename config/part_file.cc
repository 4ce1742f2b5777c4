// toml++ reading of part files, with the file, line and key in every message.
#include "config/part_file.h"

#include <cctype>

#include "config/toml_reader.h"
#include "core/text_file.h"

namespace gaugeloop {
namespace {

bool valid_program_name(const std::string& name) {
  if (name.empty() || name.size() > 24 || !std::isalpha(static_cast<unsigned char>(name[0]))) return false;
  for (char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

}  // namespace

Result<PartFile> parse_part_toml(std::string_view text, std::string_view source_name,
                                 const std::filesystem::path& base_dir) {
  Result<toml::table> parsed = parse_toml(text, source_name);
  if (!parsed) return parsed.error();
  const toml::table& table = *parsed;
  TomlReader r(table, source_name);
  r.allow_only({"name", "lobe", "lift_table", "follower", "follower_radius_mm", "base_circle_radius_mm",
                "wheel_radius_mm", "rotation_sense", "c_offset_deg", "probe_offset_deg", "nc_program"});
  PartFile out;
  Part& p = out.part;
  p.name = r.text("name", std::nullopt);
  p.lobe = static_cast<int>(r.integer("lobe", 1, 1, 64));
  const std::string table_path = r.text("lift_table", std::nullopt);
  const std::string follower = r.choice("follower", std::nullopt, {"flat", "roller", "knife_edge"});
  p.follower = follower == "roller"       ? FollowerKind::kRoller
               : follower == "knife_edge" ? FollowerKind::kKnifeEdge
                                          : FollowerKind::kFlat;
  if (p.follower == FollowerKind::kRoller) {
    p.follower_radius_mm = r.number("follower_radius_mm", std::nullopt, 0.0, 500.0, true);
  } else if (table.contains("follower_radius_mm")) {
    r.fail(r.where("follower_radius_mm") +
           ": only a roller follower has a radius; remove the key or set follower = \"roller\"");
  }
  p.base_circle_radius_mm = r.number("base_circle_radius_mm", std::nullopt, 0.0, 1000.0, true);
  p.wheel_radius_mm = r.number("wheel_radius_mm", std::nullopt, 0.0, 2000.0, true);
  const long long sense = r.integer("rotation_sense", 1, -1, 1);
  if (sense == 0) r.fail(r.where("rotation_sense") + ": must be 1 or -1");
  p.rotation_sense = sense < 0 ? -1 : 1;
  p.c_offset_deg = r.number("c_offset_deg", 0.0, -360.0, 360.0);
  p.probe_offset_deg = r.number("probe_offset_deg", 0.0, -360.0, 360.0);
  out.nc_program = r.text("nc_program", std::nullopt);
  if (!r.error && !valid_program_name(out.nc_program)) {
    r.fail(r.where("nc_program") + ": `" + out.nc_program +
           "` is not a valid NC program name; use up to 24 letters, digits and '_', starting with a letter");
  }
  if (r.error) return *r.error;
  const std::filesystem::path lt(table_path);
  p.lift_table = lt.is_absolute() ? lt : base_dir / lt;
  return out;
}

Result<PartFile> read_part_file(const std::filesystem::path& path) {
  Result<std::string> text = read_regular_file(path, "part file");
  if (!text) return text.error();
  return parse_part_toml(without_utf8_bom(*text), path.string(), path.parent_path());
}

}  // namespace gaugeloop
