// JSON and CSV of stored runs, pushes, pending tables and events; UTC time bounds.
#include "report/run_json.h"
#include "report/gear_characteristics.h"

#include "core/number_text.h"
#include "report/judged_error.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <locale>
#include <sstream>

namespace gaugeloop {
namespace {

using nlohmann::json;

template <typename T>
json opt_json(const std::optional<T>& v) {
  return v ? json(*v) : json(nullptr);
}

json text_or_null(const std::string& s) { return s.empty() ? json(nullptr) : json(s); }

std::size_t argmax_abs(const DegreeTable& t) {
  std::size_t best = 0;
  for (std::size_t d = 1; d < t.size(); ++d) {
    if (std::abs(t[d]) > std::abs(t[best])) best = d;
  }
  return best;
}

// The raw reading of revolution `rev` at cam degree `beta`, when the frame is known: the
// probe saw cam angle beta at machine angle C = c0 + probe_offset + s * beta (the inverse of
// cam_angle_at_probe_deg). A C between whole degrees is interpolated linearly.
double raw_at_cam_deg(const RevolutionSamples& rev, const Part& g, int beta) {
  double c = g.c_offset_deg + g.probe_offset_deg + g.rotation_sense * static_cast<double>(beta);
  c = std::fmod(c, 360.0);
  if (c < 0) c += 360.0;
  const double lo = std::floor(c);
  const double w = c - lo;
  const auto i = static_cast<std::size_t>(lo) % 360;
  return rev.lift_mm[i] * (1.0 - w) + rev.lift_mm[(i + 1) % 360] * w;
}

}  // namespace

json run_summary_json(const RunSummary& r) {
  return {{"id", r.id},
          {"uuid", text_or_null(r.uuid)},
          {"started_utc", r.started_utc},
          {"machine", r.machine},
          {"part", r.part},
          {"lobe", r.lobe},
          {"status", r.status},
          {"revolutions", r.revolutions},
          {"degrees_captured", r.degrees_captured},
          {"max_abs_error_um", r.max_abs_error_um},
          {"rms_error_um", r.rms_error_um},
          {"peak_to_valley_um", r.peak_to_valley_um},
          {"repeatability_um", r.repeatability_um},
          {"phase_error_deg", opt_json(r.phase_error_deg)},
          {"base_circle_runout_um", opt_json(r.base_circle_runout_um)},
          {"settings_hash", text_or_null(r.settings_hash)},
          {"serial", text_or_null(r.serial)},
          {"operator", text_or_null(r.operator_name)},
          {"verdict", verdict_name(r.verdict)},
          {"note", r.note},
          {"nc_file", r.nc_file},
          {"raw_pruned_utc", text_or_null(r.raw_pruned_utc)}};
}

std::string run_setting(const std::string& settings, std::string_view key) {
  std::size_t at = 0;
  while (at < settings.size()) {
    const std::size_t end = std::min(settings.find('\n', at), settings.size());
    const std::string_view line(settings.data() + at, end - at);
    if (line.size() > key.size() + 3 && line.substr(0, key.size()) == key && line.substr(key.size(), 3) == " = ") {
      return std::string(line.substr(key.size() + 3));
    }
    at = end + 1;
  }
  return {};
}

RunPart run_part(const StoredRun& run) {
  RunPart part;
  if (run_setting(run.settings, "part.kind") == "pin") {
    part.kind = PartKind::kPin;
    part.pin_mode = pin_mode_from_name(run_setting(run.settings, "pin.mode"));
  }
  return part;
}

RunPartTemperature run_part_temperature(const StoredRun& run) {
  RunPartTemperature t;
  const std::string text = run_setting(run.settings, "part.temperature_c");
  double value = 0.0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (!text.empty() && ec == std::errc() && end == text.data() + text.size() && std::isfinite(value)) {
    t.temperature_c = value;
    t.source = run_setting(run.settings, "part.temperature_source");
  }
  return t;
}

std::string part_temperature_text(const RunPartTemperature& t, std::string_view unit) {
  if (!t.temperature_c) return "not given";
  const std::string who = t.source == "plc" ? "PLC" : t.source.empty() ? "source not recorded" : t.source;
  return format_fixed(*t.temperature_c, 1) + " " + std::string(unit) + " (" + who + ")";
}

json run_detail_json(const StoredRun& r) {
  const LobeAnalysis& a = r.analysis;
  // Runs stored before schema version 2 computed no inspection figures, harmonics included.
  const bool has_inspection = r.summary.phase_error_deg.has_value();
  json j = run_summary_json(r.summary);
  j["finished_utc"] = r.finished_utc;
  j["gauge"] = r.gauge;
  j["polls"] = r.polls;
  j["reconnects"] = r.reconnects;
  j["discarded_revolutions"] = r.discarded_revolutions;
  j["zero_offset_mm"] = a.zero_offset_mm;
  j["max_abs_error_at_cam_deg"] = signed_degree(argmax_abs(a.error_um));
  j["correction_max_um"] = std::abs(r.correction_um[argmax_abs(r.correction_um)]);
  j["correction_in_force_run"] = opt_json(r.correction_in_force_run);
  j["ground_with_version"] = opt_json(r.ground_with_version);
  j["ground_with_source"] = text_or_null(r.ground_with_source);
  j["inspection"] = r.inspection;
  j["harmonics_fed_back"] = opt_json(r.harmonics_fed_back);
  j["harmonic_threshold_um"] = opt_json(r.harmonic_threshold_um);
  j["harmonic_amplitude_um"] =
      has_inspection ? json(std::vector<double>(a.harmonic_amplitude_um.begin(), a.harmonic_amplitude_um.end()))
                     : json(nullptr);
  j["settings"] = text_or_null(r.settings);
  const RunPartTemperature temperature = run_part_temperature(r);
  j["part_temperature_c"] = opt_json(temperature.temperature_c);
  j["part_temperature_source"] = text_or_null(temperature.source);
  if (r.geometry) {
    j["frame"] = {{"rotation_sense", r.geometry->rotation_sense},
                  {"c_offset_deg", r.geometry->c_offset_deg},
                  {"probe_offset_deg", r.geometry->probe_offset_deg}};
  } else {
    j["frame"] = nullptr;
  }
  json pushes = json::array();
  for (const NcPush& p : r.pushes) pushes.push_back(nc_push_json(p));
  j["nc_pushes"] = pushes;
  j["lift_error_reference"] = lift_error_reference_name(r.lift_error_reference);
  j["max_abs_residual_um"] = a.max_abs_residual_um;
  j["rms_residual_um"] = a.rms_residual_um;
  j["peak_to_valley_residual_um"] = a.peak_to_valley_residual_um;
  j["dial_runout_um"] = a.dial_runout_um;
  j["roundness_um"] = a.roundness_um;
  const RunPart part = run_part(r);
  j["part_kind"] = part.pin() ? "pin" : "lobe";
  if (part.pin()) j["pin_mode"] = part.pin_mode ? json(pin_mode_name(*part.pin_mode)) : json(nullptr);
  // The curve the verdicts of the error characteristics judge, and its figures: what the run
  // page's plot draws its band around (judged_error).
  const JudgedError judged = judged_error(r);
  j["judged_error"] = {{"name", judged.name},
                       {"reference", judged.reference},
                       {"max_abs_um", judged.max_abs_um},
                       {"max_abs_at_deg", judged.max_abs_at_deg},
                       {"rms_um", judged.rms_um},
                       {"peak_to_valley_um", judged.peak_to_valley_um}};
  j["characteristics"] = characteristics_json(r.characteristics, part.kind);
  for (json& c : j["characteristics"]) {
    c["judges"] = judges_error_curve(c["key"].get<std::string>(), part.kind) ? json(judged.reference) : json(nullptr);
  }
  return j;
}

json characteristic_json(const Characteristic& c, PartKind kind) {
  return {{"key", c.key},
          {"title", characteristic_title(c.key, kind)},
          {"unit", c.unit},
          {"value", c.value},
          {"min", c.min},
          {"max", c.max},
          {"lower_limit", opt_json(c.limits.lower)},
          {"upper_limit", opt_json(c.limits.upper)},
          {"verdict", verdict_name(c.verdict)},
          {"from_deg", opt_json(c.from_deg)},
          {"to_deg", opt_json(c.to_deg)}};
}

json characteristics_json(const std::vector<Characteristic>& characteristics, PartKind kind) {
  json out = json::array();
  for (const Characteristic& c : characteristics) out.push_back(characteristic_json(c, kind));
  return out;
}

namespace {

// The table's facts, as pushes and pending tables show them alike.
void add_table_facts(json& j, const TableFacts& t) {
  j["interpolation"] = t.interpolation;
  j["block_count"] = opt_json(t.block_count);
  j["command_error_um"] = opt_json(t.command_error_um);
  j["point_count"] = opt_json(t.point_count);
  j["correction_max_um"] = opt_json(t.correction_max_um);
}

}  // namespace

json nc_push_json(const NcPush& p) {
  json j{{"table_version", p.table_version},
         {"uuid", text_or_null(p.uuid)},
         {"pushed_utc", p.pushed_utc},
         {"run_id", p.run_id != 0 ? json(p.run_id) : json(nullptr)},  // null: written from the drawing
         {"reason", p.reason},
         {"nc_file", p.nc_file},
         {"program_hash", text_or_null(p.program_hash)}};
  add_table_facts(j, p.table);
  return j;
}

json pending_table_json(const PendingTable& t) {
  json j{{"id", t.id},
         {"run_id", t.run_id},
         {"gear_run_id", t.gear_run_id != 0 ? json(t.gear_run_id) : json(nullptr)},
         {"created_utc", t.created_utc},
         {"nc_file", t.nc_file},
         {"verdict", pending_verdict_name(t.verdict)},
         {"status", pending_status_name(t.status)},
         {"reason", t.reason},
         {"decided_by", t.decided_by},
         {"decided_utc", t.decided_utc},
         {"note", t.note},
         {"push_id", opt_json(t.push_id)},
         {"superseded_by", opt_json(t.superseded_by)}};
  add_table_facts(j, t.table);
  return j;
}

json gear_run_json(const StoredGearRun& g, bool with_traces) {
  const GearRunRecord& r = g.record;
  json j{{"id", g.id},
         {"started_utc", r.started_utc},
         {"machine", r.machine},
         {"part", r.part},
         {"source", r.source},
         {"serial", text_or_null(r.serial)},
         {"operator", text_or_null(r.operator_name)},
         {"note", r.note},
         {"nc_file", r.nc_file},
         {"ground_with_version", r.ground_with_version ? json(*r.ground_with_version) : nullptr},
         {"required_class", r.required_class ? json(*r.required_class) : nullptr},
         {"total_tolerance_um", r.total_tolerance_um ? json(*r.total_tolerance_um) : nullptr},
         {"verdict", verdict_name(r.verdict)},
         {"tolerance_class", r.tolerance_class},
         {"total_max_um", r.total_max_um},
         {"total_mean_um", r.total_mean_um},
         {"form_mean_um", r.form_mean_um},
         {"slope_mean_abs_um", r.slope_mean_abs_um},
         {"pushed_version", g.pushed_version ? json(*g.pushed_version) : nullptr},
         {"mesh_residual_rms_um", g.mesh_residual_rms_um ? json(*g.mesh_residual_rms_um) : nullptr},
         {"profile_tolerance_um", r.profile_tolerance_um ? json(*r.profile_tolerance_um) : nullptr}};
  if (with_traces) {
    json traces = json::array();
    for (const GearTraceRecord& t : r.traces) {
      traces.push_back({{"gap", t.gap},
                        {"flank", t.flank},
                        {"total_um", t.total_um},
                        {"form_um", t.form_um},
                        {"slope_um", t.slope_um},
                        {"tolerance_class", t.tolerance_class},
                        {"from_mm", t.from_mm},
                        {"to_mm", t.to_mm},
                        {"z_mm", t.z_mm},
                        {"deviation_um", t.deviation_um}});
    }
    j["traces"] = std::move(traces);
    // The profiles at the face's middle: none for a gear traced along its leads only.
    json profiles = json::array();
    for (const GearProfileRecord& p : r.profiles) {
      profiles.push_back({{"gap", p.gap},
                          {"flank", p.flank},
                          {"total_um", p.total_um},
                          {"form_um", p.form_um},
                          {"slope_um", p.slope_um},
                          {"tolerance_class", p.tolerance_class},
                          {"from_roll_mm", p.from_roll_mm},
                          {"to_roll_mm", p.to_roll_mm},
                          {"roll_mm", p.roll_mm},
                          {"deviation_um", p.deviation_um}});
    }
    j["profiles"] = std::move(profiles);
    if (r.profiles.empty()) {
      j["profile"] = nullptr;
    } else {
      const GearProfileFigures f = gear_profile_figures(r);
      j["profile"] = {{"tolerance_class", f.tolerance_class},
                      {"total_max_um", f.total_max_um},
                      {"total_mean_um", f.total_mean_um},
                      {"form_mean_um", f.form_mean_um},
                      {"slope_mean_abs_um", f.slope_mean_abs_um}};
    }
  }
  return j;
}

json event_json(const StoredEvent& e) {
  return {{"id", e.id},
          {"uuid", text_or_null(e.event.uuid)},
          {"at_utc", e.event.at_utc},
          {"kind", event_kind_name(e.event.kind)},
          {"code", e.event.code},
          {"machine", e.event.machine},
          {"part", e.event.part},
          {"lobe", e.event.lobe > 0 ? json(e.event.lobe) : json(nullptr)},
          {"run_id", opt_json(e.event.run_id)},
          {"message", e.event.message}};
}

namespace {

// `text` in quotes, its quotes doubled.
std::string csv_field_quoted(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"') out += '"';
    out += c;
  }
  out += '"';
  return out;
}

// One CSV field as RFC 4180 wants it: quoted when it holds a comma, a quote, CR or LF, with
// its quotes doubled; as it is otherwise. A text a spreadsheet would take for a formula (it
// begins with =, +, -, @, a tab or CR: a note "=HYPERLINK(...)") gets a leading apostrophe and
// quotes, so it is shown as the text it is, never run (OWASP, "CSV injection").
std::string csv_field(const std::string& text) {
  const bool formula = !text.empty() && std::string_view("=+-@\t\r").find(text.front()) != std::string_view::npos;
  if (formula) return csv_field_quoted("'" + text);
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  return csv_field_quoted(text);
}

}  // namespace

