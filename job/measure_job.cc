// The measurement pipeline, wiring acquisition, compensation, storage and nc_out.
#include "job/measure_job.h"

#include <stdlib.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <map>
#include <nlohmann/json.hpp>
#include <system_error>

#include "compensation/flat_probe.h"
#include "compensation/judgement.h"
#include "compensation/periodic_spline.h"
#include "compensation/pin_analysis.h"
#include "compensation/pin_kinematics.h"
#include "compensation/pin_path.h"
#include "compensation/table_evidence.h"
#include "compensation/wheel_path.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "core/text_file.h"
#include "core/verdict_text.h"
#include "job/layer_files.h"
#include "job/measure_checks.h"
#include "job/nc_push.h"
#include "job/pin_files.h"
#include "job/program_set.h"
#include "job/speed_files.h"
#include "job/tolerance_settings.h"
#include "nc_out/main_program.h"
#include "nc_out/table_guards.h"
#include "nc_out/table_program.h"
#include "report/run_json.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

// "harmonics 0..27 fed back (above 0.052 um, 4 sigma of the gauge noise on the mean; cap 30)".
std::string harmonics_text(const CompensationSettings& s, const HarmonicChoice& h) {
  std::string out = "harmonics 0.." + std::to_string(h.harmonics) + " fed back";
  if (!s.choose_harmonics) return out + " (fixed)";
  if (!(h.noise_um > 0.0)) return out + " (the cap: no spread to tell the noise)";
  return out + " (above " + format_fixed(h.threshold_um, 3) + " um, " + format_fixed(h.threshold_um / h.noise_um, 0) +
         " sigma of the gauge noise on the mean; cap " + std::to_string(s.max_harmonic) + ")";
}

// The settings a run was made with, one "key = value" a line in a fixed order, so that
// `runs compare` can show what differs and equal settings hash alike.
std::string settings_text(const JobSettings& s) {
  std::string out;
  auto line = [&out](const std::string& key, const std::string& value) { out += key + " = " + value + "\n"; };
  auto num = [](double v) { return format_fixed(v, 6); };
  if (s.pin) {
    // A pin has no lift table, follower or cam angles: its geometry instead.
    const PinGeometry& p = *s.pin;
    line("part.kind", "pin");
    line("pin.mode", std::string(pin_mode_name(p.mode)));
    line("pin.throw_mm", num(p.throw_mm));
    line("pin.pin_radius_mm", num(p.pin_radius_mm));
    line("pin.wheel_radius_mm", num(p.wheel_radius_mm));
    line("pin.pin_angle_deg", num(p.pin_angle_deg));
    line("pin.gauge_offset_deg", num(p.gauge_offset_deg));
  } else {
    line("design.lift_table", s.design.source);
    line("part.follower", std::string(follower_kind_name(s.part.follower)));
    line("part.follower_radius_mm", num(s.part.follower_radius_mm));
    line("part.base_circle_radius_mm", num(s.part.base_circle_radius_mm));
    line("part.wheel_radius_mm", num(s.part.wheel_radius_mm));
    line("part.rotation_sense", std::to_string(s.part.rotation_sense));
    line("part.c_offset_deg", num(s.part.c_offset_deg));
    line("part.probe_offset_deg", num(s.part.probe_offset_deg));
  }
  // What the reports print of the drawing and the gauge, only where given (older settings
  // hash as before).
  if (!s.part.drawing_number.empty()) line("part.drawing_number", s.part.drawing_number);
  if (!s.part.drawing_revision.empty()) line("part.drawing_revision", s.part.drawing_revision);
  if (!s.gauge_id.empty()) line("gauge.id", s.gauge_id);
  if (!s.gauge_calibration_date.empty()) line("gauge.calibration_date", s.gauge_calibration_date);
  if (s.part_temperature) {
    line("part.temperature_c", part_temperature_c_text(s.part_temperature->temperature_c));
    line("part.temperature_source", std::string(part_temperature_source_name(s.part_temperature->source)));
  }
  line("poller.mode", std::string(sampling_mode_name(s.poller.mode)));
  line("poller.revolutions", std::to_string(s.poller.revolutions));
  line("analysis.base_circle_center_deg", num(s.analysis.base_circle_center_deg));
  line("analysis.base_circle_half_width_deg", num(s.analysis.base_circle_half_width_deg));
  line("compensation.gain", num(s.compensation.gain));
  line("compensation.harmonics",
       s.compensation.choose_harmonics ? "auto" : std::to_string(s.compensation.max_harmonic));
  line("compensation.max_harmonic", std::to_string(s.compensation.max_harmonic));
  line("compensation.max_correction_um", num(s.compensation.max_correction_um));
  line("compensation.max_change_um", num(s.compensation.max_change_um));
  line("compensation.max_repeatability_um", num(s.compensation.max_repeatability_um));
  line("compensation.max_phase_deg", num(s.compensation.max_phase_deg));
  line("compensation.builds_on_table_in_force", s.build_on_table_in_force ? "true" : "false");
  line("nc.template", s.nc_template_name);
  line("nc.table", std::string(table_kind_name(s.table_kind)));
  line("nc.table_step_deg", num(s.table_step_deg));
  line("nc.command_error_bound_um", num(s.table_choice.bound_um));
  line("nc.max_segment_deg", num(s.table_choice.max_step_deg));
  line("nc.allow_spline", s.table_choice.allow_spline ? "true" : "false");
  line("nc.int_incr_per_mm", format_fixed(s.table_format.x_increments_per_mm, 0));
  line("nc.x_min_mm", num(s.axis_limits.x_min_mm));
  line("nc.x_max_mm", num(s.axis_limits.x_max_mm));
  line("nc.x_velocity_max_mm_per_s", num(s.axis_limits.x_velocity_max_mm_per_s));
  line("nc.x_acceleration_max_mm_per_s2", num(s.axis_limits.x_acceleration_max_mm_per_s2));
  line("nc.work_speed_rpm", num(s.axis_limits.speed_rpm));
  line("nc.require_approval", s.require_approval ? "true" : "false");
  line("nc.table_numbers", std::to_string(s.table_numbers[0]) + " " + std::to_string(s.table_numbers[1]));
  line("nc.main_template", s.nc_main_template_name);
  line("nc.archive_header", s.nc_archive_header ? "true" : "false");
  if (s.pin && s.pin->mode == PinMode::kCXY) {
    line("nc.y_template", s.nc_y_template_name);
    line("nc.y_table_numbers", std::to_string(s.y_table_numbers[0]) + " " + std::to_string(s.y_table_numbers[1]));
    line("nc.y_min_mm", num(s.y_axis_limits.x_min_mm));
    line("nc.y_max_mm", num(s.y_axis_limits.x_max_mm));
    line("nc.y_velocity_max_mm_per_s", num(s.y_axis_limits.x_velocity_max_mm_per_s));
    line("nc.y_acceleration_max_mm_per_s2", num(s.y_axis_limits.x_acceleration_max_mm_per_s2));
  }
  if (s.speed) {
    // Only with a speed program, so the settings of a run at one speed hash as before.
    line("speed.base_speed_rpm", num(s.speed->base_speed_rpm));
    if (s.speed->hold == SpeedHold::kFlanks) {
      line("speed.hold", std::string(speed_hold_name(s.speed->hold)));
      line("speed.grinding_point_speed_mm_per_min", num(s.speed->grinding_point_speed_mm_per_min));
      line("speed.flank_speed_mm_per_min", num(s.speed->flank_speed_mm_per_min));
    } else {
      line("speed.lobe_speed_mm_per_min", num(s.speed->lobe_speed_mm_per_min));
      line("speed.lobe_threshold_mm", num(s.speed->lobe_threshold_mm));
    }
    line("speed.c_acceleration_max_deg_per_s2", num(s.speed->c_acceleration_max_deg_per_s2));
    line("nc.speed_template", s.nc_speed_template_name);
    line("nc.speed_error_bound_percent", num(s.speed_profile.bound_percent));
  }
  out += s.pin ? tolerances_settings_text(s.pin->tolerances) : tolerances_settings_text(s.part.tolerances);
  return out;
}

