// The measurement pipeline, wiring acquisition, compensation, storage and nc_out.
#include "app/measure_job.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <system_error>

#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "core/atomic_file.h"
#include "nc_out/curve_table.h"
#include "nc_out/nc_template.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

std::string utc_now() {
  const std::time_t t = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// The curve table: the wheel path on the uniform C grid, computed at each C directly
// (compute_machine_path), closed by the C360 point equal to C0.
Result<std::vector<CurvePoint>> machine_curve(const PeriodicSpline& lift_mm, const Part& part, double step_deg) {
  Result<MachinePath> path = compute_machine_path(lift_mm, part, step_deg);
  if (!path) return path.error();
  std::vector<CurvePoint> points;
  points.reserve(path->c_deg.size() + 1);
  for (size_t k = 0; k < path->c_deg.size(); ++k) points.push_back({path->c_deg[k], path->x_mm[k]});
  points.push_back({360.0, points.front().x_mm});
  return points;
}

std::map<std::string, std::string> template_values(const JobSettings& s) {
  return {{"program_name", s.nc_program},
          {"part", s.part.name},
          {"lobe", std::to_string(s.part.lobe)},
          {"version", GAUGELOOP_VERSION},
          {"run_id", "0"},
          {"created_utc", ""},
          {"point_count", "0"},
          {"c_step_deg", fixed(s.table_step_deg, 3)},
          {"correction_max_um", "0"},
          {"table_number", std::to_string(s.table_number)},
          {"table_blocks", ""}};
}

// The settings a run was made with, one "key = value" a line in a fixed order, so that
// `runs compare` can show what differs and equal settings hash alike.
std::string settings_text(const JobSettings& s) {
  std::string out;
  auto line = [&out](const std::string& key, const std::string& value) { out += key + " = " + value + "\n"; };
  auto num = [](double v) { return fixed(v, 6); };
  line("design.lift_table", s.design.source);
  line("part.follower", std::string(follower_kind_name(s.part.follower)));
  line("part.follower_radius_mm", num(s.part.follower_radius_mm));
  line("part.base_circle_radius_mm", num(s.part.base_circle_radius_mm));
  line("part.wheel_radius_mm", num(s.part.wheel_radius_mm));
  line("part.rotation_sense", std::to_string(s.part.rotation_sense));
  line("part.c_offset_deg", num(s.part.c_offset_deg));
  line("part.probe_offset_deg", num(s.part.probe_offset_deg));
  line("poller.mode", std::string(sampling_mode_name(s.poller.mode)));
  line("poller.revolutions", std::to_string(s.poller.revolutions));
  line("analysis.base_circle_center_deg", num(s.analysis.base_circle_center_deg));
  line("analysis.base_circle_half_width_deg", num(s.analysis.base_circle_half_width_deg));
  line("compensation.gain", num(s.compensation.gain));
  line("compensation.max_harmonic", std::to_string(s.compensation.max_harmonic));
  line("compensation.max_correction_um", num(s.compensation.max_correction_um));
  line("compensation.max_change_um", num(s.compensation.max_change_um));
  line("compensation.max_repeatability_um", num(s.compensation.max_repeatability_um));
  line("compensation.max_phase_deg", num(s.compensation.max_phase_deg));
  line("compensation.builds_on_table_in_force", s.build_on_table_in_force ? "true" : "false");
  line("nc.template", s.nc_template_name);
  line("nc.table_step_deg", num(s.table_step_deg));
  line("nc.table_number", std::to_string(s.table_number));
  return out;
}

Error in_step(const std::string& step, Error e) {
  e.message = std::string(step) + ": " + e.message;
  return e;
}

}  // namespace

