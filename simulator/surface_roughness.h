// The surface the virtual grinder leaves: Ra against the equivalent chip thickness.
//
// h_eq = a_e v_w / v_s (depth of cut times grinding-point speed over wheel speed) is the chip
// thickness a grinding wheel's grits take on average; finish coarsens with it. The model is a
// stated power law, Ra = Ra_ref (h_eq / h_ref)^p, calibrated on the one pair of figures the seed
// paper gives (CCAM camshaft grinding on an MK8332: a grinding-point speed of 8000 mm/min left
// Ra 3.2 um on the flanks, 2000 mm/min left 0.775 um, at a feed of 20 um per turn and a wheel
// at 1500 rpm). Two points fix a power law and nothing more: p = ln(3.2 / 0.775) / ln 4 = 1.02.
// Outside 2000 .. 8000 mm/min it is an extrapolation (docs/variable_speed.md).
#pragma once

#include <vector>

#include "compensation/wheel_path.h"

namespace gaugeloop {

// The grinding conditions h_eq is computed for. The paper gives the wheel's 1500 rpm but not
// its diameter; 31.4 m/s is 1500 rpm of a 400 mm wheel (the sample parts' wheel). With the
// model calibrated at the same conditions, Ra depends on the grinding-point speed alone.
struct GrindingConditions {
  double depth_of_cut_um = 20.0;
  double wheel_speed_m_per_s = 31.4;
};

// h_eq in um for a grinding-point speed in mm/min.
double equivalent_chip_thickness_um(double grinding_point_speed_mm_per_min, const GrindingConditions& c);

struct RoughnessModel {
  double ra_ref_um = 0.0;  // Ra at h_ref
  double h_ref_um = 0.0;
  double exponent = 0.0;  // p
};

// The power law through (v_fast, Ra_fast) and (v_slow, Ra_slow), grinding-point speeds in mm/min,
// under `c`. The speeds must differ and the Ra be positive (callers pass constants).
RoughnessModel calibrate_roughness(double v_fast_mm_per_min, double ra_fast_um, double v_slow_mm_per_min,
                                   double ra_slow_um, const GrindingConditions& c);

// The variable-speed camshaft paper's calibration: 8000 mm/min -> 3.2 um, 2000 mm/min -> 0.775 um.
RoughnessModel paper_roughness_model(const GrindingConditions& c = {});

double roughness_ra_um(const RoughnessModel& model, double h_eq_um);

// Ra at every row of a machine path, from the grinding-point speed there (same rows), and
// the flank figure: the largest Ra where X is between 5 % and 95 % of its largest value (the
// rise and the return, neither base circle nor nose), as the paper quotes the largest.
struct SurfaceFinish {
  std::vector<double> ra_um;
  double flank_ra_um = 0.0;
  double flank_at_c_deg = 0.0;
};
SurfaceFinish surface_finish(const MachinePath& path, const std::vector<double>& grinding_point_speed_mm_per_min,
                             const RoughnessModel& model, const GrindingConditions& c = {});

}  // namespace gaugeloop