// Where the points of the table in force lie, from the program as last pushed to `nc_file`:
// the automatic choice keeps them, refined, while that costs at most 25 % more blocks than the
// fewest (write_default_table). Only for a part ground with that table (a run that builds
// on it); none when nothing was pushed, or the text was not kept (pushes before schema 3).
Result<std::optional<TablePointsInForce>> points_in_force(const RunStore& store, const std::filesystem::path& nc_file,
                                                          const JobSettings& s) {
  if (s.table_kind != TableKind::kAuto || !s.build_on_table_in_force) return std::optional<TablePointsInForce>{};
  Result<std::optional<NcPush>> last = store.last_push(nc_file.string());
  if (!last) return last.error();
  if (!*last || !(**last).program_text) return std::optional<TablePointsInForce>{};
  // It parsed when it was pushed; should a later gaugeloop read it otherwise, the table is
  // chosen afresh rather than the run refused: keeping points is a refinement, not a need.
  Result<ParsedTable> pushed = parse_table_program(*(**last).program_text, nc_file.string() + " as pushed");
  if (!pushed) return std::optional<TablePointsInForce>{};
  TablePointsInForce points;
  points.interpolation = pushed->interpolation;
  for (const CurvePoint& p : pushed->points) points.c_deg.push_back(p.c_deg);
  return std::optional<TablePointsInForce>{std::move(points)};
}

// Which table ground the part, and the correction it carries (what a new one builds on).
struct GroundWith {
  std::optional<int> version;  // of the NC file; empty: the design
  std::string source;          // "plc", "option", "assumed"; empty: not building on a table
  // The run whose correction that table carries, read once; empty: the design.
  std::optional<StoredRun> built_from;
  // The table in force: the newest push of this machine, part and lobe.
  std::optional<std::int64_t> run_in_force;
  std::optional<int> version_in_force;

  std::optional<std::int64_t> run_id() const {
    return built_from ? std::optional<std::int64_t>(built_from->summary.id) : std::nullopt;
  }
  DegreeTable correction_um() const { return built_from ? built_from->correction_um : DegreeTable{}; }
};

Result<std::optional<StoredRun>> load_if(const RunStore& store, std::optional<std::int64_t> run_id,
                                         const std::string& what) {
  if (!run_id) return std::optional<StoredRun>();
  Result<StoredRun> run = store.load_run(*run_id);
  if (!run) return in_step(what + " (run " + std::to_string(*run_id) + ")", run.error());
  return std::optional<StoredRun>(std::move(*run));
}