Result<JobReport> run_measure_job(GaugeClient& gauge, const JobSettings& s) {
  const double steps = 360.0 / s.table_step_deg;
  if (!(s.table_step_deg > 0.0) || std::abs(steps - std::round(steps)) > 1e-9 || steps < 36) {
    return make_error(ErrorCode::kInvalidInput,
                      "table step " + fixed(s.table_step_deg, 4) + " deg must divide 360 into at least 36 steps");
  }
  // Checks that need no gauge, so bad input costs no measurement.
  Result<PeriodicSpline> design = PeriodicSpline::fit(s.design.angle_deg, s.design.lift_mm);
  if (!design) return in_step("design lift table " + s.design.source, design.error());
  Result<std::vector<CurvePoint>> design_curve = machine_curve(*design, s.part, s.table_step_deg);
  if (!design_curve) return in_step("wheel path", design_curve.error());
  Result<DesignReading> design_reading = DesignReading::of_lobe(*design, s.part);
  if (!design_reading) return in_step("flat-probe reading", design_reading.error());
  if (auto r = render_nc_template(s.nc_template, s.nc_template_name, template_values(s)); !r) return r.error();
  std::error_code ec;
  std::filesystem::create_directories(s.nc_dir, ec);
  if (ec) {
    return make_error(ErrorCode::kIo, "NC output directory " + s.nc_dir.string() + ": " + ec.message());
  }
  Result<RunStore> store = RunStore::open(s.db_path);
  if (!store) return store.error();

  // From here on a failure is also kept in the database as an event (a fault or a refusal),
  // naming the run when one was stored, so `gaugeloop events` shows why a run is missing.
  std::optional<std::int64_t> stored_run;
  Result<JobReport> result = [&]() -> Result<JobReport> {
    DegreeTable in_force{};
    std::optional<std::int64_t> in_force_run;
    if (s.build_on_table_in_force) {
      Result<std::optional<std::int64_t>> last = store->last_pushed_run(s.machine, s.part.name, s.part.lobe);
      if (!last) return last.error();
      if (*last) {
        Result<StoredRun> previous = store->load_run(**last);
        if (!previous) return in_step("correction in force (run " + std::to_string(**last) + ")", previous.error());
        in_force = previous->correction_um;
        in_force_run = *last;
      }
    }

    // Acquire.
    const std::string started = utc_now();
    Poller poller(gauge, s.poller);
    Result<MeasuredRun> measured = poller.measure();
    if (!measured) return measured.error();
    const std::string finished = utc_now();

    // Analyse and correct.
    Result<LobeAnalysis> analysis = analyse_lobe(*measured, *design_reading, s.part, s.analysis);
    if (!analysis) return in_step("analysis", analysis.error());
    Result<CompensationDecision> decision = decide_correction(*analysis, *design_reading, in_force, s.compensation);
    if (!decision) return in_step("compensation", decision.error());
    const DegreeTable& correction = decision->correction_um;
    CompensationVerdict verdict = decision->verdict;
    std::string verdict_reasons = decision->reasons();
    // The table is computed before the run is stored. A correction the geometry refuses (a
    // concave flank the wheel no longer fits) is a refusal: the run is stored, nothing pushed.
    std::vector<CurvePoint> points;
    if (decision->apply()) {
      Result<std::vector<CurvePoint>> curve = [&]() -> Result<std::vector<CurvePoint>> {
        Result<PeriodicSpline> target = corrected_lift(s.design, correction, s.part);
        if (!target) return in_step("corrected lift", target.error());
        Result<std::vector<CurvePoint>> c = machine_curve(*target, s.part, s.table_step_deg);
        if (!c) return in_step("corrected wheel path", c.error());
        if (Status v = validate_curve_points(*c); !v) return in_step("curve table", v.error());
        return c;
      }();
      if (curve) {
        points = std::move(*curve);
      } else if (curve.error().code == ErrorCode::kRefused) {
        verdict = CompensationVerdict::kRefuse;
        verdict_reasons = curve.error().message;
      } else {
        return curve.error();
      }
    }
    const double correction_max_um = std::abs(decision->largest_correction_um);

    // Store the run: one transaction, all or nothing.
    RunRecord record;
    record.started_utc = started;
    record.finished_utc = finished;
    record.machine = s.machine;
    record.part = s.part.name;
    record.lobe = s.part.lobe;
    record.gauge = gauge.address();
    record.note = s.note;
    record.measured = *measured;
    record.analysis = *analysis;
    record.correction_um = correction;
    record.correction_in_force_run = in_force_run;
    record.geometry = s.part;
    record.settings = settings_text(s);
    Result<std::int64_t> run_id = store->insert_run(record);
    if (!run_id) return run_id.error();
    stored_run = *run_id;

    JobReport report;
    report.run_id = *run_id;
    report.analysis = *analysis;
    report.verdict = verdict;
    report.verdict_reasons = verdict_reasons;
    report.correction_max_um = correction_max_um;
    report.correction_in_force_run = in_force_run;
    report.db_path = store->path();
    if (verdict != CompensationVerdict::kApply) {
      // Stored with its proposed correction, not pushed: the table in force stays.
      EventRecord event;
      event.kind = EventKind::kRefusal;
      event.code = "compensation " + std::string(compensation_verdict_name(verdict));
      event.machine = s.machine;
      event.part = s.part.name;
      event.lobe = s.part.lobe;
      event.run_id = *run_id;
      event.message =
          "run " + std::to_string(*run_id) + " is stored, its table was not pushed: " + report.verdict_reasons;
      if (Result<std::int64_t> e = store->record_event(event); !e) return e.error();
      report.measured = std::move(*measured);
      return report;
    }

    // Render and push the table.
    auto values = template_values(s);
    values["run_id"] = std::to_string(*run_id);
    values["created_utc"] = finished;
    values["point_count"] = std::to_string(points.size());
    values["correction_max_um"] = fixed(correction_max_um, 1);
    values["table_blocks"] = render_curve_blocks(points);
    Result<std::string> program = render_nc_template(s.nc_template, s.nc_template_name, values);
    if (!program) return program.error();
    const std::filesystem::path nc_file = s.nc_dir / (s.nc_program + ".SPF");
    if (Status w = write_file_atomically(nc_file, *program); !w) {
      return in_step("run " + std::to_string(*run_id) + " is stored, but its table was not pushed", w.error());
    }
    NcPush push;
    push.nc_file = nc_file.string();
    push.point_count = static_cast<int>(points.size());
    push.correction_max_um = correction_max_um;
    if (Status m = store->record_push(*run_id, push, *program); !m) return m.error();

    report.measured = std::move(*measured);
    report.table_points = static_cast<int>(points.size());
    report.nc_file = nc_file;
    return report;
  }();

  if (!result) {
    EventRecord event;
    event.kind = event_kind_for(result.error().code);
    event.code = std::string(error_code_name(result.error().code));
    event.machine = s.machine;
    event.part = s.part.name;
    event.lobe = s.part.lobe;
    event.run_id = stored_run;
    event.message = result.error().message;
    (void)store->record_event(event);  // best effort: the error itself is what the user is told
  }
  return result;
}

}  // namespace gaugeloop
