// toml++ reading of shaft files, with the file, line and key in every message.
#include "config/shaft_file.h"

#include <cmath>
#include <set>

#include "config/part_file.h"
#include "config/toml_reader.h"
#include "core/number_text.h"
#include "core/text_file.h"

namespace gaugeloop {
namespace {

// A part file grinds its nose at C = c_offset_deg; the shaft wants it at reference + angle.
// A difference is not refused (the part file may serve another shaft too), but said. Runs
// keep the frame mapping they were measured with, so a record read later is not affected.
void note_offset_mismatch(const ShaftLayout& layout, const ShaftLobe& lobe, const Part& part,
                          std::vector<std::string>& notes) {
  const double wanted_c = layout.reference_c_deg + lobe.angle_deg;
  const double difference = wrap_deg_180(part.c_offset_deg - wanted_c);
  if (std::abs(difference) < 1e-9) return;
  notes.push_back("lobe " + std::to_string(lobe.lobe) + " (" + lobe.part_file.filename().string() +
                  "): the part file grinds the nose at C = " + format_fixed(part.c_offset_deg, 3) +
                  " deg, the shaft places it at C = " + format_fixed(wanted_c, 3) +
                  " deg; a lobe ground with this part file stands " + format_signed_fixed(difference, 3) +
                  " deg off (index error) unless its c_offset_deg is " + format_fixed(wanted_c, 3));
}

}  // namespace

Result<ShaftFile> parse_shaft_toml(std::string_view text, std::string_view source_name,
                                   const std::filesystem::path& base_dir) {
  Result<toml::table> parsed = parse_toml(text, source_name);
  if (!parsed) return parsed.error();
  const toml::table& table = *parsed;
  TomlReader r(table, source_name);
  r.allow_only({"name", "reference_c_deg", "index_tolerance_deg", "lobe"});
  ShaftFile out;
  ShaftLayout& s = out.layout;
  s.name = r.text("name", std::nullopt);
  s.reference_c_deg = r.number("reference_c_deg", 0.0, -360.0, 360.0);
  if (r.has("index_tolerance_deg"))
    s.index_tolerance_deg = r.number("index_tolerance_deg", std::nullopt, 0.0, 180.0, true);
  const toml::node* lobes = table.get("lobe");
  if (lobes == nullptr || !lobes->is_array_of_tables() || lobes->as_array()->empty()) {
    r.fail(std::string(source_name) +
           ": no [[lobe]] entries; add one `[[lobe]]` with `part = \"PART.toml\"` and `angle_deg = A` per lobe");
  }
  if (r.error) return *r.error;
  std::set<int> numbers;
  for (const toml::node& node : *lobes->as_array()) {
    TomlReader lr(*node.as_table(), source_name, "lobe.");
    lr.allow_only({"part", "angle_deg"});
    const std::string file = lr.text("part", std::nullopt);
    const double angle_deg = lr.number("angle_deg", std::nullopt, -360.0, 360.0);
    if (lr.error) return *lr.error;
    const std::filesystem::path named(file);
    const std::filesystem::path path = named.is_absolute() ? named : base_dir / named;
    Result<PartFile> pf = read_part_file(path);
    if (!pf) return lr.at_key("part", pf.error());
    if (!numbers.insert(pf->part.lobe).second) {
      return make_error(ErrorCode::kInvalidInput,
                        lr.where("part") + ": lobe " + std::to_string(pf->part.lobe) + " (part " + pf->part.name +
                            ") is on the shaft twice; each lobe number once, as the part files' `lobe` says");
    }
    ShaftLobe lobe{pf->part.lobe, pf->part.name, path, angle_deg};
    note_offset_mismatch(s, lobe, pf->part, out.notes);
    s.lobes.push_back(std::move(lobe));
  }
  return out;
}

Result<ShaftFile> read_shaft_file(const std::filesystem::path& path) {
  Result<std::string> text = read_regular_file(path, "shaft file");
  if (!text) return text.error();
  return parse_shaft_toml(without_utf8_bom(*text), path.string(), path.parent_path());
}

}  // namespace gaugeloop