// Before the gauge: the table that ground the part, as told or assumed.
Result<GroundWith> resolve_ground_with(const RunStore& store, const std::filesystem::path& nc_file,
                                       const JobSettings& s) {
  GroundWith g;
  if (!s.build_on_table_in_force) return g;
  Result<std::optional<std::int64_t>> last = store.last_pushed_run(s.machine, s.part.name, s.part.lobe);
  if (!last) return last.error();
  g.run_in_force = *last;
  Result<std::optional<NcPush>> last_push = store.last_push(nc_file.string());
  if (!last_push) return last_push.error();
  if (*last_push && g.run_in_force && (**last_push).run_id == *g.run_in_force) {
    g.version_in_force = (**last_push).table_version;
  }
  // The program on the control was written from the drawing (nc new): it carries no
  // correction, and no run's table is in force after it.
  if (*last_push && (**last_push).run_id == 0) {
    g.run_in_force.reset();
    g.version_in_force = (**last_push).table_version;
  }
  std::optional<std::int64_t> run_id;
  if (!s.ground_with_version) {
    g.source = "assumed";
    g.version = g.version_in_force;
    run_id = g.run_in_force;
  } else {
    g.source = s.ground_with_source;
    if (*s.ground_with_version > 0) {
      Result<NcPush> push = store.load_push(nc_file.string(), *s.ground_with_version);
      if (!push) {
        Error e = push.error();
        e.message = "the part was ground with table version " + std::to_string(*s.ground_with_version) + " (" +
                    g.source + "), but " + e.message + "; give the version the part was ground with (0: the design)";
        return e;
      }
      g.version = *s.ground_with_version;
      if (push->run_id != 0) run_id = push->run_id;  // 0: written by nc new, no correction
    }
  }
  Result<std::optional<StoredRun>> built_from = load_if(store, run_id, "correction in force");
  if (!built_from) return built_from.error();
  g.built_from = std::move(*built_from);
  return g;
}

std::string version_text(std::optional<int> version) {
  return version ? "table version " + std::to_string(*version) : std::string("the design (no table)");
}

// After the analysis: may a correction built on `g` be pushed? Empty: yes. Otherwise why not.
// A table is corrected from a part it ground, once: a part ground with an older table (or
// measured again after its table was replaced) would repeat the change already made.
Result<std::string> why_not_built_on(const RunStore& store, const GroundWith& g, const LobeAnalysis& now,
                                     int revolutions, const JobSettings& s, std::string& evidence) {
  if (g.source.empty()) return std::string();
  if (g.source != "assumed") {
    if (g.version == g.version_in_force) return std::string();
    const std::string said_by = g.source == "plc"            ? std::string("said by the PLC")
                                : g.source == "main_program" ? std::string("the main program on the control coupled it")
                                                             : std::string("said by --ground-with");
    return "the part was ground with " + version_text(g.version) + " (" + said_by + "), but " +
           version_text(g.version_in_force) + " is in force" +
           (g.run_in_force ? " (run " + std::to_string(*g.run_in_force) + ")" : std::string()) +
           ": a correction built on the older table would repeat what the newer one changed; the run is kept "
           "for inspection. Measure a part ground with the table in force";
  }
  // Assumed: built_from is the run the table in force was built on.
  if (!g.built_from) return std::string();  // ground from the design: nothing to repeat
  const StoredRun& before = *g.built_from;
  Result<std::optional<StoredRun>> base =
      load_if(store, before.correction_in_force_run, "the correction the table in force was built on");
  if (!base) return base.error();
  DegreeTable change = before.correction_um;
  if (*base) {
    for (std::size_t d = 0; d < change.size(); ++d) change[d] -= (**base).correction_um[d];
  }
  const MeasuredError now_error{&now.error_um, &now.spread_um, revolutions};
  const MeasuredError before_error{&before.analysis.error_um, &before.analysis.spread_um,
                                   std::max(1, before.summary.revolutions)};
  const TableEvidence e = judge_table_evidence(now_error, before_error, change, s.compensation.max_harmonic);
  switch (e.verdict) {
    case TableEvidenceVerdict::kGround:
      evidence = "the part shows the table in force: " + e.describe();
      return std::string();
    case TableEvidenceVerdict::kCannotTell:
      evidence = "assumed ground with the table in force; the part cannot tell: " + e.describe();
      return std::string();
    case TableEvidenceVerdict::kNotGround:
      evidence = "the part does not show the table in force: " + e.describe();
      return "the part does not show the table in force (" + version_text(g.version) + ", built on run " +
             std::to_string(*g.run_in_force) + "): " + e.describe() +
             ". It was measured again, or ground before that table; a correction built on it would repeat the "
             "table's change. The run is kept for inspection; measure a part ground with the table in force, or "
             "say which table ground it with --ground-with";
  }
  return std::string();
}

constexpr const char* kUnstoredKind = "gaugeloop unstored run";

// The measurement of a run the database did not take, as JSON, so it is not lost: in
// `unstored-runs` beside the database (the data directory, whose room for a run was checked
// before the gauge was read), never in the control's NC share or a temporary directory that a
// service's private /tmp loses at stop. Returns the file written, or empty if it could not be.
std::filesystem::path keep_unstored_measurement(const RunRecord& r, const JobSettings& s) {
  nlohmann::json j;
  j["kind"] = kUnstoredKind;
  j["machine"] = r.machine;
  j["part"] = r.part;
  j["lobe"] = r.lobe;
  j["gauge"] = r.gauge;
  j["started_utc"] = r.started_utc;
  j["finished_utc"] = r.finished_utc;
  j["note"] = r.note;
  j["serial"] = r.serial;
  j["operator"] = r.operator_name;
  j["frame"] = "machine degrees of C, lift in mm";
  j["polls"] = r.measured.polls;
  j["reconnects"] = r.measured.reconnects;
  j["discarded_revolutions"] = r.measured.discarded_revolutions;
  nlohmann::json revs = nlohmann::json::array();
  for (const RevolutionSamples& rev : r.measured.revolutions) {
    revs.push_back({{"amplifier_revolution", rev.revolution}, {"lift_mm", rev.lift_mm}});
  }
  j["revolutions"] = std::move(revs);
  std::string name = r.started_utc + "-" + r.part + "-lobe" + std::to_string(r.lobe) + ".json";
  std::replace(name.begin(), name.end(), ':', '-');
  const std::filesystem::path db_dir =
      s.db_path.has_parent_path() ? s.db_path.parent_path() : std::filesystem::path(".");
  const std::filesystem::path dir = db_dir / "unstored-runs";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) return {};
  if (write_file_atomically(dir / name, j.dump(1) + "\n")) return dir / name;
  return {};
}

