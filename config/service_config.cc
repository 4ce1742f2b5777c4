// toml++ reading of the service configuration, every message with file, line and key.
#include "config/service_config.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>

#include "config/gauge_config.h"
#include "config/service_config_internal.h"
#include "config/shaft_file.h"
#include "config/toml_reader.h"
#include "core/text_file.h"
#include "core/utc_time.h"
#include "plant/central_history.h"
#include "plant/plant_messages.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using config_internal::ConfigFile;
using config_internal::read_http_table;
using config_internal::read_plant_table;
using config_internal::read_plc_table;
using config_internal::read_text;
using config_internal::relative_to;

// The service creates and writes files in `dir` (the database, NC programs): the directory, or
// the nearest one above it that exists (the rest is created), must be a directory this user
// may write. Caught at load, not at the first run: under the systemd unit /etc is read-only
// (ProtectSystem=strict), so a path left relative to a config in /etc/gaugeloop fails there.
Status check_writable_dir(const fs::path& dir, const std::string& what) {
  fs::path at = dir;
  std::error_code ec;
  while (!at.empty() && at != at.root_path() && !fs::exists(at, ec)) at = at.parent_path();
  if (at.empty()) at = ".";
  const std::string advice = "; give a directory this user can write, e.g. under /var/lib/gaugeloop";
  if (!fs::is_directory(at, ec)) {
    return make_error(ErrorCode::kInvalidInput,
                      what + " " + dir.string() + ": " + at.string() + " is not a directory" + advice);
  }
  if (::access(at.c_str(), W_OK | X_OK) != 0) {
    const std::string why = std::strerror(errno);
    return make_error(ErrorCode::kInvalidInput,
                      what + " " + dir.string() + ": " + at.string() + " is not writable (" + why + ")" + advice);
  }
  return {};
}

// The database: its directory as above, and the file itself writable if it exists.
Status check_writable_database(const fs::path& db_path) {
  if (Status d = check_writable_dir(db_path.parent_path(), "database directory"); !d) return d;
  std::error_code ec;
  if (fs::exists(db_path, ec) && ::access(db_path.c_str(), W_OK) != 0) {
    const std::string why = std::strerror(errno);
    return make_error(ErrorCode::kInvalidInput, "database " + db_path.string() + " is not writable (" + why +
                                                    "); the service's user must own it (chown it to them)");
  }
  return {};
}

// [gauge]: the gauge config file (link and register map), sampling mode and revolutions. A
// missing table fails `top` (reported after the other tables, with the top level's errors).
Status read_gauge_table(TomlReader& top, const ConfigFile& f, ServiceConfig& c) {
  const toml::table* g = top.subtable("gauge");
  if (g == nullptr) {
    top.fail(f.source + ": no [gauge] table; it names the gauge config (link and register map, docs/gauge.md)");
    return {};
  }
  TomlReader gr(*g, f.source, "gauge.");
  gr.allow_only({"config", "mode", "revolutions", "id", "calibration_date"});
  const std::string gauge_file = gr.text("config", "");
  c.job.gauge_id = gr.label("id", "the gauge's inventory number");
  c.job.gauge_calibration_date = gr.text("calibration_date", "");
  if (!c.job.gauge_calibration_date.empty() && !is_past_calendar_date(c.job.gauge_calibration_date)) {
    gr.fail(gr.where("calibration_date") + ": `" + c.job.gauge_calibration_date +
            "` is not a past day as YYYY-MM-DD; give the date on the gauge's calibration certificate");
  }
  PollerSettings& poller = c.job.poller;
  poller.mode =
      gr.choice("mode", "latched", {"latched", "live"}) == "live" ? SamplingMode::kLive : SamplingMode::kLatched;
  poller.revolutions = static_cast<int>(gr.integer("revolutions", 3, 3, 100));
  if (gr.error) return *gr.error;
  if (!gauge_file.empty()) {
    Result<ModbusSettings> gs = read_gauge_file(f.resolve(gauge_file));
    if (!gs) return gr.at_key("config", gs.error());
    c.gauge = std::move(*gs);
  }
  return {};
}

