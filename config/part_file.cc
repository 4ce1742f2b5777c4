// toml++ reading of part files, with the file, line and key in every message.
#include "config/part_file.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <sstream>
#include <utility>

#include "compensation/pin_kinematics.h"
#include "config/toml_reader.h"
#include "core/text_file.h"
#include "nc_out/infeed.h"

namespace gaugeloop {
bool valid_program_name(std::string_view name) {
  if (name.empty() || name.size() > 24 || !std::isalpha(static_cast<unsigned char>(name[0]))) return false;
  for (char c : name) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

namespace {

std::string number_text(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

// "file:line" of a node (the file alone when toml++ gives no line).
std::string at(std::string_view source, const toml::node& node) {
  const auto line = node.source().begin.line;
  return std::string(source) + (line > 0 ? ":" + std::to_string(line) : std::string());
}

// The two numbers of a `[first, second]` array, or why not. Only the shape is checked here.
std::optional<std::pair<double, double>> number_pair(TomlReader& r, std::string_view key, const toml::array& a,
                                                     std::string_view what) {
  if (a.size() != 2) {
    r.fail(r.where(key) + ": expected " + std::string(what) + ", two numbers; got " + std::to_string(a.size()));
    return std::nullopt;
  }
  const auto first = a[0].value<double>();
  const auto second = a[1].value<double>();
  if (!first || !second || !a[0].is_number() || !a[1].is_number() || !std::isfinite(*first) ||
      !std::isfinite(*second)) {
    r.fail(r.where(key) + ": expected " + std::string(what) + ", two finite numbers");
    return std::nullopt;
  }
  return std::pair{*first, *second};
}

// A tolerance that may be one-sided or not: a number x > 0 means [-x, x]; `[lower, upper]`
// gives both limits, lower < upper. Absent: no limits (not judged).
Limits symmetric_or_range(TomlReader& r, const toml::table& table, std::string_view key) {
  const toml::node* n = table.get(key);
  if (n == nullptr) return {};
  const std::string allowed = "; give a number x > 0 for [-x, x], or [lower, upper] with lower < upper";
  if (const toml::array* a = n->as_array()) {
    auto pair = number_pair(r, key, *a, "[lower, upper]");
    if (!pair) return {};
    if (pair->first >= pair->second) {
      r.fail(r.where(key) + ": lower limit " + number_text(pair->first) + " is not below upper limit " +
             number_text(pair->second) + allowed);
      return {};
    }
    return Limits{pair->first, pair->second};
  }
  const auto v = n->value<double>();
  if (!n->is_number() || !v || !std::isfinite(*v)) {
    r.fail(r.where(key) + ": expected a number" + allowed);
    return {};
  }
  if (*v <= 0.0) {
    r.fail(r.where(key) + ": " + number_text(*v) + " is not a tolerance" + allowed);
    return {};
  }
  return Limits{-*v, *v};
}

// A figure that only has an upper limit (a runout, a roundness): one number > 0.
Limits upper_only(TomlReader& r, const toml::table& table, std::string_view key) {
  const toml::node* n = table.get(key);
  if (n == nullptr) return {};
  const std::string allowed = "; it has an upper limit only: give one number > 0, e.g. " + std::string(key) + " = 8.0";
  if (n->is_array()) {
    r.fail(r.where(key) + ": [lower, upper] is not allowed here" + allowed);
    return {};
  }
  const auto v = n->value<double>();
  if (!n->is_number() || !v || !std::isfinite(*v)) {
    r.fail(r.where(key) + ": expected a number" + allowed);
    return {};
  }
  if (*v <= 0.0) {
    r.fail(r.where(key) + ": " + number_text(*v) + " is not a limit" + allowed);
    return {};
  }
  return Limits{std::nullopt, *v};
}

// One [[tolerance.zone]]: which zone, where it is (by cam angle or by design lift) and its
// limits. Overlaps and zones that hold no degree depend on the design and are checked when
// the run is judged; here only what the file alone can tell.
std::optional<ZoneTolerance> read_zone(const toml::table& table, std::string_view source, TomlReader& outer) {
  TomlReader r(table, source, "tolerance.zone.");
  r.allow_only(
      {"zone", "angle_deg", "lift_mm", "lift_error_um", "velocity_error_mm_per_deg", "acceleration_error_mm_per_deg2"});
  ZoneTolerance z;
  if (!r.has("zone")) {
    r.fail(at(source, table) + ": [[tolerance.zone]] without key `tolerance.zone.zone`; name the zone: " +
           "base_circle, opening_ramp, opening_flank, nose, closing_flank or closing_ramp");
  } else {
    const std::string name =
        r.choice("zone", std::nullopt,
                 {"base_circle", "opening_ramp", "opening_flank", "nose", "closing_flank", "closing_ramp"});
    if (auto zone = lobe_zone_from_name(name)) z.zone = *zone;
  }
  const bool by_angle = r.has("angle_deg");
  z.by_lift = r.has("lift_mm");
  if (by_angle == z.by_lift) {
    r.fail((by_angle ? r.where("lift_mm") : at(source, table) + ": [[tolerance.zone]]") +
           ": give exactly one of angle_deg = [from, to] (cam degrees) or lift_mm = [from, to] (design lift)");
  }
  if (by_angle) {
    const toml::array* a = table.get("angle_deg")->as_array();
    if (a == nullptr) {
      r.fail(r.where("angle_deg") +
             ": expected [from, to], the arc from the first angle up to the second, in "
             "cam degrees with the nose at 0, each in [-360, 360]");
    } else if (auto pair = number_pair(r, "angle_deg", *a, "[from, to] in cam degrees")) {
      for (double deg : {pair->first, pair->second}) {
        if (deg < -360.0 || deg > 360.0) {
          r.fail(r.where("angle_deg") + ": " + number_text(deg) + " is out of range; angles are in [-360, 360]");
        }
      }
      z.from_deg = pair->first;
      z.to_deg = pair->second;
    }
  }
  if (z.by_lift) {
    const toml::array* a = table.get("lift_mm")->as_array();
    if (a == nullptr) {
      r.fail(r.where("lift_mm") + ": expected [from, to], the design lift in mm from `from` (included) up to `to`");
    } else if (auto pair = number_pair(r, "lift_mm", *a, "[from, to] in mm of design lift")) {
      if (pair->first < 0.0 || pair->first >= pair->second) {
        r.fail(r.where("lift_mm") + ": [" + number_text(pair->first) + ", " + number_text(pair->second) +
               "] is not a lift band; allowed 0 <= from < to");
      }
      z.from_lift_mm = pair->first;
      z.to_lift_mm = pair->second;
    }
  }
  z.lift_error_um = symmetric_or_range(r, table, "lift_error_um");
  z.velocity_error_mm_per_deg = symmetric_or_range(r, table, "velocity_error_mm_per_deg");
  z.acceleration_error_mm_per_deg2 = symmetric_or_range(r, table, "acceleration_error_mm_per_deg2");
  if (r.error) {
    outer.fail(r.error->message);
    return std::nullopt;
  }
  return z;
}

// [tolerance]: absent means nothing is judged.
LobeTolerances read_tolerances(TomlReader& top, std::string_view source) {
  LobeTolerances t;
  const toml::table* table = top.subtable("tolerance");
  if (table == nullptr) return t;
  TomlReader r(*table, source, "tolerance.");
  r.allow_only({"lift_error", "lift_error_um", "velocity_error_mm_per_deg", "acceleration_error_mm_per_deg2",
                "phase_deg", "base_circle_runout_um", "roundness_um", "zone"});
  const std::string reference = r.choice("lift_error", "best_fit", {"best_fit", "nominal"});
  t.lift_error_reference = reference == "nominal" ? LiftErrorReference::kNominal : LiftErrorReference::kBestFit;
  t.lift_error_um = symmetric_or_range(r, *table, "lift_error_um");
  t.velocity_error_mm_per_deg = symmetric_or_range(r, *table, "velocity_error_mm_per_deg");
  t.acceleration_error_mm_per_deg2 = symmetric_or_range(r, *table, "acceleration_error_mm_per_deg2");
  t.phase_deg = symmetric_or_range(r, *table, "phase_deg");
  t.base_circle_runout_um = upper_only(r, *table, "base_circle_runout_um");
  t.roundness_um = upper_only(r, *table, "roundness_um");
  if (const toml::node* zones = table->get("zone")) {
    const toml::array* list = zones->as_array();
    if (list == nullptr || !list->is_array_of_tables()) {
      r.fail(r.where("zone") + ": expected [[tolerance.zone]] tables, one per zone");
    } else {
      std::vector<std::string> first_at;  // "file:line" of each zone read, by index into t.zones
      for (const toml::node& node : *list) {
        const toml::table& zt = *node.as_table();
        std::optional<ZoneTolerance> z = read_zone(zt, source, r);
        if (!z) break;
        for (size_t i = 0; i < t.zones.size(); ++i) {
          if (t.zones[i].zone == z->zone) {
            r.fail(at(source, *zt.get("zone")) + ": key `tolerance.zone.zone`: zone `" +
                   std::string(lobe_zone_name(z->zone)) + "` is given twice (first at " + first_at[i] +
                   "); one [[tolerance.zone]] per zone");
          }
        }
        if (r.error) break;
        t.zones.push_back(*z);
        first_at.push_back(at(source, *zt.get("zone")));
      }
    }
  }
  if (r.error) top.fail(r.error->message);
  return t;
}

// [speed]: absent means one work speed. Ranges as validate(WorkSpeedSettings). `hold` says
// where the grinding-point speed is held: "lobe" (lobe_speed_mm_per_min on the lobe) or
// "flanks" (grinding_point_speed_mm_per_min all round, flank_speed_mm_per_min on the rise and
// return); the other hold's keys are refused by name.
std::optional<WorkSpeedSettings> read_speed(TomlReader& top, std::string_view source) {
  const toml::table* table = top.subtable("speed");
  if (table == nullptr) return std::nullopt;
  TomlReader r(*table, source, "speed.");
  r.allow_only({"hold", "base_speed_rpm", "lobe_speed_mm_per_min", "lobe_threshold_mm",
                "grinding_point_speed_mm_per_min", "flank_speed_mm_per_min", "c_acceleration_max_deg_per_s2"});
  WorkSpeedSettings s;
  const std::string hold = r.choice("hold", std::string("lobe"), {"lobe", "flanks"});
  s.hold = hold == "flanks" ? SpeedHold::kFlanks : SpeedHold::kLobe;
  s.base_speed_rpm = r.number("base_speed_rpm", s.base_speed_rpm, 0.0, 1000.0, true);
  const bool flanks = s.hold == SpeedHold::kFlanks;
  const std::array<std::string_view, 2> lobe_keys{"lobe_speed_mm_per_min", "lobe_threshold_mm"};
  const std::array<std::string_view, 2> flank_keys{"grinding_point_speed_mm_per_min", "flank_speed_mm_per_min"};
  for (std::string_view key : flanks ? lobe_keys : flank_keys) {
    if (r.has(key) && !r.error) {
      r.fail(r.where(key) + ": not used with hold = \"" + hold + "\"; " +
             (flanks ? "give grinding_point_speed_mm_per_min and flank_speed_mm_per_min"
                     : "give lobe_speed_mm_per_min, or set hold = \"flanks\"") +
             " (docs/variable_speed.md)");
    }
  }
  if (flanks) {
    s.grinding_point_speed_mm_per_min = r.number("grinding_point_speed_mm_per_min", std::nullopt, 0.0, 1e5, true);
    s.flank_speed_mm_per_min = r.number("flank_speed_mm_per_min", std::nullopt, 0.0, 1e5, true);
  } else {
    s.lobe_speed_mm_per_min = r.number("lobe_speed_mm_per_min", std::nullopt, 0.0, 1e5, true);
    s.lobe_threshold_mm = r.number("lobe_threshold_mm", s.lobe_threshold_mm, 0.0, 10.0, true);
  }
  s.c_acceleration_max_deg_per_s2 =
      r.number("c_acceleration_max_deg_per_s2", s.c_acceleration_max_deg_per_s2, 0.0, 1e7, true);
  if (r.error) top.fail(r.error->message);
  return s;
}

// [grinding]: the allowance and the passes; absent: GrindingCycle's defaults. Ranges and
// consistency as validate(GrindingCycle), with the file, line and key.
GrindingCycle read_grinding(TomlReader& top, std::string_view source) {
  GrindingCycle g;
  const toml::table* table = top.subtable("grinding");
  if (table == nullptr) return g;
  TomlReader r(*table, source, "grinding.");
  r.allow_only({"stock_mm", "air_gap_mm", "roughing_infeed_mm_per_turn", "finishing_stock_mm",
                "finishing_infeed_mm_per_turn", "spark_out_turns"});
  g.stock_mm = r.number("stock_mm", g.stock_mm, 0.0, 5.0);
  g.air_gap_mm = r.number("air_gap_mm", g.air_gap_mm, 0.0, 5.0);
  g.roughing_infeed_mm_per_turn =
      r.number("roughing_infeed_mm_per_turn", g.roughing_infeed_mm_per_turn, 0.0, 1.0, true);
  g.finishing_stock_mm = r.number("finishing_stock_mm", g.finishing_stock_mm, 0.0, 5.0);
  g.finishing_infeed_mm_per_turn =
      r.number("finishing_infeed_mm_per_turn", g.finishing_infeed_mm_per_turn, 0.0, 1.0, true);
  g.spark_out_turns = static_cast<int>(r.integer("spark_out_turns", g.spark_out_turns, 0, 100));
  if (!r.error && g.finishing_stock_mm > g.stock_mm) {
    r.fail(r.where(r.has("finishing_stock_mm") ? "finishing_stock_mm" : "stock_mm") + ": finishing_stock_mm " +
           number_text(g.finishing_stock_mm) + " mm is more than stock_mm " + number_text(g.stock_mm) +
           " mm; the finishing stock is the last part of the stock: make it at most stock_mm");
  }
  if (!r.error) {
    if (Status s = validate(g); !s) r.fail(at(source, *table) + ": " + s.error().message);
  }
  if (r.error) top.fail(r.error->message);
  return g;
}

// [correction_layer]: the correction as a table of its own on the virtual axis SIM1, summed
// with the design table by the gearbox (docs/nc_output.md). Absent: 0, one whole table.
int read_correction_layer(TomlReader& top, std::string_view source) {
  const toml::table* table = top.subtable("correction_layer");
  if (table == nullptr) return 0;
  TomlReader r(*table, source, "correction_layer.");
  r.allow_only({"design_table_number"});
  const int n = static_cast<int>(r.integer("design_table_number", 5, 1, 999));
  if (r.error) top.fail(r.error->message);
  return n;
}

// [pin.tolerance]: absent means nothing is judged. Read as the lobe's [tolerance].
PinTolerances read_pin_tolerances(TomlReader& pin, std::string_view source) {
  PinTolerances t;
  const toml::table* table = pin.subtable("tolerance");
  if (table == nullptr) return t;
  TomlReader r(*table, source, "pin.tolerance.");
  r.allow_only({"roundness_um", "diameter_error_um", "stroke_error_um", "index_error_deg"});
  t.roundness_um = upper_only(r, *table, "roundness_um");
  t.diameter_error_um = symmetric_or_range(r, *table, "diameter_error_um");
  t.stroke_error_um = symmetric_or_range(r, *table, "stroke_error_um");
  t.index_error_deg = symmetric_or_range(r, *table, "index_error_deg");
  if (r.error) pin.fail(r.error->message);
  return t;
}

// drawing_number and drawing_revision, for the reports.
void read_drawing(TomlReader& r, Part& p) {
  p.drawing_number = r.label("drawing_number", "as the drawing's title block gives it");
  p.drawing_revision = r.label("drawing_revision", "as the drawing's title block gives it");
}

// A part file with [pin]: a crankpin. The lobe's keys mean nothing for it and are refused by
// name rather than ignored, so a lobe file with a stray [pin] is never ground as a pin unseen.
Result<PartFile> parse_pin_part(const toml::table& table, std::string_view source) {
  TomlReader r(table, source);
  for (std::string_view key : {"lobe", "lift_table", "follower", "follower_radius_mm", "base_circle_radius_mm",
                               "wheel_radius_mm", "rotation_sense", "c_offset_deg", "probe_offset_deg", "tolerance"}) {
    if (!table.contains(key)) continue;
    const std::string instead = key == "lobe"              ? "give the pin's number as pin_number"
                                : key == "wheel_radius_mm" ? "give it in [pin]"
                                : key == "tolerance"       ? "give a pin's tolerances in [pin.tolerance]"
                                                           : "remove it";
    r.fail(r.where(key) + ": a lobe's key, and this file describes a crankpin ([pin]); " + instead +
           " (docs/parts.md)");
  }
  r.allow_only({"name", "pin_number", "nc_program", "speed", "pin", "grinding", "drawing_number", "drawing_revision"});
  PartFile out;
  Part& p = out.part;
  p.name = r.text("name", std::nullopt);
  read_drawing(r, p);
  p.lobe = static_cast<int>(r.integer("pin_number", 1, 1, 64));
  out.nc_program = r.text("nc_program", std::nullopt);
  if (!r.error && !valid_program_name(out.nc_program)) {
    r.fail(r.where("nc_program") + ": `" + out.nc_program +
           "` is not a valid NC program name; use up to 24 letters, digits and '_', starting with a letter");
  }
  PinGeometry pin;
  const toml::table* pin_table = r.subtable("pin");
  if (pin_table != nullptr) {
    TomlReader pr(*pin_table, source, "pin.");
    pr.allow_only(
        {"throw_mm", "pin_radius_mm", "wheel_radius_mm", "pin_angle_deg", "mode", "gauge_offset_deg", "tolerance"});
    pin.throw_mm = pr.number("throw_mm", std::nullopt, 0.0, 2000.0, true);
    pin.pin_radius_mm = pr.number("pin_radius_mm", std::nullopt, 0.0, 1000.0, true);
    pin.wheel_radius_mm = pr.number("wheel_radius_mm", std::nullopt, 0.0, 2000.0, true);
    pin.pin_angle_deg = pr.number("pin_angle_deg", std::nullopt, -360.0, 360.0);
    const std::string mode = pr.choice("mode", std::nullopt, {"c-x", "c-x-y"});
    if (auto m = pin_mode_from_name(mode)) pin.mode = *m;
    pin.gauge_offset_deg = pr.number("gauge_offset_deg", 180.0, -360.0, 360.0);
    pin.tolerances = read_pin_tolerances(pr, source);
    if (!pr.error) {
      if (Status s = validate(pin); !s) {
        // The line of the key the message names, else that of [pin].
        std::string where = at(source, *pin_table);
        for (std::string_view key : {"throw_mm", "pin_radius_mm", "wheel_radius_mm", "pin_angle_deg"}) {
          if (s.error().message.find(key) != std::string::npos) {
            where = at(source, *pin_table->get(key));
            break;
          }
        }
        pr.fail(where + ": " + s.error().message);
      }
    }
    if (pr.error) r.fail(pr.error->message);
  }
  if (r.has("speed") && !r.error && pin.mode == PinMode::kCXY) {
    r.fail(r.where("speed") +
           ": a pin ground C-X-Y keeps its grinding-point speed constant at a constant C speed, so it has no "
           "speed program; remove [speed], or grind the pin with mode = \"c-x\"");
  }
  out.speed = read_speed(r, source);
  out.grinding = read_grinding(r, source);
  if (!r.error && out.speed && out.speed->hold != SpeedHold::kLobe) {
    r.fail(r.where("speed") +
           ": hold = \"flanks\" is for a cam lobe; a pin has no flanks: hold its grinding-point speed all round "
           "with lobe_speed_mm_per_min");
  }
  if (r.error) return *r.error;
  p.wheel_radius_mm = pin.wheel_radius_mm;
  out.pin = pin;
  return out;
}

}  // namespace

Result<PartFile> parse_part_toml(std::string_view text, std::string_view source_name,
                                 const std::filesystem::path& base_dir) {
  Result<toml::table> parsed = parse_toml(text, source_name);
  if (!parsed) return parsed.error();
  const toml::table& table = *parsed;
  if (table.contains("gear")) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(source_name) +
                          ": a gear part ([gear]): measure and nc new take cam lobes and crankpins; `gaugeloop "
                          "gear coupling --part " +
                          std::string(source_name) + "` derives its electronic gearbox, `gaugeloop demo --part " +
                          std::string(source_name) + "` grinds it on the virtual gear grinder (docs/gears.md)");
  }
  if (table.contains("pin")) return parse_pin_part(table, source_name);
  TomlReader r(table, source_name);
  r.allow_only({"name", "lobe", "lift_table", "follower", "follower_radius_mm", "base_circle_radius_mm",
                "wheel_radius_mm", "rotation_sense", "c_offset_deg", "probe_offset_deg", "nc_program", "tolerance",
                "speed", "grinding", "correction_layer", "drawing_number", "drawing_revision"});
  PartFile out;
  Part& p = out.part;
  p.name = r.text("name", std::nullopt);
  read_drawing(r, p);
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
  p.tolerances = read_tolerances(r, source_name);
  out.speed = read_speed(r, source_name);
  out.grinding = read_grinding(r, source_name);
  out.layer_design_table_number = read_correction_layer(r, source_name);
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
