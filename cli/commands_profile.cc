// profile: the wheel path of a part, with the wheel slide's velocity and acceleration, for
// inspection before anything runs on the machine.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "cli/cli_common.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "compensation/work_speed.h"

namespace gaugeloop {
namespace {

// Work spindle speeds beyond this are a typo, not a camshaft grinder.
constexpr double kMaxSpeedRpm = 3000.0;

struct ProfileOptions {
  std::string part_path;
  double step_deg = 1.0;
  std::string format = "csv";
  std::string frame = "cam";
  std::optional<double> speed_rpm;
  // --speed-program: C slowed on the lobe to hold this grinding-point speed, --speed-rpm (or
  // the default base speed) on the base circle.
  bool speed_program = false;
  std::optional<double> lobe_speed_mm_per_min;  // unset: the part file's [speed], else 2000
};

// One row whichever the frame: the angle (psi or C), X, and its derivatives along that angle.
struct Row {
  double angle_deg = 0.0;
  double x_mm = 0.0;
  double dx_mm_per_deg = 0.0;
  double d2x_mm_per_deg2 = 0.0;
  double v_mm_per_s = 0.0;  // only with a speed
  double a_mm_per_s2 = 0.0;
  double c_speed_rpm = 0.0;  // only with the speed program
  double grinding_point_speed_mm_per_min = 0.0;
};

// "%.10g": every digit the kinematics carry, no trailing zeros.
std::string number(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.10g", v);
  return buf;
}

Error in_part(const std::string& part_path, Error e) {
  e.message = "profile of " + part_path + ": " + e.message;
  return e;
}

int cmd_profile(const ProfileOptions& o) {
  if (o.speed_rpm && !(std::isfinite(*o.speed_rpm) && *o.speed_rpm != 0.0 && std::abs(*o.speed_rpm) <= kMaxSpeedRpm)) {
    return report_error(make_error(ErrorCode::kInvalidInput, "--speed-rpm " + number(*o.speed_rpm) +
                                                                 " is not a work spindle speed; give a speed in " +
                                                                 "rpm, non-zero, at most " + number(kMaxSpeedRpm) +
                                                                 " either way (negative: C turning down)"));
  }
  Result<LoadedPart> loaded = load_lobe_part(o.part_path, "gaugeloop profile");
  if (!loaded) return report_error(loaded.error());
  const Part& part = loaded->file.part;
  Result<PeriodicSpline> lift = PeriodicSpline::fit(loaded->design.angle_deg, loaded->design.lift_mm);
  if (!lift) {
    return report_error(in_part(o.part_path, make_error(lift.error().code, "lift table " + loaded->design.source +
                                                                               ": " + lift.error().message)));
  }

  // The angle columns: psi in the cam frame (the issue's `psi_deg`), or C in the machine frame.
  const bool machine = o.frame == "machine";
  std::vector<Row> rows;
  if (machine) {
    Result<MachinePath> path = compute_machine_path(*lift, part, o.step_deg);
    if (!path) return report_error(in_part(o.part_path, path.error()));
    rows.resize(path->c_deg.size());
    for (size_t k = 0; k < rows.size(); ++k) {
      rows[k] = {path->c_deg[k], path->x_mm[k], path->dx_dc_mm_per_deg[k], path->d2x_dc2_mm_per_deg2[k]};
    }
  } else {
    Result<WheelPath> path = compute_wheel_path(*lift, part, o.step_deg);
    if (!path) return report_error(in_part(o.part_path, path.error()));
    rows.resize(path->psi_deg.size());
    for (size_t k = 0; k < rows.size(); ++k) {
      rows[k] = {path->psi_deg[k], path->x_mm[k], path->dx_dpsi_mm_per_deg[k], path->d2x_dpsi2_mm_per_deg2[k]};
    }
  }
  // In time, C turns at 6 n deg/s; from the cam frame dX/dC = s dX/dpsi.
  const double sense = machine ? 1.0 : static_cast<double>(part.rotation_sense);
  std::optional<WorkSpeedPlan> plan;
  WorkSpeedSettings plan_settings;
  if (o.speed_program) {
    // The program is planned on the rows' own angle: its limits hold either way round the
    // turn, so the cam frame's rows get the same speeds as the machine frame's.
    MachinePath on_rows;
    for (const Row& r : rows) {
      on_rows.c_deg.push_back(r.angle_deg);
      on_rows.x_mm.push_back(r.x_mm);
      on_rows.dx_dc_mm_per_deg.push_back(r.dx_mm_per_deg);
      on_rows.d2x_dc2_mm_per_deg2.push_back(r.d2x_mm_per_deg2);
    }
    WorkSpeedSettings ws = loaded->file.speed.value_or(WorkSpeedSettings{});
    if (o.speed_rpm) ws.base_speed_rpm = std::abs(*o.speed_rpm);
    if (o.lobe_speed_mm_per_min) ws.lobe_speed_mm_per_min = *o.lobe_speed_mm_per_min;
    plan_settings = ws;
    Result<WorkSpeedPlan> planned = plan_work_speed(on_rows, part, ws);
    if (!planned) return report_error(in_part(o.part_path, planned.error()));
    plan = std::move(*planned);
    const size_t n = rows.size();
    const double h = o.step_deg;
    for (size_t k = 0; k < n; ++k) {
      Row& r = rows[k];
      const double w = spindle_deg_per_s(plan->program.speed_rpm[k]);
      const double w_prev = spindle_deg_per_s(plan->program.speed_rpm[(k + n - 1) % n]);
      const double w_next = spindle_deg_per_s(plan->program.speed_rpm[(k + 1) % n]);
      // d2X/dt2 = X'' w^2 + X' w dw/dangle; w dw/dangle = d(w^2)/dangle / 2 (the sense cancels).
      const double w_dw = (w_next * w_next - w_prev * w_prev) / (4.0 * h);
      r.c_speed_rpm = plan->program.speed_rpm[k];
      r.grinding_point_speed_mm_per_min = plan->grinding_point_speed_mm_per_min[k];
      r.v_mm_per_s = sense * r.dx_mm_per_deg * w;
      r.a_mm_per_s2 = r.d2x_mm_per_deg2 * w * w + r.dx_mm_per_deg * w_dw;
    }
  } else if (o.speed_rpm) {
    for (Row& r : rows) {
      r.v_mm_per_s = slide_velocity_mm_per_s(sense * r.dx_mm_per_deg, *o.speed_rpm);
      r.a_mm_per_s2 = slide_acceleration_mm_per_s2(r.d2x_mm_per_deg2, *o.speed_rpm);
      r.grinding_point_speed_mm_per_min =
          grinding_point_speed_mm_per_min(contact_arc_mm_per_deg(r.x_mm, r.dx_mm_per_deg, r.d2x_mm_per_deg2,
                                                                 part.base_circle_radius_mm, part.wheel_radius_mm),
                                          *o.speed_rpm);
    }
  }
  const bool timed = o.speed_rpm || o.speed_program;

  const std::string angle = machine ? "c_deg" : "psi_deg";
  const std::string d1 = machine ? "dx_dc_mm_per_deg" : "dx_dpsi_mm_per_deg";
  const std::string d2 = machine ? "d2x_dc2_mm_per_deg2" : "d2x_dpsi2_mm_per_deg2";
  if (o.format == "json") {
    nlohmann::ordered_json points = nlohmann::ordered_json::array();
    Row peak;  // largest magnitudes
    for (const Row& r : rows) {
      nlohmann::ordered_json p = {
          {angle, r.angle_deg}, {"x_mm", r.x_mm}, {d1, r.dx_mm_per_deg}, {d2, r.d2x_mm_per_deg2}};
      if (o.speed_program) p["c_speed_rpm"] = r.c_speed_rpm;
      if (timed) {
        p["v_mm_per_s"] = r.v_mm_per_s;
        p["a_mm_per_s2"] = r.a_mm_per_s2;
        p["grinding_point_speed_mm_per_min"] = r.grinding_point_speed_mm_per_min;
      }
      points.push_back(std::move(p));
      peak.x_mm = std::max(peak.x_mm, r.x_mm);
      peak.dx_mm_per_deg = std::max(peak.dx_mm_per_deg, std::abs(r.dx_mm_per_deg));
      peak.d2x_mm_per_deg2 = std::max(peak.d2x_mm_per_deg2, std::abs(r.d2x_mm_per_deg2));
      peak.v_mm_per_s = std::max(peak.v_mm_per_s, std::abs(r.v_mm_per_s));
      peak.a_mm_per_s2 = std::max(peak.a_mm_per_s2, std::abs(r.a_mm_per_s2));
      peak.grinding_point_speed_mm_per_min =
          std::max(peak.grinding_point_speed_mm_per_min, r.grinding_point_speed_mm_per_min);
    }
    nlohmann::ordered_json peaks = {{"x_mm", peak.x_mm}, {d1, peak.dx_mm_per_deg}, {d2, peak.d2x_mm_per_deg2}};
    if (timed) {
      peaks["v_mm_per_s"] = peak.v_mm_per_s;
      peaks["a_mm_per_s2"] = peak.a_mm_per_s2;
      peaks["grinding_point_speed_mm_per_min"] = peak.grinding_point_speed_mm_per_min;
    }
    nlohmann::ordered_json program(nullptr);
    if (plan) {
      program = {{"lobe_speed_mm_per_min", plan_settings.lobe_speed_mm_per_min},
                 {"base_speed_rpm", plan_settings.base_speed_rpm},
                 {"cycle_time_s", plan->cycle_time_s},
                 {"constant_cycle_time_s", plan->constant_cycle_time_s}};
    }
    const nlohmann::ordered_json out = {
        {"part", part.name},
        {"lobe", part.lobe},
        {"follower", std::string(follower_kind_name(part.follower))},
        {"wheel_radius_mm", part.wheel_radius_mm},
        {"frame", o.frame},
        {"step_deg", o.step_deg},
        {"rotation_sense", part.rotation_sense},
        {"c_offset_deg", part.c_offset_deg},
        {"speed_rpm", o.speed_rpm ? nlohmann::ordered_json(*o.speed_rpm) : nlohmann::ordered_json(nullptr)},
        {"speed_program", program},
        {"peak_abs", peaks},
        {"points", points}};
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  std::string text = angle + ",x_mm," + d1 + "," + d2 + (o.speed_program ? ",c_speed_rpm" : "") +
                     (timed ? ",v_mm_per_s,a_mm_per_s2,grinding_point_speed_mm_per_min\n" : "\n");
  for (const Row& r : rows) {
    text +=
        number(r.angle_deg) + "," + number(r.x_mm) + "," + number(r.dx_mm_per_deg) + "," + number(r.d2x_mm_per_deg2);
    if (o.speed_program) text += "," + number(r.c_speed_rpm);
    if (timed) {
      text +=
          "," + number(r.v_mm_per_s) + "," + number(r.a_mm_per_s2) + "," + number(r.grinding_point_speed_mm_per_min);
    }
    text += "\n";
  }
  std::fwrite(text.data(), 1, text.size(), stdout);
  return kExitOk;
}

}  // namespace

void add_profile_commands(CLI::App& app, CommandAction& action) {
  auto o = std::make_shared<ProfileOptions>();
  CLI::App* cmd = app.add_subcommand(
      "profile",
      "Print the wheel path of a part: infeed X (mm, 0 on the base circle) at every step of wheel angle psi\n"
      "(cam frame, 0 at the nose) or of C (--frame machine), with dX and d2X per degree and, at a work\n"
      "speed, the wheel slide's velocity (mm/s) and acceleration (mm/s^2). Refuses a lobe the wheel cannot "
      "grind.");
  cmd->add_option("--part", o->part_path, "Part file (TOML), see examples/")->required();
  cmd->add_option("--step-deg", o->step_deg, "Angle step in degrees; must divide 360")->required();
  cmd->add_option("--format", o->format, "Output format")->capture_default_str()->check(CLI::IsMember({"csv", "json"}));
  cmd->add_option("--frame", o->frame,
                  "cam: rows at wheel angle psi (psi_deg); machine: rows at C = rotation_sense * psi + c_offset_deg "
                  "(c_deg), as the curve table has them")
      ->capture_default_str()
      ->check(CLI::IsMember({"cam", "machine"}));
  cmd->add_option("--speed-rpm", o->speed_rpm,
                  "Work spindle speed, C turning up (negative: down); adds v_mm_per_s, a_mm_per_s2 and "
                  "grinding_point_speed_mm_per_min (the contact point along the lobe surface). With "
                  "--speed-program: the speed on the base circle [the part file's [speed], else 60]");
  cmd->add_flag("--speed-program", o->speed_program,
                "At a work speed program (docs/variable_speed.md): C slowed on the lobe to hold "
                "--lobe-speed-mm-per-min there, within the part file's [speed] (else 1000 deg/s^2 of C) and the "
                "slide's 300 mm/s and 20000 mm/s^2; adds c_speed_rpm, and v, a and the grinding-point speed at "
                "that speed");
  cmd->add_option("--lobe-speed-mm-per-min", o->lobe_speed_mm_per_min,
                  "Speed program: grinding-point speed held on the lobe [the part file's [speed], else 2000]")
      ->check(CLI::Range(1.0, 1e5));
  cmd->callback([&action, o] { action = [o] { return cmd_profile(*o); }; });
}

}  // namespace gaugeloop