// [analysis]: the base-circle window the lobe is zeroed on.
Status read_analysis_table(TomlReader& top, const ConfigFile& f, AnalysisSettings& a) {
  const toml::table* t = top.subtable("analysis");
  if (t == nullptr) return {};
  TomlReader ar(*t, f.source, "analysis.");
  ar.allow_only({"base_circle_center_deg", "base_circle_half_width_deg"});
  a.base_circle_center_deg = ar.number("base_circle_center_deg", 180.0, 0.0, 360.0);
  a.base_circle_half_width_deg = ar.number("base_circle_half_width_deg", 30.0, 0.0, 90.0, true);
  if (ar.error) return *ar.error;
  return {};
}

// [compensation]: the gain and the guards on a correction.
Status read_compensation_table(TomlReader& top, const ConfigFile& f, JobSettings& job) {
  const toml::table* t = top.subtable("compensation");
  if (t == nullptr) return {};
  TomlReader kr(*t, f.source, "compensation.");
  kr.allow_only({"gain", "harmonics", "max_harmonic", "max_correction_um", "max_change_um", "max_repeatability_um",
                 "max_phase_deg", "build_on_table_in_force"});
  CompensationSettings& s = job.compensation;
  s.gain = kr.number("gain", 1.0, 0.0, 1.0, true);
  // harmonics = "auto": the band from the measurement, capped at max_harmonic; N: 0..N always.
  const toml::node* harmonics = t->get("harmonics");
  if (harmonics != nullptr && !harmonics->is_string()) {
    s.choose_harmonics = false;
    s.max_harmonic = static_cast<int>(kr.integer("harmonics", 30, 0, 180));
    if (kr.has("max_harmonic")) {
      kr.fail(kr.where("max_harmonic") +
              ": is the cap of harmonics = \"auto\"; with a fixed harmonics count it has no use: remove one");
    }
  } else {
    kr.choice("harmonics", "auto", {"auto"});
    s.choose_harmonics = true;
    s.max_harmonic = static_cast<int>(kr.integer("max_harmonic", 30, 0, 180));
  }
  s.max_correction_um = kr.number("max_correction_um", 100.0, 0.0, 10000.0, true);
  s.max_change_um = kr.number("max_change_um", 50.0, 0.0, 10000.0, true);
  s.max_repeatability_um = kr.number("max_repeatability_um", 2.0, 0.0, 1000.0, true);
  s.max_phase_deg = kr.number("max_phase_deg", 0.5, 0.0, 45.0, true);
  job.build_on_table_in_force = kr.flag("build_on_table_in_force", true);
  if (kr.error) return *kr.error;
  return {};
}

// The keys of [nc] that shape the table and bound the infeed axis.
void read_nc_table_keys(TomlReader& nr, JobSettings& job) {
  job.table_kind = table_kind_named(nr.choice("table", "auto", table_kind_names()));
  job.table_step_deg = nr.number("table_step_deg", 1.0, 0.0, 10.0, true);
  job.table_choice.bound_um = nr.number("command_error_um", 0.5, 0.0, 100.0, true);
  job.table_choice.max_step_deg = nr.number("max_segment_deg", 10.0, 0.0, 90.0, true);
  job.table_choice.allow_spline = nr.flag("allow_spline", true);
  job.require_approval = nr.flag("require_approval", false);
  job.nc_archive_header = nr.flag("archive_header", false);
  // The control's MD10200 $MN_INT_INCR_PER_MM: X is written on its grid (curve_table.h).
  job.table_format.x_increments_per_mm = static_cast<double>(nr.integer("int_incr_per_mm", 10000, 1, 1000000));
  AxisLimits& l = job.axis_limits;
  l.x_min_mm = nr.number("x_min_mm", l.x_min_mm, -1000.0, 1000.0);
  l.x_max_mm = nr.number("x_max_mm", l.x_max_mm, -1000.0, 1000.0);
  l.x_velocity_max_mm_per_s = nr.number("x_velocity_max_mm_per_s", l.x_velocity_max_mm_per_s, 0.0, 1e6, true);
  l.x_acceleration_max_mm_per_s2 =
      nr.number("x_acceleration_max_mm_per_s2", l.x_acceleration_max_mm_per_s2, 0.0, 1e8, true);
  l.speed_rpm = nr.number("work_speed_rpm", l.speed_rpm, 0.0, 3000.0, true);
  // A crankpin grinder's vertical slide (C-X-Y pins only).
  AxisLimits& y = job.y_axis_limits;
  y.x_min_mm = nr.number("y_min_mm", y.x_min_mm, -1000.0, 1000.0);
  y.x_max_mm = nr.number("y_max_mm", y.x_max_mm, -1000.0, 1000.0);
  y.x_velocity_max_mm_per_s = nr.number("y_velocity_max_mm_per_s", y.x_velocity_max_mm_per_s, 0.0, 1e6, true);
  y.x_acceleration_max_mm_per_s2 =
      nr.number("y_acceleration_max_mm_per_s2", y.x_acceleration_max_mm_per_s2, 0.0, 1e8, true);
  y.speed_rpm = l.speed_rpm;
}