std::string run_csv(const StoredRun& r, bool comments) {
  const RunSummary& s = r.summary;
  // Spreadsheets and CSV readers expect CRLF (RFC 4180); the comment lines end the same way.
  constexpr const char* kEol = "\r\n";
  std::ostringstream o;
  // Integers through a stream would take the global locale's digit grouping ("1.234").
  o.imbue(std::locale::classic());
  const bool cam_frame_raw = r.geometry.has_value();
  const bool pruned = !s.raw_pruned_utc.empty();
  const JudgedError judged = judged_error(r);
  if (comments) {
    o << "# gaugeloop run " << s.id << ": " << s.part << " lobe " << s.lobe << " on " << s.machine << ", started "
      << s.started_utc << ", status " << s.status << kEol;
    o << "# One row per cam degree (cam frame: 0 at the nose); row k is cam angle k, or k - 360 above 180 (the "
         "opening side, negative on the charts), as the lift tables are indexed."
      << kEol;
    o << "# design_lift_mm, mean_lift_mm, spread_um, error_um, correction_um: cam frame. mean is zeroed on the base "
         "circle (gauge reading minus zero_offset_mm "
      << format_fixed(r.analysis.zero_offset_mm, 6) << "); error = mean - design; spread = standard deviation across "
      << "revolutions." << kEol;
    o << "# judged_error_um: the " << judged.name << ", the curve the run's verdicts judge." << kEol;
    if (pruned) {
      o << "# Raw revolutions were pruned on " << s.raw_pruned_utc << ": the revN columns are empty." << kEol;
    } else if (cam_frame_raw) {
      const Part& g = *r.geometry;
      o << "# revN_lift_mm: raw gauge reading of revolution N (mm, not zeroed), mapped to the CAM frame with the "
           "run's frame: C = "
        << (g.rotation_sense > 0 ? "+" : "-") << "beta + " << format_fixed(g.c_offset_deg + g.probe_offset_deg, 3)
        << " deg (c0 + probe offset); linearly interpolated between machine degrees when that is not whole." << kEol;
    } else {
      o << "# revN_at_machine_deg_lift_mm: raw gauge reading of revolution N (mm, not zeroed) in the MACHINE frame: "
           "row k holds the reading at C = k deg, NOT at cam degree k. This run did not record its frame mapping."
        << kEol;
    }
  }
  // The columns come from what the run recorded, not from what is still stored: a pruned run
  // keeps its revolution columns, empty, so a sheet built on one export reads the next.
  const std::size_t rev_columns = std::max(r.revolutions.size(), static_cast<std::size_t>(std::max(s.revolutions, 0)));
  o << "cam_deg,design_lift_mm";
  for (std::size_t i = 0; i < rev_columns; ++i) {
    o << ",rev" << (i + 1) << (cam_frame_raw ? "_lift_mm" : "_at_machine_deg_lift_mm");
  }
  o << ",mean_lift_mm,spread_um,error_um,judged_error_um,correction_um,run_id,machine,part,lobe,started_utc,serial,"
       "operator,note"
    << kEol;
  // The run's identity on every row: exports of several runs can be pasted into one sheet.
  std::ostringstream id;
  id.imbue(std::locale::classic());
  id << s.id << "," << csv_field(s.machine) << "," << csv_field(s.part) << "," << s.lobe << ","
     << csv_field(s.started_utc) << "," << csv_field(s.serial) << "," << csv_field(s.operator_name) << ","
     << csv_field(s.note);
  const std::string identity = id.str();
  for (int d = 0; d < kDegreesPerRevolution; ++d) {
    const auto k = static_cast<std::size_t>(d);
    o << d << "," << format_fixed(r.analysis.design_lift_mm[k], 7);
    for (std::size_t i = 0; i < rev_columns; ++i) {
      o << ",";
      if (i >= r.revolutions.size()) continue;  // pruned: an empty field
      const RevolutionSamples& rev = r.revolutions[i];
      o << format_fixed(cam_frame_raw ? raw_at_cam_deg(rev, *r.geometry, d) : rev.lift_mm[k], 7);
    }
    o << "," << format_fixed(r.analysis.mean_lift_mm[k], 7) << "," << format_fixed(r.analysis.spread_um[k], 4) << ","
      << format_fixed(r.analysis.error_um[k], 4) << "," << format_fixed(judged.error_um[k], 4) << ","
      << format_fixed(r.correction_um[k], 4) << "," << identity << kEol;
  }
  return o.str();
}

