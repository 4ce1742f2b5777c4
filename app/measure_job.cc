// The measurement pipeline, wiring acquisition, compensation, storage and nc_out.
#include "app/measure_job.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <map>
#include <system_error>

#include "app/nc_push.h"
#include "app/run_json.h"
#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "nc_out/table_guards.h"
#include "nc_out/table_program.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

std::string fixed(double v, int decimals) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  return buf;
}

// The exact wheel path the tables are chosen against and checked on: 36,000 rows.
constexpr double kFinePathStepDeg = 0.01;

Error in_step(const std::string& step, Error e) {
  e.message = std::string(step) + ": " + e.message;
  return e;
}

// A table and the exact path it was chosen against.
struct BuiltTable {
  SampledPath fine;
  CurveTable table;
};

// The wheel path of `lift_mm` on the fine C grid (compute_machine_path: exact rows), the
// axis guards on it, the table the settings ask for, and the guards on the table as the NC
// will interpolate it. Refusals (a wheel that does not fit, a limit broken) are kRefused.
Result<BuiltTable> build_table(const PeriodicSpline& lift_mm, const JobSettings& s,
                               const TablePointsInForce* in_force = nullptr) {
  Result<MachinePath> path = compute_machine_path(lift_mm, s.part, kFinePathStepDeg);
  if (!path) return in_step("wheel path", path.error());
  BuiltTable out;
  out.fine.c_step_deg = kFinePathStepDeg;
  out.fine.x_mm = std::move(path->x_mm);
  out.fine.dx_dc_mm_per_deg = std::move(path->dx_dc_mm_per_deg);
  out.fine.d2x_dc2_mm_per_deg2 = std::move(path->d2x_dc2_mm_per_deg2);
  if (Status g = check_path_guards(out.fine, s.axis_limits); !g) return in_step("wheel path", g.error());
  const AdaptiveSettings adaptive{s.table_choice.bound_um, s.table_choice.max_step_deg};
  Result<CurveTable> table = [&]() -> Result<CurveTable> {
    switch (s.table_kind) {
      case TableKind::kAuto:
        return write_default_table(out.fine, s.table_choice, {}, in_force);
      case TableKind::kLinear:
        return write_linear_table(out.fine, s.table_step_deg);
      case TableKind::kSpline:
        return write_spline_table(out.fine, s.table_step_deg);
      case TableKind::kAdaptiveLinear:
        return write_adaptive_linear_table(out.fine, adaptive);
      case TableKind::kAdaptiveSpline:
        return write_adaptive_spline_table(out.fine, adaptive);
    }
    return make_error(ErrorCode::kInternal, "unknown table kind");
  }();
  if (!table) return in_step("curve table", table.error());
  if (Status g = check_table_guards(*table, out.fine, s.axis_limits); !g) return in_step("curve table", g.error());
  out.table = std::move(*table);
  return out;
}

std::map<std::string, std::string> template_values(const JobSettings& s) {
  return {{"program_name", s.nc_program},
          {"part", s.part.name},
          {"lobe", std::to_string(s.part.lobe)},
          {"version", GAUGELOOP_VERSION},
          {"run_id", "0"},
          {"created_utc", ""},
          {"correction_max_um", "0"},
          {"table_number", std::to_string(s.table_number)}};
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
  line("nc.table", std::string(table_kind_name(s.table_kind)));
  line("nc.table_step_deg", num(s.table_step_deg));
  line("nc.command_error_bound_um", num(s.table_choice.bound_um));
  line("nc.max_segment_deg", num(s.table_choice.max_step_deg));
  line("nc.allow_spline", s.table_choice.allow_spline ? "true" : "false");
  line("nc.x_min_mm", num(s.axis_limits.x_min_mm));
  line("nc.x_max_mm", num(s.axis_limits.x_max_mm));
  line("nc.x_velocity_max_mm_per_s", num(s.axis_limits.x_velocity_max_mm_per_s));
  line("nc.x_acceleration_max_mm_per_s2", num(s.axis_limits.x_acceleration_max_mm_per_s2));
  line("nc.work_speed_rpm", num(s.axis_limits.speed_rpm));
  line("nc.require_approval", s.require_approval ? "true" : "false");
  line("nc.table_number", std::to_string(s.table_number));
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

// What the checks before the gauge produce and the job goes on with.
struct Prepared {
  PeriodicSpline design;
  DesignReading reading;
};

// Checks that need no gauge, so bad input costs no measurement: the design must make a
// table within the axis limits, and the template must render it.
Result<Prepared> prepare(const JobSettings& s) {
  if (s.table_kind == TableKind::kLinear || s.table_kind == TableKind::kSpline) {
    const double steps = 360.0 / s.table_step_deg;
    if (!(s.table_step_deg > 0.0) || std::abs(steps - std::round(steps)) > 1e-9 || steps < 36) {
      return make_error(ErrorCode::kInvalidInput,
                        "table step " + fixed(s.table_step_deg, 4) + " deg must divide 360 into at least 36 steps");
    }
  }
  if (Status l = check_axis_limits(s.axis_limits); !l) return l.error();
  Result<PeriodicSpline> design = PeriodicSpline::fit(s.design.angle_deg, s.design.lift_mm);
  if (!design) return in_step("design lift table " + s.design.source, design.error());
  Result<BuiltTable> design_table = build_table(*design, s);
  if (!design_table) return in_step("the design", design_table.error());
  Result<DesignReading> design_reading = DesignReading::of_lobe(*design, s.part);
  if (!design_reading) return in_step("flat-probe reading", design_reading.error());
  if (auto r = render_table_program(s.nc_template, s.nc_template_name, template_values(s), design_table->table, {});
      !r) {
    return r.error();
  }
  return Prepared{std::move(*design), std::move(*design_reading)};
}

}  // namespace

