// The gear's loop on the virtual gear grinder.
#include "cli/gear_loop.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "acquisition/gear_probe.h"
#include "job/gear_run.h"
#include "simulator/gear_probe_simulator.h"

namespace gaugeloop {

namespace {

GearLeadSummary summary_of(const GearRunRecord& r) {
  GearLeadSummary s;
  s.total_mean_um = r.total_mean_um;
  s.total_max_um = r.total_max_um;
  s.form_mean_um = r.form_mean_um;
  s.slope_mean_abs_um = r.slope_mean_abs_um;
  s.tolerance_class = r.tolerance_class;
  s.verdict = r.verdict;
  return s;
}

}  // namespace

Result<GearLeadSummary> summarize_lead(const std::vector<LeadTrace>& traces, const GearPart& part,
                                       std::optional<int> required_class) {
  GearRunOrigin origin;
  origin.required_class = required_class;
  Result<GearRunRecord> r = judge_gear(part, traces, origin);
  if (!r) return r.error();
  return summary_of(*r);
}

Result<std::vector<GearLoopIteration>> run_gear_loop(const GearLoopSettings& settings,
                                                     const std::function<void(const GearLoopIteration&)>& on_gear) {
  const GearPart& part = settings.part.part;
  if (Status v = validate(part); !v) return v.error();
  const GearCoupling coupling = gear_coupling(part);
  // The first stroke: SIM1 at 0 at every spline point, no compensation yet.
  StrokeAxisErrors none;
  none.z_mm = {part.stroke.z_start_mm, part.stroke.z_end_mm};
  none.y_error_um = none.z_error_um = none.b_error_deg = none.c_error_deg = {0.0, 0.0};
  Result<std::vector<StrokeSimPoint>> first = stroke_sim_points(part, coupling, none);
  if (!first) return first.error();
  Result<GearStrokeReport> pushed =
      push_gear_stroke(part, std::move(*first), "no compensation (the first gear)", settings.stroke);
  if (!pushed) return pushed.error();
  int version = pushed->version;

  // The machine's flank probe, served over Modbus TCP on loopback as a real grinder serves it,
  // and gaugeloop's link to it.
  Result<std::unique_ptr<GearProbeSimulator>> probe_sim = GearProbeSimulator::start({});
  if (!probe_sim) return probe_sim.error();
  GearProbeSettings ps;
  ps.link.port = (*probe_sim)->port();
  ps.link.response_timeout = std::chrono::milliseconds(1000);
  GearProbe probe(ps);
  if (Status c = probe.connect(); !c) return c.error();
  const std::vector<double> heights = lead_heights_mm(part.gear, settings.lead_step_mm);

  std::vector<GearLoopIteration> out;
  GearMachineErrors quiet = settings.machine;
  quiet.checker_noise_um = 0.0;
  for (int it = 0; it <= settings.iterations; ++it) {
    GearLoopIteration g;
    g.iteration = it;
    g.ground_from_version = version;
    const std::string stroke_file = settings.stroke.nc_file.string();
    Result<GroundGear> gear = grind_gear(part, settings.machine, stroke_file);
    if (!gear) return gear.error();
    (*probe_sim)->load_gear(*gear, static_cast<std::uint64_t>(it));
    Result<std::vector<LeadTrace>> probed = probe.measure_lead(settings.gaps, heights);
    if (!probed) return probed.error();
    const std::vector<LeadTrace>& traces = *probed;
    // The gear as the checker measured it, judged and kept before anything is pushed from it.
    GearRunOrigin origin;
    origin.part_name = settings.part.name;
    origin.required_class = settings.part.tolerance_class;
    origin.machine = settings.machine_name;
    origin.source = "flank probe " + probe.address();
    origin.serial = "GEAR-" + std::to_string(it);
    origin.nc_file = settings.stroke.nc_file;
    origin.ground_with_version = version;
    // The profile at the face's middle, as the checker traces it on the same gaps: kept with the
    // leads, and judged with them.
    const std::vector<ProfileTrace> profiles =
        measure_profile(*gear, settings.gaps, 0.25, static_cast<std::uint64_t>(it));
    Result<GearRunRecord> measured = judge_gear(part, traces, origin, profiles);
    if (!measured) return measured.error();
    g.measured = summary_of(*measured);
    if (settings.stroke.store != nullptr) {
      Result<std::int64_t> id = settings.stroke.store->insert_gear_run(*measured);
      if (!id) return id.error();
      g.gear_run_id = *id;
    }
    Result<GroundGear> as_ground = grind_gear(part, quiet, stroke_file);
    if (!as_ground) return as_ground.error();
    Result<GearLeadSummary> ground =
        summarize_lead(measure_lead(*as_ground, settings.gaps, settings.lead_step_mm, static_cast<std::uint64_t>(it)),
                       part, settings.part.tolerance_class);
    if (!ground) return ground.error();
    g.ground = *ground;
    g.profile = gear_profile_figures(*measured);
    if (it < settings.iterations) {
      std::string gaps;
      for (int gap : settings.gaps) gaps += (gaps.empty() ? "" : ", ") + std::to_string(gap);
      const std::string run_name = g.gear_run_id > 0 ? "gear run " + std::to_string(g.gear_run_id) + ", " : "";
      Result<GearCorrection> c =
          correct_gear_stroke(part, traces,
                              run_name + "lead of gaps " + gaps + " of gear " + std::to_string(it) +
                                  " (stroke version " + std::to_string(version) + "): mesh error identified",
                              settings.stroke);
      if (!c) return c.error();
      if (g.gear_run_id > 0) {
        Status recorded = settings.stroke.store->record_gear_correction(
            g.gear_run_id, c->identification.residual_rms_um, c->pushed.version);
        if (!recorded) return recorded.error();
      }
      version = c->pushed.version;
      g.identified = std::move(c->identification);
      g.pushed_version = version;
      g.sim_max_abs_deg = c->pushed.sim_max_abs_deg;
    }
    if (on_gear) on_gear(g);
    out.push_back(std::move(g));
  }
  return out;
}

}  // namespace gaugeloop