Result<std::string> time_bound(const std::string& text, bool until, std::string_view name) {
  if (text.empty()) return std::string();
  std::tm tm{};
  int consumed = 0;
  int precision = 0;  // 0 day, 1 minute, 2 second
  std::string t = text;
  if (t.size() > 10 && (t[10] == ' ' || t[10] == 't')) t[10] = 'T';
  if (!t.empty() && (t.back() == 'Z' || t.back() == 'z')) t.pop_back();
  if (std::sscanf(t.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour, &tm.tm_min,
                  &tm.tm_sec, &consumed) == 6 &&
      static_cast<std::size_t>(consumed) == t.size()) {
    precision = 2;
  } else if (tm = std::tm{}, consumed = 0; std::sscanf(t.c_str(), "%4d-%2d-%2dT%2d:%2d%n", &tm.tm_year, &tm.tm_mon,
                                                       &tm.tm_mday, &tm.tm_hour, &tm.tm_min, &consumed) == 5 &&
                                           static_cast<std::size_t>(consumed) == t.size()) {
    precision = 1;
  } else if (tm = std::tm{}, consumed = 0;
             std::sscanf(t.c_str(), "%4d-%2d-%2d%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &consumed) == 3 &&
             static_cast<std::size_t>(consumed) == t.size()) {
    precision = 0;
  } else {
    return make_error(ErrorCode::kInvalidInput, std::string(name) + " '" + text +
                                                    "' is not a UTC date or time; write 2026-11-22 or "
                                                    "2026-11-22T08:30 or 2026-11-22T08:30:00Z");
  }
  const std::tm given = tm;
  tm.tm_year -= 1900;
  tm.tm_mon -= 1;
  const std::time_t at = timegm(&tm);
  // timegm normalises 2026-02-30 to March: a date that changed was not a date.
  std::tm back{};
  gmtime_r(&at, &back);
  if (back.tm_year + 1900 != given.tm_year || back.tm_mon + 1 != given.tm_mon || back.tm_mday != given.tm_mday ||
      back.tm_hour != given.tm_hour || back.tm_min != given.tm_min || back.tm_sec != given.tm_sec) {
    return make_error(ErrorCode::kInvalidInput, std::string(name) + " '" + text + "' is not a real date or time");
  }
  const std::time_t unit = precision == 0 ? 86400 : precision == 1 ? 60 : 1;
  return format_utc(until ? at + unit : at);
}

Status set_time_bounds(const std::string& since, const std::string& until, std::string& since_utc,
                       std::string& until_utc) {
  Result<std::string> from = time_bound(since, false, "--since");
  if (!from) return from.error();
  Result<std::string> to = time_bound(until, true, "--until");
  if (!to) return to.error();
  since_utc = *from;
  until_utc = *to;
  return {};
}

}  // namespace gaugeloop