// `key` = [A, B]: two distinct whole numbers 1..999, or nothing (empty) when absent or wrong
// (nr.fail says which).
std::optional<TableNumbers> read_number_pair(TomlReader& nr, const toml::table& t, const std::string& key,
                                             const std::string& example) {
  const toml::node* node = t.get(key);
  if (node == nullptr) return std::nullopt;
  const std::string expected = ": expected two distinct whole numbers 1..999, e.g. " + key + " = " + example;
  const toml::array* a = node->as_array();
  if (a == nullptr || a->size() != 2) {
    nr.fail(nr.where(key) + expected);
    return std::nullopt;
  }
  TableNumbers numbers{0, 0};
  for (std::size_t i = 0; i < 2; ++i) {
    const std::optional<std::int64_t> v = a->get(i)->value_exact<std::int64_t>();
    if (!v || *v < 1 || *v > 999) {
      nr.fail(nr.where(key) + expected);
      return std::nullopt;
    }
    numbers[i] = static_cast<int>(*v);
  }
  if (numbers[0] == numbers[1]) {
    nr.fail(nr.where(key) + ": the two numbers are both " + std::to_string(numbers[0]) +
            "; they must differ, so a new table never redefines the one coupled");
    return std::nullopt;
  }
  return numbers;
}

// table_numbers = [A, B]: two distinct numbers 1..999. The older single table_number = N is
// read as [N, N + 1], the pair it would have been written as; both at once are refused.
void read_table_numbers(TomlReader& nr, const toml::table& t, JobSettings& job) {
  if (nr.has("table_number") && nr.has("table_numbers")) {
    nr.fail(nr.where("table_number") + ": give table_numbers = [A, B] alone; table_number is its older form");
    return;
  }
  if (nr.has("table_number")) {
    const long long n = nr.integer("table_number", 1, 1, 998);
    if (nr.error) {
      nr.error->message +=
          " (998 at most: it is read as table_numbers = [N, N + 1]; write table_numbers to choose both)";
      return;
    }
    job.table_numbers = {static_cast<int>(n), static_cast<int>(n + 1)};
    return;
  }
  if (std::optional<TableNumbers> numbers = read_number_pair(nr, t, "table_numbers", "[1, 2]")) {
    job.table_numbers = *numbers;
  }
  if (std::optional<TableNumbers> y = read_number_pair(nr, t, "y_table_numbers", "[3, 4]")) job.y_table_numbers = *y;
  // Given, they must stay clear of the X tables' numbers. Left at their default they matter
  // only to a C-X-Y pin (check_y_table_numbers), so a service of lobes may use 3 and 4.
  if (!nr.has("y_table_numbers")) return;
  for (int y : job.y_table_numbers) {
    if (!nr.error && (y == job.table_numbers[0] || y == job.table_numbers[1])) {
      nr.fail(nr.where("y_table_numbers") + ": table " + std::to_string(y) +
              " would hold both a pin's X table and its Y table; give y_table_numbers two "
              "numbers the X tables do not use");
      return;
    }
  }
}

// A C-X-Y pin's Y tables go to y_table_numbers, 3 and 4 unless [nc] gives them: refused
// (naming the part's entry) when table_numbers gives one of them to the X tables.
Status check_y_table_numbers(const TomlReader& pr, const JobSettings& job) {
  if (!job.pin || job.pin->mode != PinMode::kCXY) return {};
  for (int y : job.y_table_numbers) {
    if (y == job.table_numbers[0] || y == job.table_numbers[1]) {
      return make_error(ErrorCode::kInvalidInput,
                        pr.where("file") + ": part " + job.part.name + " is a C-X-Y pin, and its Y tables would go " +
                            "to table " + std::to_string(y) + ", which [nc] table_numbers gives the X tables; give " +
                            "[nc] y_table_numbers two numbers the X tables do not use");
    }
  }
  return {};
}