// No gauge: a kept measurement is stored without reading one (store_unstored_run).
class NoGauge final : public GaugeClient {
 public:
  explicit NoGauge(std::string address) : address_(std::move(address)) {}
  Status connect() override { return refused(); }
  void disconnect() override {}
  bool connected() const override { return false; }
  Result<GaugeSnapshot> read_snapshot() override { return refused(); }
  Result<LatchState> read_latch_state() override { return refused(); }
  Result<std::vector<LatchedSample>> read_latched(int, int) override { return refused(); }
  std::string address() const override { return address_; }

 private:
  static Error refused() {
    return make_error(ErrorCode::kInvalidInput, "a kept measurement is stored without reading a gauge");
  }
  std::string address_;
};

}  // namespace

Result<UnstoredRun> read_unstored_run(const std::filesystem::path& file) {
  Result<std::string> text = read_regular_file(file, "kept measurement");
  if (!text) return text.error();
  const auto bad = [&file](const std::string& what) {
    return make_error(ErrorCode::kInvalidInput,
                      "kept measurement " + file.string() + ": " + what +
                          "; give a file gaugeloop wrote in <data-dir>/unstored-runs/ when the database refused a run");
  };
  const nlohmann::json j = nlohmann::json::parse(*text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) return bad("not JSON (an object)");
  if (j.value("kind", std::string()) != kUnstoredKind)
    return bad("`kind` is not \"" + std::string(kUnstoredKind) + "\"");
  UnstoredRun u;
  for (auto [key, out] : {std::pair<const char*, std::string*>{"machine", &u.machine},
                          {"part", &u.part},
                          {"gauge", &u.gauge},
                          {"started_utc", &u.started_utc},
                          {"finished_utc", &u.finished_utc},
                          {"note", &u.note},
                          {"serial", &u.serial},
                          {"operator", &u.operator_name}}) {
    const auto it = j.find(key);
    if (it == j.end() || !it->is_string()) return bad("`" + std::string(key) + "` is missing or not text");
    *out = it->get<std::string>();
  }
  if (!j.contains("lobe") || !j["lobe"].is_number_integer()) return bad("`lobe` is missing or not a whole number");
  u.lobe = j["lobe"].get<int>();
  for (auto [key, out] : {std::pair<const char*, std::int64_t*>{"polls", &u.measured.polls},
                          {"reconnects", &u.measured.reconnects},
                          {"discarded_revolutions", &u.measured.discarded_revolutions}}) {
    if (j.contains(key) && j[key].is_number_integer()) *out = j[key].get<std::int64_t>();
  }
  if (!j.contains("revolutions") || !j["revolutions"].is_array() || j["revolutions"].empty()) {
    return bad("`revolutions` is missing or empty");
  }
  for (std::size_t i = 0; i < j["revolutions"].size(); ++i) {
    const nlohmann::json& r = j["revolutions"][i];
    const std::string where = "revolution " + std::to_string(i + 1);
    if (!r.is_object() || !r.contains("amplifier_revolution") || !r["amplifier_revolution"].is_number_integer() ||
        !r.contains("lift_mm") || !r["lift_mm"].is_array() || r["lift_mm"].size() != kDegrees) {
      return bad(where + " is not {amplifier_revolution, lift_mm: 360 readings}");
    }
    RevolutionSamples rev;
    rev.revolution = r["amplifier_revolution"].get<std::int64_t>();
    for (std::size_t d = 0; d < kDegrees; ++d) {
      const nlohmann::json& v = r["lift_mm"][d];
      if (!v.is_number() || !std::isfinite(v.get<double>())) {
        return bad(where + ", machine degree " + std::to_string(d) + ": not a finite number");
      }
      rev.lift_mm[d] = v.get<double>();
    }
    u.measured.revolutions.push_back(rev);
  }
  return u;
}

Result<JobReport> store_unstored_run(const UnstoredRun& kept, JobSettings settings) {
  const auto other = [&kept](const std::string& what, const std::string& theirs, const std::string& ours) {
    return make_error(ErrorCode::kInvalidInput, "the kept measurement of " + kept.started_utc + " is of " + what + " " +
                                                    theirs + ", not " + ours +
                                                    "; give the part file (or config) it was measured with");
  };
  if (kept.part != settings.part.name) return other("part", kept.part, settings.part.name);
  if (kept.lobe != settings.part.lobe) {
    return other("lobe", std::to_string(kept.lobe), std::to_string(settings.part.lobe));
  }
  if (!kept.machine.empty() && kept.machine != settings.machine)
    return other("machine", kept.machine, settings.machine);
  settings.inspect = true;
  settings.replay = &kept;
  NoGauge gauge(kept.gauge);
  return run_measure_job(gauge, settings);
}

MainProgramSource main_program_source(const JobSettings& settings) {
  MainProgramSource m;
  m.template_text = settings.nc_main_template;
  m.template_name = settings.nc_main_template_name;
  return m;
}

namespace {

// One run through the job's steps, in order: the table in force, acquire, analyse and
// correct, store, then push the table or keep it. Each step leaves its results in members
// for the next; a step's failure ends the run with that step's error.
class JobRun {
 public:
  JobRun(GaugeClient& gauge, const JobSettings& s, const Prepared& prepared, RunStore& store,
         std::filesystem::path nc_file)
      : gauge_(gauge), s_(s), design_reading_(prepared.reading), store_(store), nc_file_(std::move(nc_file)) {}

