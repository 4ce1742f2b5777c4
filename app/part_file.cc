// toml++ reading of part files, with the file, line and key in every message.
#include "app/part_file.h"

#include <toml++/toml.h>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace gaugeloop {
namespace {

class PartReader {
 public:
  PartReader(const toml::table& table, std::string_view source) : table_(table), source_(source) {}

  std::string where(std::string_view key) const {
    const toml::node* n = table_.get(key);
    const auto line = n != nullptr ? n->source().begin.line : 0;
    return std::string(source_) + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": key `" +
           std::string(key) + "`";
  }

  std::optional<Error> error;

  std::string text(std::string_view key, std::optional<std::string> fallback) {
    const toml::node* n = table_.get(key);
    if (n == nullptr) return missing(key, fallback);
    if (auto v = n->value<std::string>()) return *v;
    fail(where(key) + ": expected a string in quotes");
    return {};
  }

  double number(std::string_view key, std::optional<double> fallback, double min, double max, bool open_min = false) {
    const toml::node* n = table_.get(key);
    if (n == nullptr) {
      if (fallback) return *fallback;
      fail(std::string(source_) + ": key `" + std::string(key) + "` is missing; it is required");
      return 0.0;
    }
    auto v = n->value<double>();  // integers convert too
    if (!v || !std::isfinite(*v)) {
      fail(where(key) + ": expected a number");
      return 0.0;
    }
    if ((open_min ? *v <= min : *v < min) || *v > max) {
      std::ostringstream os;
      os << where(key) << ": " << *v << " is out of range; allowed " << (open_min ? "(" : "[") << min << ", " << max
         << "]";
      fail(os.str());
    }
    return *v;
  }

  void fail(std::string message) {
    if (!error) error = make_error(ErrorCode::kInvalidInput, std::move(message));
  }

 private:
  std::string missing(std::string_view key, const std::optional<std::string>& fallback) {
    if (fallback) return *fallback;
    fail(std::string(source_) + ": key `" + std::string(key) + "` is missing; it is required");
    return {};
  }

  const toml::table& table_;
  std::string_view source_;
};

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
  toml::table table;
  try {
    table = toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ":" + std::to_string(e.source().begin.line) +
                                                    ": " + std::string(e.description()));
  }
  static const std::set<std::string, std::less<>> kKeys = {"name",
                                                           "lobe",
                                                           "lift_table",
                                                           "follower",
                                                           "follower_radius_mm",
                                                           "base_circle_radius_mm",
                                                           "wheel_radius_mm",
                                                           "rotation_sense",
                                                           "c_offset_deg",
                                                           "probe_offset_deg",
                                                           "nc_program"};
  PartReader r(table, source_name);
  for (const auto& [key, node] : table) {
    if (kKeys.find(key.str()) == kKeys.end()) {
      std::string known;
      for (const auto& k : kKeys) known += (known.empty() ? "" : ", ") + k;
      r.fail(r.where(key.str()) + ": unknown key; known keys: " + known);
    }
  }
  PartFile out;
  Part& p = out.part;
  p.name = r.text("name", std::nullopt);
  p.lobe = static_cast<int>(r.number("lobe", 1.0, 1, 64));
  const std::string table_path = r.text("lift_table", std::nullopt);
  const std::string follower = r.text("follower", std::nullopt);
  if (follower == "flat") {
    p.follower = FollowerKind::kFlat;
  } else if (follower == "roller") {
    p.follower = FollowerKind::kRoller;
  } else if (follower == "knife_edge") {
    p.follower = FollowerKind::kKnifeEdge;
  } else if (!r.error) {
    r.fail(r.where("follower") + ": `" + follower + "` is not a follower; use flat, roller or knife_edge");
  }
  if (p.follower == FollowerKind::kRoller) {
    p.follower_radius_mm = r.number("follower_radius_mm", std::nullopt, 0.0, 500.0, true);
  } else if (table.contains("follower_radius_mm")) {
    r.fail(r.where("follower_radius_mm") +
           ": only a roller follower has a radius; remove the key or set follower = \"roller\"");
  }
  p.base_circle_radius_mm = r.number("base_circle_radius_mm", std::nullopt, 0.0, 1000.0, true);
  p.wheel_radius_mm = r.number("wheel_radius_mm", std::nullopt, 0.0, 2000.0, true);
  const double sense = r.number("rotation_sense", 1.0, -1.0, 1.0);
  if (sense != 1.0 && sense != -1.0) r.fail(r.where("rotation_sense") + ": must be 1 or -1");
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
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    return make_error(ErrorCode::kNotFound, "part file " + path.string() + ": cannot be opened; check the --part path");
  }
  std::ostringstream buf;
  buf << in.rdbuf();
  return parse_part_toml(buf.str(), path.string(), path.parent_path());
}

}  // namespace gaugeloop