// [nc]: the output directory (writable), the template (required, read now), the main
// program's template (optional, read now) and the table keys.
Status read_nc_table(TomlReader& top, const ConfigFile& f, ServiceConfig& c) {
  JobSettings& job = c.job;
  std::string template_path;
  job.nc_dir = f.resolve("nc");
  if (const toml::table* t = top.subtable("nc")) {
    TomlReader nr(*t, f.source, "nc.");
    nr.allow_only({"dir",
                   "template",
                   "table",
                   "table_step_deg",
                   "command_error_um",
                   "pin_command_error_um",
                   "max_segment_deg",
                   "allow_spline",
                   "require_approval",
                   "table_number",
                   "table_numbers",
                   "main_template",
                   "int_incr_per_mm",
                   "archive_header",
                   "x_min_mm",
                   "x_max_mm",
                   "x_velocity_max_mm_per_s",
                   "x_acceleration_max_mm_per_s2",
                   "work_speed_rpm",
                   "speed_template",
                   "main_speed_template",
                   "y_template",
                   "y_table_numbers",
                   "pin_main_template",
                   "pin_main_xy_template",
                   "layer_main_template",
                   "y_min_mm",
                   "y_max_mm",
                   "y_velocity_max_mm_per_s",
                   "y_acceleration_max_mm_per_s2"});
    job.nc_dir = f.resolve(nr.text("dir", "nc"));
    template_path = nr.text("template", "");
    const std::string main_path = nr.text("main_template", "");
    const std::string speed_path = nr.text("speed_template", "");
    const std::string main_speed_path = nr.text("main_speed_template", "");
    const std::string y_path = nr.text("y_template", "");
    const std::string pin_main_path = nr.text("pin_main_template", "");
    const std::string pin_main_xy_path = nr.text("pin_main_xy_template", "");
    const std::string layer_main_path = nr.text("layer_main_template", "");
    read_nc_table_keys(nr, job);
    c.pin_command_error_um = nr.number("pin_command_error_um", kPinCommandErrorBoundUm, 0.0, 100.0, true);
    read_table_numbers(nr, *t, job);
    if (nr.error) return *nr.error;
    if (!main_path.empty()) {
      Result<std::string> text = read_text(f.resolve(main_path), "NC main program template");
      if (!text) return nr.at_key("main_template", text.error());
      job.nc_main_template = std::move(*text);
      job.nc_main_template_name = f.resolve(main_path).string();
    }
    if (!speed_path.empty()) {
      Result<std::string> text = read_text(f.resolve(speed_path), "NC speed subprogram template");
      if (!text) return nr.at_key("speed_template", text.error());
      job.nc_speed_template = std::move(*text);
      job.nc_speed_template_name = f.resolve(speed_path).string();
    }
    if (!main_speed_path.empty()) {
      Result<std::string> text = read_text(f.resolve(main_speed_path), "NC main program template (speed)");
      if (!text) return nr.at_key("main_speed_template", text.error());
      c.nc_main_speed_template = std::move(*text);
      c.nc_main_speed_template_name = f.resolve(main_speed_path).string();
    }
    // Crankpins: the Y table's template, and the main programs coupling X (C-X) or X and Y (C-X-Y).
    auto read_template = [&](const std::string& path, const char* key, std::string& text_out,
                             std::string& name_out) -> Status {
      if (path.empty()) return {};
      Result<std::string> text = read_text(f.resolve(path), "NC template");
      if (!text) return nr.at_key(key, text.error());
      text_out = std::move(*text);
      name_out = f.resolve(path).string();
      return {};
    };
    if (Status r = read_template(y_path, "y_template", job.nc_y_template, job.nc_y_template_name); !r) return r;
    if (Status r =
            read_template(pin_main_path, "pin_main_template", c.nc_pin_main_template, c.nc_pin_main_template_name);
        !r) {
      return r;
    }
    if (Status r = read_template(pin_main_xy_path, "pin_main_xy_template", c.nc_pin_main_xy_template,
                                 c.nc_pin_main_xy_template_name);
        !r) {
      return r;
    }
    if (Status r = read_template(layer_main_path, "layer_main_template", c.nc_layer_main_template,
                                 c.nc_layer_main_template_name);
        !r) {
      return r;
    }
    if (!(job.y_axis_limits.x_min_mm < job.y_axis_limits.x_max_mm)) {
      return make_error(ErrorCode::kInvalidInput, nr.where("y_max_mm") + ": must be above y_min_mm");
    }
    if (!(job.axis_limits.x_min_mm < job.axis_limits.x_max_mm)) {
      return make_error(ErrorCode::kInvalidInput, nr.where("x_max_mm") + ": must be above x_min_mm");
    }
    if (Status w = check_writable_dir(job.nc_dir, "NC directory"); !w) return nr.at_key("dir", w.error());
    if (!template_path.empty()) {
      Result<std::string> text = read_text(f.resolve(template_path), "NC template");
      if (!text) return nr.at_key("template", text.error());
      job.nc_template = std::move(*text);
      job.nc_template_name = f.resolve(template_path).string();
    }
  }
  if (template_path.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      f.source +
                          ": [nc] template is required: your table subprogram with {{placeholders}}, e.g. "
                          "examples/sinumerik/cam_table.spf (docs/nc_output.md)");
  }
  return {};
}