Status check_job_settings(const JobSettings& settings) {
  Result<Prepared> p = prepare(settings);
  if (!p) return p.error();
  return {};
}

Result<JobReport> run_measure_job(GaugeClient& gauge, const JobSettings& s) {
  Result<Prepared> prepared = prepare(s);
  if (!prepared) return prepared.error();
  const DesignReading* design_reading = &prepared->reading;
  std::error_code ec;
  std::filesystem::create_directories(s.nc_dir, ec);
  if (ec) {
    return make_error(ErrorCode::kIo, "NC output directory " + s.nc_dir.string() + ": " + ec.message());
  }
  Result<RunStore> store = RunStore::open(s.db_path);
  if (!store) return store.error();
  // Absolute, so the push history names one file whatever directory a command runs in.
  const std::filesystem::path nc_file =
      std::filesystem::absolute(s.nc_dir / (s.nc_program + ".SPF")).lexically_normal();
  // Something other than a file where the program goes (a directory, a device) would fail
  // the push after the run is stored: say so before measuring.
  if (std::filesystem::exists(nc_file, ec) && !std::filesystem::is_regular_file(nc_file, ec)) {
    return make_error(ErrorCode::kIo, "NC program " + nc_file.string() +
                                          " exists but is not a file (a directory?); gaugeloop writes the curve "
                                          "table there: move it away, then measure");
  }

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

    Result<std::optional<TablePointsInForce>> in_force_points = points_in_force(*store, nc_file, s);
    if (!in_force_points) return in_force_points.error();

    auto step = [&s](std::string code, std::string message, std::optional<std::int64_t> run_id = std::nullopt) {
      if (s.on_step) s.on_step(JobStep{std::move(code), std::move(message), run_id});
    };

    // Acquire.
    const std::string started = format_utc(std::time(nullptr));
    const auto acquire_start = std::chrono::steady_clock::now();
    Poller poller(gauge, s.poller);
    Result<MeasuredRun> measured = poller.measure();
    if (!measured) return measured.error();
    const std::string finished = format_utc(std::time(nullptr));
    step("acquired",
         std::to_string(measured->revolutions.size()) + " revolutions from " + gauge.address() + " in " +
             fixed(std::chrono::duration<double>(std::chrono::steady_clock::now() - acquire_start).count(), 1) +
             " s (" + std::to_string(measured->discarded_revolutions) + " discarded, " +
             std::to_string(measured->reconnects) + " reconnects, " + std::to_string(measured->polls) + " polls)");

    // Analyse and correct.
    Result<LobeAnalysis> analysis = analyse_lobe(*measured, *design_reading, s.part, s.analysis);
    if (!analysis) return in_step("analysis", analysis.error());
    step("analysed", "max lift error " + fixed(analysis->max_abs_error_um, 2) + " um, RMS " +
                         fixed(analysis->rms_error_um, 2) + " um, phase " + fixed(analysis->phase_error_deg, 4) +
                         " deg, runout " + fixed(analysis->base_circle_runout_um, 2) + " um, repeatability " +
                         fixed(analysis->repeatability_um, 2) + " um");
    Result<CompensationDecision> decision = decide_correction(*analysis, *design_reading, in_force, s.compensation);
    if (!decision) return in_step("compensation", decision.error());
    const DegreeTable& correction = decision->correction_um;
    CompensationVerdict verdict = decision->verdict;
    std::string verdict_reasons = decision->reasons();
    // The table is built before the run is stored, for a held correction too (a person may
    // approve it). One the geometry or the axis guards refuse (a concave flank the wheel no
    // longer fits, a limit broken) is a refusal: the run is stored, nothing is pushed.
    std::optional<BuiltTable> built;
    if (verdict != CompensationVerdict::kRefuse) {
      Result<BuiltTable> b = [&]() -> Result<BuiltTable> {
        Result<PeriodicSpline> target = corrected_lift(s.design, *design_reading, correction, s.part);
        if (!target) return in_step("corrected lift", target.error());
        return build_table(*target, s, *in_force_points ? &**in_force_points : nullptr);
      }();
      if (b) {
        built = std::move(*b);
      } else if (b.error().code == ErrorCode::kRefused) {
        verdict = CompensationVerdict::kRefuse;
        verdict_reasons = verdict_reasons.empty() ? b.error().message : verdict_reasons + "; " + b.error().message;
      } else {
        return b.error();
      }
    }
    const double correction_max_um = std::abs(decision->largest_correction_um);
    {
      std::string what = std::string(compensation_verdict_name(verdict)) + ": largest correction " +
                         fixed(decision->largest_correction_um, 2) + " um at " +
                         std::to_string(decision->largest_correction_deg) + " deg";
      if (in_force_run) what += ", built on run " + std::to_string(*in_force_run) + "'s";
      if (built) {
        what += "; table " + std::to_string(built->table.block_count()) + " blocks (" + built->table.writer +
                "), command position error " + fixed(built->table.error.max_abs_um, 3) + " um";
      }
      if (!verdict_reasons.empty()) what += "; " + verdict_reasons;
      step("compensated", what);
    }

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
    step("stored", "run " + std::to_string(*run_id) + " stored in " + store->path().string(), *run_id);

    JobReport report;
    report.run_id = *run_id;
    report.measured = std::move(*measured);
    report.analysis = *analysis;
    report.verdict = verdict;
    report.correction_max_um = correction_max_um;
    report.correction_in_force_run = in_force_run;
    report.db_path = store->path();
    if (built) {
      report.interpolation = std::string(interpolation_name(built->table.interpolation));
      report.table_writer = built->table.writer;
      report.table_blocks = built->table.block_count();
      report.command_error_um = built->table.error.max_abs_um;
    }

    auto values = template_values(s);
    values["run_id"] = std::to_string(*run_id);
    values["created_utc"] = finished;
    values["correction_max_um"] = fixed(correction_max_um, 1);
    auto render = [&](int table_version) {
      return render_table_program(s.nc_template, s.nc_template_name, values, built->table,
                                  {*run_id, static_cast<std::int64_t>(table_version)});
    };
    PushFacts facts;
    facts.run_id = *run_id;
    facts.reason = "run " + std::to_string(*run_id);
    if (built) {
      facts.interpolation = report.interpolation;
      facts.block_count = report.table_blocks;
      facts.command_error_um = report.command_error_um;
      facts.point_count = static_cast<int>(built->table.points.size());
    }
    facts.correction_max_um = correction_max_um;

    // Not pushed: keep the table for approval when there is one, and say why in the events.
    auto keep = [&](const std::string& reason, CompensationVerdict why) -> Result<JobReport> {
      report.not_pushed_reason = reason;
      if (built) {
        Result<std::string> program = render(0);
        if (!program) return program.error();
        PendingTable pending;
        pending.run_id = *run_id;
        pending.nc_file = nc_file.string();
        pending.program_text = std::move(*program);
        pending.verdict = why == CompensationVerdict::kHold ? PendingVerdict::kHold : PendingVerdict::kApply;
        pending.reason = reason;
        pending.interpolation = facts.interpolation;
        pending.block_count = facts.block_count;
        pending.command_error_um = facts.command_error_um;
        pending.correction_max_um = facts.correction_max_um;
        pending.point_count = facts.point_count;
        Result<std::int64_t> id = store->add_pending(pending);
        if (!id) return id.error();
        report.pending_id = *id;
      }
      EventRecord event;
      event.kind = EventKind::kRefusal;
      event.code = "table not pushed";
      if (why != CompensationVerdict::kApply)
        event.code = "compensation " + std::string(compensation_verdict_name(why));
      event.machine = s.machine;
      event.part = s.part.name;
      event.lobe = s.part.lobe;
      event.run_id = *run_id;
      event.message = "run " + std::to_string(*run_id) + " is stored, its table was not pushed: " + reason;
      if (report.pending_id) {
        event.message += " (waiting as pending table " + std::to_string(*report.pending_id) + ")";
      }
      if (Result<std::int64_t> e = store->record_event(event); !e) return e.error();
      return report;
    };

    if (verdict != CompensationVerdict::kApply) return keep(verdict_reasons, verdict);
    if (s.require_approval) return keep("approval required", CompensationVerdict::kApply);
    Result<int> version = push_program(*store, nc_file, facts, render);
    if (!version) {
      // A table edited by hand on the control is not overwritten: a person decides.
      if (version.error().code == ErrorCode::kRefused)
        return keep(version.error().message, CompensationVerdict::kApply);
      return version.error();
    }
    report.table_version = *version;
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
  }
  return "?";
}

}  // namespace gaugeloop