  Result<JobReport> run() {
    if (Status t = read_table_in_force(); !t) return t.error();
    if (Status a = acquire(); !a) return a.error();
    if (Status c = analyse_and_correct(); !c) return lost(c.error());
    if (Status r = store_run(); !r) return lost(r.error());
    return push_or_keep();
  }

  // The run's id once it is stored: a failure after that still names it.
  std::optional<std::int64_t> stored_run() const {
    return report_.run_id != 0 ? std::optional<std::int64_t>(report_.run_id) : std::nullopt;
  }

 private:
  void step(std::string code, std::string message, std::optional<std::int64_t> run_id = std::nullopt) const {
    if (s_.on_step) s_.on_step(JobStep{std::move(code), std::move(message), run_id});
  }

  // A failure after the measurement: the measurement is kept in a file, and the error says where.
  Error lost(Error e) const {
    const std::filesystem::path kept = keep_unstored_measurement(record_, s_);
    e.message += kept.empty() ? "; the measurement could not be kept anywhere either"
                              : "; the measurement is kept in " + kept.string();
    return e;
  }

  // Which table ground the part, the correction it carries, and where its points lie.
  Status read_table_in_force() {
    Result<GroundWith> ground = resolve_ground_with(store_, nc_file_, s_);
    if (!ground) return ground.error();
    ground_ = std::move(*ground);
    correction_in_force_ = ground_.correction_um();
    Result<std::optional<TablePointsInForce>> points = points_in_force(store_, nc_file_, s_);
    if (!points) return points.error();
    points_in_force_ = std::move(*points);
    return read_design_table_on_control();
  }

  // A correction layer is written against the design table the control holds: read before
  // the gauge, so a missing or edited one costs no measurement.
  Status read_design_table_on_control() {
    if (s_.layer_design_table_number == 0 || s_.inspect) return {};
    const std::filesystem::path file = design_program_path(nc_file_);
    NcFiles& files = s_.nc_files ? *s_.nc_files : real_nc_files();
    Result<std::optional<std::string>> text = files.read_program(file);
    if (!text) return text.error();
    if (!*text) {
      return make_error(ErrorCode::kInvalidInput,
                        "the correction layer of part " + s_.part.name + " is added to the design table " +
                            file.string() +
                            ", which is not there: write the first program from the drawing (`gaugeloop nc new "
                            "--part ...`), then measure");
    }
    Result<DesignTable> design = read_design_table(**text, file.string(), s_.layer_design_table_number);
    if (!design) return design.error();
    design_on_control_ = std::move(*design);
    return {};
  }

  // The revolutions from the gauge, and the record as far as the measurement goes: kept
  // whatever happens next.
  Status acquire() {
    if (s_.replay != nullptr) return take_kept_measurement(*s_.replay);
    const std::string started = format_utc(std::time(nullptr));
    const auto acquire_start = std::chrono::steady_clock::now();
    Poller poller(gauge_, s_.poller);
    Result<MeasuredRun> measured = poller.measure();
    if (!measured) return measured.error();
    finished_utc_ = format_utc(std::time(nullptr));
    step("acquired",
         std::to_string(measured->revolutions.size()) + " revolutions from " + gauge_.address() + " in " +
             format_fixed(std::chrono::duration<double>(std::chrono::steady_clock::now() - acquire_start).count(), 1) +
             " s (" + std::to_string(measured->discarded_revolutions) + " discarded, " +
             std::to_string(measured->reconnects) + " reconnects, " + std::to_string(measured->polls) + " polls)");
    record_.started_utc = started;
    record_.gauge = gauge_.address();
    record_.note = s_.note;
    record_.serial = s_.serial;
    record_.operator_name = s_.operator_name;
    record_.measured = std::move(*measured);
    return describe_run();
  }

  // A measurement kept when the database refused its run: the run as it was measured.
  Status take_kept_measurement(const UnstoredRun& kept) {
    finished_utc_ = kept.finished_utc;
    step("acquired", std::to_string(kept.measured.revolutions.size()) + " revolutions kept from " + kept.started_utc +
                         " (" + kept.gauge + "), not read from the gauge");
    record_.started_utc = kept.started_utc;
    record_.gauge = kept.gauge;
    record_.note = kept.note;
    record_.serial = kept.serial;
    record_.operator_name = kept.operator_name;
    record_.measured = kept.measured;
    return describe_run();
  }

  // What the run is besides its measurement: the machine, part and settings.
  Status describe_run() {
    record_.finished_utc = finished_utc_;
    record_.machine = s_.machine;
    record_.part = s_.part.name;
    record_.lobe = s_.part.lobe;
    record_.correction_in_force_run = ground_.run_id();
    // A pin's geometry is in its settings: the stored geometry is a lobe's frame mapping.
    if (!s_.pin) record_.geometry = s_.part;
    record_.settings = settings_text(s_);
    record_.inspection = s_.inspect;
    if (!ground_.source.empty() && ground_.version) {
      record_.ground_with_version = ground_.version;
      record_.ground_with_source = ground_.source;
    }
    return {};
  }

  // The lift error, whether the part shows the table in force, the correction and its verdict,
  // and the table built from it (for a held correction too: a person may approve it).
  Status analyse_and_correct() {
    Result<CompensationDecision> decision = s_.pin ? analyse_pin_run() : analyse_lobe_run();
    if (!decision) return decision.error();
    // An inspection, or a part the table did not grind, leaves the correction in force as it is.
    const bool correction_stands = s_.inspect || !not_built_on_.empty();
    record_.correction_um = correction_stands ? correction_in_force_ : decision->correction_um;
    verdict_ = decision->verdict;
    verdict_reasons_ = decision->reasons();
    correction_max_um_ = std::abs(decision->largest_correction_um);
    harmonics_ = decision->harmonics;
    if (!s_.inspect) {
      record_.harmonics_fed_back = harmonics_.harmonics;
      if (s_.compensation.choose_harmonics && harmonics_.noise_um > 0.0) {
        record_.harmonic_threshold_um = harmonics_.threshold_um;
      }
    }
    if (verdict_ != CompensationVerdict::kRefuse && !correction_stands) {
      if (Status b = build_corrected_table(); !b) return b;
    }
    step("compensated", compensated_text(*decision));
    return {};
  }