// [database]: the run database's path, writable by this user (also when left at its default).
Status read_database_table(TomlReader& top, const ConfigFile& f, JobSettings& job, int& integrity_check_hours) {
  job.db_path = f.resolve("gaugeloop.sqlite");
  if (const toml::table* t = top.subtable("database")) {
    TomlReader dr(*t, f.source, "database.");
    dr.allow_only({"path", "integrity_check_hours"});
    job.db_path = f.resolve(dr.text("path", "gaugeloop.sqlite"));
    integrity_check_hours = static_cast<int>(dr.integer("integrity_check_hours", 24, 1, 8760));
    if (dr.error) return *dr.error;
    if (Status w = check_writable_database(job.db_path); !w) return dr.at_key("path", w.error());
  } else if (Status w = check_writable_database(job.db_path); !w) {
    return make_error(ErrorCode::kInvalidInput,
                      f.source + ": [database] path (default " + job.db_path.string() + "): " + w.error().message);
  }
  return {};
}

// What the [[part]] entries read so far claim, to refuse a part or a PLC number given twice.
struct PartClaims {
  std::set<std::pair<std::string, int>> parts;  // (name, lobe)
  std::map<int, std::string> plc_number_part;   // plc_part_number -> part name
  std::set<std::pair<int, int>> plc_numbers;    // (plc_part_number, lobe)
};

// The PLC number of a part: one number is one part name, and (number, lobe) is unique.
Status claim_plc_number(const TomlReader& pr, int plc_number, const Part& part, PartClaims& claims) {
  auto [it, fresh] = claims.plc_number_part.emplace(plc_number, part.name);
  if (!fresh && it->second != part.name) {
    return make_error(ErrorCode::kInvalidInput, pr.where("plc_part_number") + ": " + std::to_string(plc_number) +
                                                    " already names part " + it->second + ", not " + part.name +
                                                    "; give each part its own number");
  }
  if (!claims.plc_numbers.insert({plc_number, part.lobe}).second) {
    return make_error(ErrorCode::kInvalidInput, pr.where("plc_part_number") + ": part number " +
                                                    std::to_string(plc_number) + " lobe " + std::to_string(part.lobe) +
                                                    " is configured twice");
  }
  return {};
}

// One [[part]]: its part file and design read, its claims checked, and its job settings
// checked (the design within the axis limits, the template rendering) before it is added.
Status read_part_entry(const toml::table& entry, const ConfigFile& f, PartClaims& claims, ServiceConfig& c) {
  TomlReader pr(entry, f.source, "part.");
  pr.allow_only({"file", "plc_part_number"});
  const std::string file = pr.text("file", std::nullopt);
  std::optional<int> plc_number;
  if (pr.has("plc_part_number")) plc_number = static_cast<int>(pr.integer("plc_part_number", std::nullopt, 1, 65535));
  if (pr.error) return *pr.error;
  Result<PartFile> pf = read_part_file(f.resolve(file));
  if (!pf) return pr.at_key("file", pf.error());
  Result<LiftTable> design = pf->pin ? Result<LiftTable>(LiftTable{}) : read_lift_table_csv(pf->part.lift_table);
  if (!design) return pr.at_key("file", design.error());
  if (!claims.parts.insert({pf->part.name, pf->part.lobe}).second) {
    return make_error(ErrorCode::kInvalidInput, pr.where("file") + ": part " + pf->part.name + " lobe " +
                                                    std::to_string(pf->part.lobe) + " is configured twice");
  }
  if (plc_number) {
    if (Status claimed = claim_plc_number(pr, *plc_number, pf->part, claims); !claimed) return claimed;
  }
  c.parts.push_back({std::move(*pf), std::move(*design), plc_number});
  const JobSettings job = job_for(c, c.parts.back());
  if (Status y = check_y_table_numbers(pr, job); !y) return y;
  if (Status ok = check_job_settings(job); !ok) return pr.at_key("file", ok.error());
  return {};
}

