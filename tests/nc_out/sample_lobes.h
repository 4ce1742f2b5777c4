// The sample lobes of examples/ as fine wheel paths, built the way app/ will: design lift
// table -> periodic spline -> compensation's compute_machine_path at 0.01 deg -> SampledPath.
#pragma once

#include <map>
#include <string>

#include <gtest/gtest.h>

#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "core/lift_table.h"
#include "core/part.h"
#include "nc_out/sampled_path.h"

namespace gaugeloop::testing {

inline constexpr double kFineStepDeg = 0.01;

// The parts as examples/<name>.toml describes them (nc_out tests do not read TOML: app/ does).
inline Part sample_part(const std::string& name) {
  Part p;
  p.name = name;
  if (name == "intake_flat") {
    p.lobe = 1;
    p.follower = FollowerKind::kFlat;
    p.base_circle_radius_mm = 18.0;
    p.wheel_radius_mm = 200.0;
  } else {
    EXPECT_EQ(name, "exhaust_roller");
    p.lobe = 2;
    p.follower = FollowerKind::kRoller;
    p.follower_radius_mm = 11.0;
    p.base_circle_radius_mm = 17.0;
    p.wheel_radius_mm = 45.0;
  }
  p.lift_table = name + ".csv";
  return p;
}

inline SampledPath fine_path_of(const std::string& name) {
  Result<LiftTable> t = read_lift_table_csv(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/" + name + ".csv");
  EXPECT_TRUE(t.ok()) << (t.ok() ? "" : t.error().message);
  Result<PeriodicSpline> lift = PeriodicSpline::fit(t->angle_deg, t->lift_mm);
  EXPECT_TRUE(lift.ok());
  Result<MachinePath> m = compute_machine_path(*lift, sample_part(name), kFineStepDeg);
  EXPECT_TRUE(m.ok()) << (m.ok() ? "" : m.error().message);
  return SampledPath{kFineStepDeg, m->x_mm, m->dx_dc_mm_per_deg, m->d2x_dc2_mm_per_deg2};
}

// Computed once per test binary: 36000 rows of exact kinematics each.
inline const SampledPath& sample_path(const std::string& name) {
  static std::map<std::string, SampledPath> cache;
  auto it = cache.find(name);
  if (it == cache.end()) it = cache.emplace(name, fine_path_of(name)).first;
  return it->second;
}

}  // namespace gaugeloop::testing