  // A pin: the gauge read through the kinematics, the pin's figures, its tolerances, and the
  // correction along the grinding normal. Whether the part shows the table in force is a
  // lobe's check (compensation/table_evidence.h): a pin is assumed ground with it.
  Result<CompensationDecision> analyse_pin_run() {
    Result<PinAnalysis> pin = analyse_pin(record_.measured, *s_.pin);
    if (!pin) return in_step("pin analysis", pin.error());
    record_.analysis = pin->table;
    step("analysed", "pin roundness " + format_fixed(pin->roundness_um, 2) + " um, diameter error " +
                         format_fixed(pin->diameter_error_um, 2) + " um, stroke error " +
                         format_fixed(pin->stroke_error_um, 2) + " um, index error " +
                         format_fixed(pin->index_error_deg, 4) + " deg, largest radius error " +
                         format_fixed(pin->table.max_abs_error_um, 2) + " um, repeatability " +
                         format_fixed(pin->table.repeatability_um, 2) + " um");
    record_.characteristics = judge_pin(*pin, s_.pin->tolerances);
    std::vector<Verdict> verdicts;
    for (const Characteristic& c : record_.characteristics) verdicts.push_back(c.verdict);
    record_.verdict = combined_verdict(verdicts);
    step("judged", verdict_summary(record_.verdict, record_.characteristics));
    Result<CompensationDecision> decision = decide_pin_correction(*pin, correction_in_force_, s_.compensation);
    if (!decision) return in_step("compensation", decision.error());
    return decision;
  }

  // A lobe: the lift error, its tolerances, whether the part shows the table in force, and
  // the correction.
  Result<CompensationDecision> analyse_lobe_run() {
    Result<LobeAnalysis> analysis = analyse_lobe(record_.measured, design_reading_, s_.part, s_.analysis);
    if (!analysis) return in_step("analysis", analysis.error());
    record_.analysis = std::move(*analysis);
    const LobeAnalysis& a = record_.analysis;
    // The raw error at nominal timing: the verdicts that follow judge their own curve (after the
    // phase or best fit, as the part file says), which the "judged" step and the reports name.
    step("analysed", "raw lift error at nominal timing: max " + format_fixed(a.max_abs_error_um, 2) + " um, RMS " +
                         format_fixed(a.rms_error_um, 2) + " um; phase " + format_fixed(a.phase_error_deg, 4) +
                         " deg, runout " + format_fixed(a.dial_runout_um, 2) + " um (dial), eccentricity " +
                         format_fixed(a.base_circle_runout_um, 2) + " um, repeatability " +
                         format_fixed(a.repeatability_um, 2) + " um");
    judge();
    if (!s_.inspect) {
      const int revolutions = static_cast<int>(record_.measured.revolutions.size());
      Result<std::string> why = why_not_built_on(store_, ground_, a, revolutions, s_, evidence_);
      if (!why) return why.error();
      not_built_on_ = std::move(*why);
    }
    Result<CompensationDecision> decision =
        decide_correction(a, design_reading_, correction_in_force_, s_.compensation);
    if (!decision) return in_step("compensation", decision.error());
    return decision;
  }

  // The run's characteristics and verdict against the part's tolerances. A judgement that
  // fails (prepare checked the zones, so only a bug gets here) leaves the run not judged
  // rather than losing the measurement; the step says why.
  void judge() {
    record_.lift_error_reference = s_.part.tolerances.lift_error_reference;
    Result<LobeJudgement> j = judge_lobe(record_.analysis, s_.part.tolerances);
    if (!j) {
      step("judged", "not judged: " + j.error().message);
      return;
    }
    record_.characteristics = std::move(j->characteristics);
    record_.verdict = j->verdict;
    step("judged", verdict_summary(record_.verdict, record_.characteristics));
  }

  // A table the geometry or the axis guards refuse (a concave flank the wheel no longer fits,
  // a limit broken) is a refusal: the run is stored, nothing is pushed.
  Status build_corrected_table() {
    Result<BuiltTable> b = [&]() -> Result<BuiltTable> {
      const TablePointsInForce* in_force = points_in_force_ ? &*points_in_force_ : nullptr;
      if (s_.pin) return build_pin_table(record_.correction_um, s_, in_force);
      Result<PeriodicSpline> target = corrected_lift(s_.design, design_reading_, record_.correction_um, s_.part);
      if (!target) return in_step("corrected lift", target.error());
      return build_table(*target, s_, in_force, design_on_control_ ? &design_on_control_->nc : nullptr);
    }();
    if (b) {
      built_ = std::move(*b);
    } else if (b.error().code == ErrorCode::kRefused) {
      verdict_ = CompensationVerdict::kRefuse;
      verdict_reasons_ = verdict_reasons_.empty() ? b.error().message : verdict_reasons_ + "; " + b.error().message;
    } else {
      return b.error();
    }
    return {};
  }