// [[part]]: each a part file; checked now, so a bad part never waits for the PLC to ask.
// Reports the top level's own errors first (unknown keys, a missing [gauge]), as those were
// found before any part was read.
Status read_part_entries(const toml::table& table, TomlReader& top, const ConfigFile& f, ServiceConfig& c) {
  const toml::node* parts = table.get("part");
  if (parts == nullptr || !parts->is_array_of_tables() || parts->as_array()->empty()) {
    top.fail(f.source + ": no [[part]] entries; add one `[[part]] file = \"PART.toml\"` per part and lobe measured");
  }
  if (top.error) return *top.error;
  PartClaims claims;
  for (const toml::node& node : *parts->as_array()) {
    if (Status read = read_part_entry(*node.as_table(), f, claims, c); !read) return read;
  }
  if (c.plc && claims.plc_number_part.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      f.source +
                          ": [plc] is set but no [[part]] has a plc_part_number, so the PLC could ask for "
                          "nothing; give each part the PLC measures `plc_part_number = N`");
  }
  return {};
}

// [[shaft]]: each a shaft file (lobes and their angles), for the pages' camshaft record
// (/api/shaft). Optional; checked now like the parts. Names are unique.
Status read_shaft_entries(const toml::table& table, const ConfigFile& f, ServiceConfig& c) {
  const toml::node* shafts = table.get("shaft");
  if (shafts == nullptr) return {};
  if (!shafts->is_array_of_tables()) {
    return make_error(ErrorCode::kInvalidInput,
                      f.source + ": `shaft` must be [[shaft]] entries, each `file = \"SHAFT.toml\"`");
  }
  for (const toml::node& node : *shafts->as_array()) {
    TomlReader sr(*node.as_table(), f.source, "shaft.");
    sr.allow_only({"file"});
    const std::string file = sr.text("file", std::nullopt);
    if (sr.error) return *sr.error;
    Result<ShaftFile> shaft = read_shaft_file(f.resolve(file));
    if (!shaft) return sr.at_key("file", shaft.error());
    for (const ShaftLayout& known : c.shafts) {
      if (known.name == shaft->layout.name) {
        return make_error(ErrorCode::kInvalidInput, sr.where("file") + ": shaft '" + known.name +
                                                        "' is named twice; give each shaft file its own name");
      }
    }
    c.shafts.push_back(std::move(shaft->layout));
  }
  return {};
}

}  // namespace

// The tables are read in a fixed order and the first error is returned, except that the top
// level's own errors (unknown keys, a table of the wrong type, a missing [gauge]) are kept
// until the parts are read (read_part_entries).
Result<ServiceConfig> read_service_config(const fs::path& path) {
  Result<std::string> text = read_text(path, "service config");
  if (!text) {
    Error e = text.error();
    e.message += "; check --config";
    return e;
  }
  const ConfigFile f{path.string(), path.parent_path()};
  Result<toml::table> parsed = parse_toml(*text, f.source);
  if (!parsed) return parsed.error();
  const toml::table& table = *parsed;
  TomlReader top(table, f.source);
  top.allow_only(
      {"machine", "gauge", "part", "shaft", "analysis", "compensation", "nc", "database", "http", "plc", "plant"});

  ServiceConfig c;
  c.source = path;
  c.machine = top.text("machine", "grinder-1");
  c.job.machine = c.machine;
  if (Status s = read_gauge_table(top, f, c); !s) return s.error();
  if (Status s = read_analysis_table(top, f, c.job.analysis); !s) return s.error();
  if (Status s = read_compensation_table(top, f, c.job); !s) return s.error();
  if (Status s = read_nc_table(top, f, c); !s) return s.error();
  if (Status s = read_database_table(top, f, c.job, c.integrity_check_hours); !s) return s.error();
  if (Status s = read_plant_table(top, f, c); !s) return s.error();  // before [http]: its history
  Result<std::optional<HttpSettings>> http = read_http_table(top, f, c.central);
  if (!http) return http.error();
  c.http = std::move(*http);
  Result<std::optional<PlcSettings>> plc = read_plc_table(top, f);
  if (!plc) return plc.error();
  c.plc = std::move(*plc);
  if (Status s = read_part_entries(table, top, f, c); !s) return s.error();
  if (Status s = read_shaft_entries(table, f, c); !s) return s.error();
  return c;
}

