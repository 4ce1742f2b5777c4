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
};

// One row whichever the frame: the angle (psi or C), X, and its derivatives along that angle.
struct Row {
  double angle_deg = 0.0;
  double x_mm = 0.0;
  double dx_mm_per_deg = 0.0;
  double d2x_mm_per_deg2 = 0.0;
  double v_mm_per_s = 0.0;  // only with a speed
  double a_mm_per_s2 = 0.0;
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
  Result<LoadedPart> loaded = load_part(o.part_path);
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
  if (o.speed_rpm) {
    // In time, C turns at 6 n deg/s; from the cam frame dX/dC = s dX/dpsi.
    const double sense = machine ? 1.0 : static_cast<double>(part.rotation_sense);
    for (Row& r : rows) {
      r.v_mm_per_s = slide_velocity_mm_per_s(sense * r.dx_mm_per_deg, *o.speed_rpm);
      r.a_mm_per_s2 = slide_acceleration_mm_per_s2(r.d2x_mm_per_deg2, *o.speed_rpm);
    }
  }

  const std::string angle = machine ? "c_deg" : "psi_deg";
  const std::string d1 = machine ? "dx_dc_mm_per_deg" : "dx_dpsi_mm_per_deg";
  const std::string d2 = machine ? "d2x_dc2_mm_per_deg2" : "d2x_dpsi2_mm_per_deg2";
  if (o.format == "json") {
    nlohmann::ordered_json points = nlohmann::ordered_json::array();
    Row peak;  // largest magnitudes
    for (const Row& r : rows) {
      nlohmann::ordered_json p = {
          {angle, r.angle_deg}, {"x_mm", r.x_mm}, {d1, r.dx_mm_per_deg}, {d2, r.d2x_mm_per_deg2}};
      if (o.speed_rpm) {
        p["v_mm_per_s"] = r.v_mm_per_s;
        p["a_mm_per_s2"] = r.a_mm_per_s2;
      }
      points.push_back(std::move(p));
      peak.x_mm = std::max(peak.x_mm, r.x_mm);
      peak.dx_mm_per_deg = std::max(peak.dx_mm_per_deg, std::abs(r.dx_mm_per_deg));
      peak.d2x_mm_per_deg2 = std::max(peak.d2x_mm_per_deg2, std::abs(r.d2x_mm_per_deg2));
      peak.v_mm_per_s = std::max(peak.v_mm_per_s, std::abs(r.v_mm_per_s));
      peak.a_mm_per_s2 = std::max(peak.a_mm_per_s2, std::abs(r.a_mm_per_s2));
    }
    nlohmann::ordered_json peaks = {{"x_mm", peak.x_mm}, {d1, peak.dx_mm_per_deg}, {d2, peak.d2x_mm_per_deg2}};
    if (o.speed_rpm) {
      peaks["v_mm_per_s"] = peak.v_mm_per_s;
      peaks["a_mm_per_s2"] = peak.a_mm_per_s2;
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
        {"peak_abs", peaks},
        {"points", points}};
    std::cout << out.dump(2) << "\n";
    return kExitOk;
  }
  std::string text = angle + ",x_mm," + d1 + "," + d2 + (o.speed_rpm ? ",v_mm_per_s,a_mm_per_s2\n" : "\n");
  for (const Row& r : rows) {
    text +=
        number(r.angle_deg) + "," + number(r.x_mm) + "," + number(r.dx_mm_per_deg) + "," + number(r.d2x_mm_per_deg2);
    if (o.speed_rpm) text += "," + number(r.v_mm_per_s) + "," + number(r.a_mm_per_s2);
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
                  "Work spindle speed, C turning up (negative: down); adds v_mm_per_s and a_mm_per_s2");
  cmd->callback([&action, o] { action = [o] { return cmd_profile(*o); }; });
}

}  // namespace gaugeloop
