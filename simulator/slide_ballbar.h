// The virtual gear grinder's slides over their travel and a ballbar run on them in the ZY plane
// (docs/gears.md, "The slides"): the geometry a compensation table can take out (scales,
// squareness, guides' bows, screws' periodic errors) and what it cannot (the servo mismatch of
// Y and Z, their drives' backlash, the bar's own noise). The circle is centred on the axes' zero.
#pragma once

#include <cstdint>
#include <vector>

#include "compensation/ballbar.h"
#include "core/slide_table.h"

namespace gaugeloop {

struct SlideErrors {
  double y_scale = 0.0;           // Y's error per mm of Y (mm/mm)
  double z_scale = 0.0;           // Z's error per mm of Z
  double squareness = 0.0;        // Y's error per mm of Z (mm/mm)
  double y_bow_per_mm = 0.0;      // Y's error per mm^2 of Z: Z's guide bowed in Y (1/mm)
  double z_bow_per_mm = 0.0;      // Z's error per mm^2 of Y: Y's guide bowed in Z
  double y_screw_lead_mm = 10.0;  // Y's ball screw: its lead and periodic error
  double y_screw_mm = 0.0;
  double y_screw_phase_rad = 0.0;
  double z_screw_lead_mm = 16.0;
  double z_screw_mm = 0.0;
  double z_screw_phase_rad = 0.0;
  double y_lag_ms = 0.0;  // each axis stands behind its command by its velocity times its lag
  double z_lag_ms = 0.0;
  double y_backlash_um = 0.0;  // each axis stands behind by half its play in the direction it moves
  double z_backlash_um = 0.0;
  double bar_noise_um = 0.2;  // the ballbar's own, one sigma
  std::uint64_t seed = 1;
  // Where the axes stand less where they were commanded at (y, z), moving with velocity
  // (vy, vz) mm/s, less what `tables` take out.
  void error_mm(double y_mm, double z_mm, double vy, double vz, const std::vector<SlideCompensationTable>& tables,
                double& ey_mm, double& ez_mm) const;
};

// The slides of the machine drawn from `seed` (docs/gears.md): scales 20-50 ppm each, squareness
// 200-300 um/m, each guide bowed 20-35 um at 100 mm either side, screws' periodic errors 1.5-3 um
// (Y's lead 10 mm, Z's 16 mm), lags 1-3 ms apart by 0.05-0.2 ms, backlash 1-3 um, the bar's noise
// 0.2 um: a ZY ballbar of 100 mm shows 42 to 53 um of roundness (seeds 1 to 20).
SlideErrors seeded_slides(std::uint64_t seed);

// A ballbar test on the slides with `tables` loaded: a circle of `radius_mm` counter-clockwise
// and then clockwise at `feed_mm_per_min`, sampled at `rate_hz` (a QC10's 41.667 Hz: a point
// every 0.4 mm at 1000 mm/min), the bar's set-up centre where the axes stand commanded to the
// circle's centre. `measurement` seeds the bar's noise.
BallbarTest run_ballbar(const SlideErrors& slides, const std::vector<SlideCompensationTable>& tables,
                        double radius_mm = 100.0, double feed_mm_per_min = 1000.0, double rate_hz = 41.667,
                        std::uint64_t measurement = 0);

}  // namespace gaugeloop