  std::string compensated_text(const CompensationDecision& decision) const {
    std::string what = s_.inspect ? std::string("inspection: the correction in force stands")
                                  : std::string(compensation_verdict_name(verdict_)) + ": largest correction " +
                                        format_fixed(decision.largest_correction_um, 2) + " um at " +
                                        std::to_string(decision.largest_correction_deg) + " deg";
    if (const std::optional<std::int64_t> r = ground_.run_id()) what += ", built on run " + std::to_string(*r) + "'s";
    if (!s_.inspect) what += "; " + harmonics_text(s_.compensation, harmonics_);
    if (built_) {
      what += "; " + std::string(built_->y_table ? "X table " : "table ") +
              std::to_string(built_->table.block_count()) + " blocks (" + built_->table.writer +
              "), command position error " + format_fixed(built_->table.error.max_abs_um, 3) + " um";
      if (const std::optional<CurveTable>& y = built_->y_table) {
        what += "; Y table " + std::to_string(y->block_count()) + " blocks (" + y->writer +
                "), command position error " + format_fixed(y->error.max_abs_um, 3) + " um";
      }
      if (const std::optional<BuiltSpeed>& sp = built_->speed) {
        what += "; speed program " + std::to_string(sp->profile.block_count()) + " feed blocks (speed error " +
                format_fixed(sp->profile.error.max_speed_error_percent, 2) + " %), one turn " +
                format_fixed(sp->plan.cycle_time_s, 3) + " s against " +
                format_fixed(sp->plan.constant_cycle_time_s, 3) + " s at " + format_fixed(s_.speed->base_speed_rpm, 0) +
                " rpm";
      }
    }
    if (!verdict_reasons_.empty()) what += "; " + verdict_reasons_;
    if (!evidence_.empty()) what += "; " + evidence_;
    return what;
  }

  // One transaction, all or nothing; the report is filled from here on.
  Status store_run() {
    Result<std::int64_t> run_id = store_.insert_run(record_);
    if (!run_id) return run_id.error();
    (void)store_.mark_ids();  // best effort: a mark not written only means a loss of it goes unnoticed
    step("stored", "run " + std::to_string(*run_id) + " stored in " + store_.path().string(), *run_id);
    report_.run_id = *run_id;
    report_.measured = record_.measured;
    report_.analysis = record_.analysis;
    report_.characteristics = record_.characteristics;
    report_.tolerance_verdict = record_.verdict;
    report_.verdict = verdict_;
    report_.correction_max_um = correction_max_um_;
    report_.harmonics_fed_back = harmonics_.harmonics;
    report_.correction_in_force_run = ground_.run_id();
    report_.ground_with_version = ground_.version;
    report_.ground_with_source = ground_.source;
    report_.ground_with_evidence = evidence_;
    report_.inspection = s_.inspect;
    report_.db_path = store_.path();
    if (built_) {
      report_.interpolation = std::string(interpolation_name(built_->table.interpolation));
      report_.table_writer = built_->table.writer;
      report_.table_blocks = built_->table.block_count();
      report_.command_error_um = built_->table.error.max_abs_um;
      if (built_->y_table) {
        report_.y_table_blocks = built_->y_table->block_count();
        report_.y_command_error_um = built_->y_table->error.max_abs_um;
      }
      if (built_->speed) {
        report_.speed_cycle_time_s = built_->speed->plan.cycle_time_s;
        report_.constant_cycle_time_s = built_->speed->plan.constant_cycle_time_s;
        report_.speed_blocks = built_->speed->profile.block_count();
        report_.speed_error_percent = built_->speed->profile.error.max_speed_error_percent;
      }
    }
    return {};
  }

  Result<std::string> render(int table_version) const {
    return render_x_table(s_, *built_, report_.run_id, finished_utc_, correction_max_um_, table_version);
  }

  // What the push or the pending table records of the table built.
  TableFacts table_facts() const {
    TableFacts t;
    if (built_) {
      t.interpolation = report_.interpolation;
      t.block_count = report_.table_blocks;
      t.command_error_um = report_.command_error_um;
      t.point_count = static_cast<int>(built_->table.points.size());
    }
    t.correction_max_um = correction_max_um_;
    return t;
  }

  PushFacts push_facts() const {
    PushFacts facts;
    facts.run_id = report_.run_id;
    facts.reason = "run " + std::to_string(report_.run_id);
    facts.table = table_facts();
    return facts;
  }

  // The table goes to the control unless something says not: an inspection, a part the table
  // in force did not grind, a held or refused correction, approval required, a program edited
  // by hand on the control.
  Result<JobReport> push_or_keep() {
    if (s_.inspect) {
      report_.not_pushed_reason = "inspection: the correction in force and the NC program are untouched";
      return report_;
    }
    if (!not_built_on_.empty()) {
      // Nothing to approve: the correction would repeat a change already made.
      report_.verdict = CompensationVerdict::kRefuse;
      built_.reset();
      return keep(not_built_on_, CompensationVerdict::kRefuse, "part not ground with the table in force");
    }
    if (verdict_ != CompensationVerdict::kApply) {
      return keep(verdict_reasons_, verdict_, "compensation " + std::string(compensation_verdict_name(verdict_)));
    }
    if (s_.require_approval) return keep("approval required", CompensationVerdict::kApply, "table not pushed");
    PushOptions options;
    options.files = s_.nc_files.get();
    options.main = main_source(s_, finished_utc_);
    Result<PushCompletion> version =
        push_program_set(store_, nc_file_, push_facts(), *built_, s_, finished_utc_, correction_max_um_, options);
    if (!version) {
      // A table edited by hand on the control is not overwritten: a person decides.
      if (version.error().code == ErrorCode::kRefused)
        return keep(version.error().message, CompensationVerdict::kApply, "table not pushed");
      Error e = version.error();
      e.message = "run " + std::to_string(report_.run_id) + " is stored; " + e.message;
      return e;
    }
    report_.table_version = version->table_version;
    report_.nc_file = nc_file_;
    return report_;
  }

