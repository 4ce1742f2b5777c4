// The gear's loop on the virtual gear grinder.
#include "cli/gear_loop.h"

#include <algorithm>
#include <cmath>

namespace gaugeloop {

Result<GearLeadSummary> summarize_lead(const std::vector<LeadTrace>& traces, const GearGeometry& gear,
                                       double pitch_diameter_mm) {
  GearLeadSummary s;
  if (traces.empty()) return s;
  for (const LeadTrace& t : traces) {
    Result<LeadFigures> f = lead_figures(t, gear);
    if (!f) return f.error();
    s.total_mean_um += f->total_um;
    s.total_max_um = std::max(s.total_max_um, f->total_um);
    s.form_mean_um += f->form_um;
    s.slope_mean_abs_um += std::abs(f->slope_um);
  }
  const double n = static_cast<double>(traces.size());
  s.total_mean_um /= n;
  s.form_mean_um /= n;
  s.slope_mean_abs_um /= n;
  s.tolerance_class = helix_tolerance_class(s.total_max_um, pitch_diameter_mm, gear.face_width_mm);
  return s;
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
    const std::vector<LeadTrace> traces =
        measure_lead(*gear, settings.gaps, settings.lead_step_mm, static_cast<std::uint64_t>(it));
    Result<GearLeadSummary> measured = summarize_lead(traces, part.gear, coupling.gear_pitch_diameter_mm);
    if (!measured) return measured.error();
    g.measured = *measured;
    Result<GroundGear> as_ground = grind_gear(part, quiet, stroke_file);
    if (!as_ground) return as_ground.error();
    Result<GearLeadSummary> ground =
        summarize_lead(measure_lead(*as_ground, settings.gaps, settings.lead_step_mm, static_cast<std::uint64_t>(it)),
                       part.gear, coupling.gear_pitch_diameter_mm);
    if (!ground) return ground.error();
    g.ground = *ground;
    if (it < settings.iterations) {
      std::string gaps;
      for (int gap : settings.gaps) gaps += (gaps.empty() ? "" : ", ") + std::to_string(gap);
      Result<GearCorrection> c =
          correct_gear_stroke(part, traces,
                              "lead of gaps " + gaps + " of gear " + std::to_string(it) + " (stroke version " +
                                  std::to_string(version) + "): mesh error identified",
                              settings.stroke);
      if (!c) return c.error();
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