Result<ServiceDataPaths> read_service_data_paths(const fs::path& path) {
  Result<std::string> text = read_text(path, "service config");
  if (!text) return text.error();
  const ConfigFile f{path.string(), path.parent_path()};
  Result<toml::table> parsed = parse_toml(*text, f.source);
  if (!parsed) return parsed.error();
  TomlReader top(*parsed, f.source);
  ServiceDataPaths paths{f.resolve("gaugeloop.sqlite"), f.resolve("nc"), top.text("machine", "grinder-1")};
  if (const toml::table* t = top.subtable("database")) {
    TomlReader dr(*t, f.source, "database.");
    paths.db_path = f.resolve(dr.text("path", "gaugeloop.sqlite"));
    if (dr.error) return *dr.error;
  }
  if (const toml::table* t = top.subtable("nc")) {
    TomlReader nr(*t, f.source, "nc.");
    paths.nc_dir = f.resolve(nr.text("dir", "nc"));
    if (nr.error) return *nr.error;
  }
  if (top.error) return *top.error;
  return paths;
}

Result<const ServicePart*> find_plc_part(const ServiceConfig& config, int plc_part_number, int lobe) {
  std::string known;
  for (const ServicePart& p : config.parts) {
    if (!p.plc_part_number) continue;
    if (*p.plc_part_number == plc_part_number && p.file.part.lobe == lobe) return &p;
    known += (known.empty() ? "" : ", ") + std::to_string(*p.plc_part_number) + " lobe " +
             std::to_string(p.file.part.lobe) + " (" + p.file.part.name + ")";
  }
  return make_error(ErrorCode::kNotFound, "PLC part number " + std::to_string(plc_part_number) + " lobe " +
                                              std::to_string(lobe) + " is not in " + config.source.string() +
                                              "; configured: " + (known.empty() ? "none" : known));
}

std::string configured_parts(const ServiceConfig& config) {
  std::string known;
  for (const ServicePart& p : config.parts) {
    known += (known.empty() ? "" : ", ") + p.file.part.name + " lobe " + std::to_string(p.file.part.lobe);
  }
  return known;
}

Result<const ServicePart*> find_part(const ServiceConfig& config, const std::string& name, int lobe) {
  for (const ServicePart& p : config.parts) {
    if (p.file.part.name == name && p.file.part.lobe == lobe) return &p;
  }
  return make_error(ErrorCode::kNotFound, "part " + name + " lobe " + std::to_string(lobe) + " is not in " +
                                              config.source.string() + "; configured: " + configured_parts(config));
}

JobSettings job_for(const ServiceConfig& config, const ServicePart& part) {
  JobSettings js = config.job;
  js.part = part.file.part;
  js.design = part.design;
  js.nc_program = part.file.nc_program;
  js.speed = part.file.speed;
  js.cycle = part.file.grinding;
  js.pin = part.file.pin;
  js.layer_design_table_number = part.file.layer_design_table_number;
  if (js.layer_design_table_number != 0) {
    // A correction layer's main program couples the design table and the layer: [nc]
    // layer_main_template; without it the lobes' main template, which the job then refuses.
    if (!config.nc_layer_main_template.empty()) {
      js.nc_main_template = config.nc_layer_main_template;
      js.nc_main_template_name = config.nc_layer_main_template_name;
    }
  } else if (js.speed && !config.nc_main_speed_template.empty()) {
    js.nc_main_template = config.nc_main_speed_template;
    js.nc_main_template_name = config.nc_main_speed_template_name;
  } else if (js.pin) {
    // A pin's main program couples what its mode moves: X, or X and Y.
    const bool with_y = js.pin->mode == PinMode::kCXY;
    const std::string& text = with_y ? config.nc_pin_main_xy_template : config.nc_pin_main_template;
    js.nc_main_template = text;
    js.nc_main_template_name = text.empty()
                                   ? std::string()
                                   : (with_y ? config.nc_pin_main_xy_template_name : config.nc_pin_main_template_name);
  }
  if (js.pin) js.table_choice.bound_um = config.pin_command_error_um;
  return js;
}

}  // namespace gaugeloop