  // Not pushed: the table is kept for approval when there is one, and the reason is an event.
  Result<JobReport> keep(const std::string& reason, CompensationVerdict why, const std::string& code) {
    report_.not_pushed_reason = reason;
    if (built_ && built_->y_table) {
      // An approval pushes one table program; the Y table would not follow it, and an X table
      // without its Y is a wrong pin. So a C-X-Y pin's table is not kept for approval.
      report_.not_pushed_reason +=
          " (a C-X-Y pin's tables are not kept for approval: measure again once the cause "
          "is cleared)";
    } else if (built_) {
      Result<std::string> program = render(0);
      if (!program) return program.error();
      PendingTable pending;
      pending.run_id = report_.run_id;
      pending.nc_file = nc_file_.string();
      pending.program_text = std::move(*program);
      pending.verdict = why == CompensationVerdict::kHold ? PendingVerdict::kHold : PendingVerdict::kApply;
      pending.reason = reason;
      pending.table = table_facts();
      // The speed subprogram that goes with the table, written when it is approved; the
      // version it is written beside is known then.
      if (built_->speed) {
        Result<std::string> speed = render_speed(s_, *built_->speed, report_.run_id, finished_utc_, 0);
        if (!speed) return speed.error();
        pending.speed_program_text = std::move(*speed);
      }
      Result<std::int64_t> id = store_.add_pending(pending);
      if (!id) return id.error();
      report_.pending_id = *id;
    }
    EventRecord event;
    event.kind = EventKind::kRefusal;
    event.code = code;
    event.machine = s_.machine;
    event.part = s_.part.name;
    event.lobe = s_.part.lobe;
    event.run_id = report_.run_id;
    event.message = "run " + std::to_string(report_.run_id) + " is stored, its table was not pushed: " + reason;
    if (report_.pending_id) {
      event.message += " (waiting as pending table " + std::to_string(*report_.pending_id) + ")";
    }
    if (Result<std::int64_t> e = store_.record_event(event); !e) return e.error();
    return report_;
  }

  GaugeClient& gauge_;
  const JobSettings& s_;
  const DesignReading& design_reading_;
  RunStore& store_;
  const std::filesystem::path nc_file_;
  // read_table_in_force
  GroundWith ground_;
  DegreeTable correction_in_force_;
  std::optional<TablePointsInForce> points_in_force_;
  std::optional<DesignTable> design_on_control_;  // a correction layer's design table
  // acquire
  RunRecord record_;
  std::string finished_utc_;
  // analyse_and_correct
  std::string evidence_;
  std::string not_built_on_;
  CompensationVerdict verdict_ = CompensationVerdict::kApply;
  std::string verdict_reasons_;
  double correction_max_um_ = 0.0;
  HarmonicChoice harmonics_;
  std::optional<BuiltTable> built_;
  // store_run on
  JobReport report_;
};

// A failure once the database is open is also kept there as an event (a fault or a refusal),
// naming the run when one was stored, so `gaugeloop events` shows why a run is missing.
void record_failure(RunStore& store, const JobSettings& s, const Error& error, std::optional<std::int64_t> run_id) {
  EventRecord event;
  event.kind = event_kind_for(error.code);
  event.code = std::string(error_code_name(error.code));
  event.machine = s.machine;
  event.part = s.part.name;
  event.lobe = s.part.lobe;
  event.run_id = run_id;
  event.message = error.message;
  (void)store.record_event(event);  // best effort: the error itself is what the user is told
}

}  // namespace

Result<JobReport> run_measure_job(GaugeClient& gauge, const JobSettings& s) {
  Result<Prepared> prepared = check_names_and_prepare(s);
  if (!prepared) return prepared.error();
  // Absolute, so the push history names one file whatever directory a command runs in.
  const std::filesystem::path nc_file =
      std::filesystem::absolute(s.nc_dir / (s.nc_program + ".SPF")).lexically_normal();
  StoreFindings found;
  Result<RunStore> store = open_store_for_push(s, nc_file, &found);
  if (!store) return store.error();
  const std::optional<StaleMain>& stale = found.stale;
  // The main program coupled an older table than the history's: the part was ground with that
  // one, and a correction built on the newer table would be wrong (why_not_built_on holds it).
  JobSettings settings = s;
  if (stale && !settings.ground_with_version && settings.build_on_table_in_force) {
    settings.ground_with_version = stale->coupled_version;
    settings.ground_with_source = "main_program";
  }
  JobRun run(gauge, settings, *prepared, *store, nc_file);
  Result<JobReport> result = run.run();
  if (!result) record_failure(*store, s, result.error(), run.stored_run());
  if (result && found.lost_commits) result->history_warning = lost_commits_text(store->path(), *found.lost_commits);
  return result;
}

std::string_view table_kind_name(TableKind kind) {
  switch (kind) {
    case TableKind::kAuto:
      return "auto";
    case TableKind::kLinear:
      return "linear";
    case TableKind::kSpline:
      return "spline";
    case TableKind::kAdaptiveLinear:
      return "adaptive-linear";
    case TableKind::kAdaptiveSpline:
      return "adaptive-spline";
    case TableKind::kPoly:
      return "poly";
  }
  return "?";
}

std::vector<std::string> table_kind_names() {
  std::vector<std::string> out;
  for (TableKind k : {TableKind::kAuto, TableKind::kLinear, TableKind::kSpline, TableKind::kAdaptiveLinear,
                      TableKind::kAdaptiveSpline, TableKind::kPoly}) {
    out.emplace_back(table_kind_name(k));
  }
  return out;
}

TableKind table_kind_named(std::string_view name) {
  for (TableKind k : {TableKind::kLinear, TableKind::kSpline, TableKind::kAdaptiveLinear, TableKind::kAdaptiveSpline,
                      TableKind::kPoly}) {
    if (table_kind_name(k) == name) return k;
  }
  return TableKind::kAuto;
}

}  // namespace gaugeloop
