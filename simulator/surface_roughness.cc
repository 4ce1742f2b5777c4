// Ra against h_eq: the power law and the flank figure.
#include "simulator/surface_roughness.h"

#include <algorithm>
#include <cmath>

#include "compensation/work_speed.h"

namespace gaugeloop {

double equivalent_chip_thickness_um(double grinding_point_speed_mm_per_min, const GrindingConditions& c) {
  const double v_w_mm_per_s = grinding_point_speed_mm_per_min / 60.0;
  const double v_s_mm_per_s = c.wheel_speed_m_per_s * 1000.0;
  return c.depth_of_cut_um * v_w_mm_per_s / v_s_mm_per_s;
}

RoughnessModel calibrate_roughness(double v_fast_mm_per_min, double ra_fast_um, double v_slow_mm_per_min,
                                   double ra_slow_um, const GrindingConditions& c) {
  RoughnessModel m;
  m.ra_ref_um = ra_fast_um;
  m.h_ref_um = equivalent_chip_thickness_um(v_fast_mm_per_min, c);
  m.exponent =
      std::log(ra_fast_um / ra_slow_um) / std::log(m.h_ref_um / equivalent_chip_thickness_um(v_slow_mm_per_min, c));
  return m;
}

RoughnessModel paper_roughness_model(const GrindingConditions& c) {
  return calibrate_roughness(8000.0, 3.2, 2000.0, 0.775, c);
}

double roughness_ra_um(const RoughnessModel& m, double h_eq_um) {
  return m.ra_ref_um * std::pow(std::max(h_eq_um, 0.0) / m.h_ref_um, m.exponent);
}

SurfaceFinish surface_finish(const MachinePath& path, const std::vector<double>& grinding_point_speed_mm_per_min,
                             const RoughnessModel& model, const GrindingConditions& c) {
  SurfaceFinish f;
  const size_t n = std::min(path.x_mm.size(), grinding_point_speed_mm_per_min.size());
  f.ra_um.resize(n);
  double x_max = 0.0;
  for (size_t k = 0; k < n; ++k) x_max = std::max(x_max, path.x_mm[k]);
  for (size_t k = 0; k < n; ++k) {
    f.ra_um[k] = roughness_ra_um(model, equivalent_chip_thickness_um(grinding_point_speed_mm_per_min[k], c));
    const bool flank = is_flank_row(path.x_mm[k], x_max);
    if (flank && f.ra_um[k] > f.flank_ra_um) {
      f.flank_ra_um = f.ra_um[k];
      f.flank_at_c_deg = k < path.c_deg.size() ? path.c_deg[k] : 0.0;
    }
  }
  return f;
}

}  // namespace gaugeloop
