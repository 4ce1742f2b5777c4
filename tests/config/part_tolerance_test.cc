// [tolerance] in part files: every form read into the right limits, every refusal naming the
// file, line and key, and the canonical settings lines of a lobe's tolerances.
#include <gtest/gtest.h>

#include <string>

#include "compensation/flat_probe.h"
#include "compensation/judgement.h"
#include "compensation/periodic_spline.h"
#include "config/part_file.h"
#include "core/lift_table.h"
#include "job/tolerance_settings.h"
#include "tests/support/refused.h"

namespace gaugeloop {
namespace {

using testing::refused;

// A complete flat-follower part (8 lines) followed by `tolerance`, which starts on line 9.
std::string part_with(const std::string& tolerance) {
  return "name = \"intake\"\n"
         "lobe = 1\n"
         "lift_table = \"intake.csv\"\n"
         "follower = \"flat\"\n"
         "base_circle_radius_mm = 18.0\n"
         "wheel_radius_mm = 200.0\n"
         "c_offset_deg = 0.0\n"
         "nc_program = \"CAM_INTAKE_L1\"\n" +
         tolerance;
}

Result<PartFile> parse_tolerances(const std::string& text) { return parse_part_toml(text, "part.toml", "/parts"); }

void expect_limits(const Limits& l, std::optional<double> lower, std::optional<double> upper, const char* what) {
  EXPECT_EQ(l.lower, lower) << what;
  EXPECT_EQ(l.upper, upper) << what;
}

TEST(PartTolerance, NoToleranceJudgesNothing) {
  auto pf = parse_tolerances(part_with(""));
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  const LobeTolerances& t = pf->part.tolerances;
  EXPECT_EQ(t.lift_error_reference, LiftErrorReference::kBestFit);
  EXPECT_FALSE(t.lift_error_um.any());
  EXPECT_FALSE(t.velocity_error_mm_per_deg.any());
  EXPECT_FALSE(t.acceleration_error_mm_per_deg2.any());
  EXPECT_FALSE(t.phase_deg.any());
  EXPECT_FALSE(t.base_circle_runout_um.any());
  EXPECT_FALSE(t.roundness_um.any());
  EXPECT_TRUE(t.zones.empty());
  EXPECT_EQ(tolerances_settings_text(t), "") << "a part without tolerances keeps the settings it had";

  auto empty = parse_tolerances(part_with("[tolerance]\n"));
  ASSERT_TRUE(empty.ok()) << empty.error().message;
  EXPECT_EQ(empty->part.tolerances.lift_error_reference, LiftErrorReference::kBestFit) << "the default";
  EXPECT_FALSE(empty->part.tolerances.lift_error_um.any());
}

TEST(PartTolerance, ReadsEachFormIntoItsLimits) {
  auto pf =
      parse_tolerances(part_with("[tolerance]\n"
                                 "lift_error = \"nominal\"\n"
                                 "lift_error_um = 20\n"                           // an integer is a number too
                                 "velocity_error_mm_per_deg = [-0.001, 0.003]\n"  // asymmetric
                                 "acceleration_error_mm_per_deg2 = 0.0005\n"
                                 "phase_deg = [-0.5, 0.25]\n"
                                 "base_circle_runout_um = 8.0\n"
                                 "roundness_um = 5\n"
                                 "[[tolerance.zone]]\n"
                                 "zone = \"opening_flank\"\n"
                                 "angle_deg = [-70.0, -20.0]\n"
                                 "lift_error_um = 12.0\n"
                                 "[[tolerance.zone]]\n"
                                 "zone = \"base_circle\"\n"
                                 "lift_mm = [0, 0.05]\n"
                                 "lift_error_um = [-5, 10]\n"
                                 "velocity_error_mm_per_deg = 0.001\n"
                                 "acceleration_error_mm_per_deg2 = [-0.0003, 0.0002]\n"
                                 "[[tolerance.zone]]\n"
                                 "zone = \"nose\"\n"
                                 "angle_deg = [170, -170]\n"));  // wraps through 180; no limits of its own
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  const LobeTolerances& t = pf->part.tolerances;
  EXPECT_EQ(t.lift_error_reference, LiftErrorReference::kNominal);
  expect_limits(t.lift_error_um, -20.0, 20.0, "lift_error_um");
  expect_limits(t.velocity_error_mm_per_deg, -0.001, 0.003, "velocity");
  expect_limits(t.acceleration_error_mm_per_deg2, -0.0005, 0.0005, "acceleration");
  expect_limits(t.phase_deg, -0.5, 0.25, "phase");
  expect_limits(t.base_circle_runout_um, std::nullopt, 8.0, "runout: an upper limit only");
  expect_limits(t.roundness_um, std::nullopt, 5.0, "roundness: an upper limit only");
  ASSERT_EQ(t.zones.size(), 3u);

  const ZoneTolerance& flank = t.zones[0];
  EXPECT_EQ(flank.zone, LobeZone::kOpeningFlank);
  EXPECT_FALSE(flank.by_lift);
  EXPECT_EQ(flank.from_deg, -70.0);
  EXPECT_EQ(flank.to_deg, -20.0);
  expect_limits(flank.lift_error_um, -12.0, 12.0, "flank lift");
  EXPECT_FALSE(flank.velocity_error_mm_per_deg.any()) << "each limit optional";
  EXPECT_FALSE(flank.acceleration_error_mm_per_deg2.any());

  const ZoneTolerance& base = t.zones[1];
  EXPECT_EQ(base.zone, LobeZone::kBaseCircle);
  EXPECT_TRUE(base.by_lift);
  EXPECT_EQ(base.from_lift_mm, 0.0);
  EXPECT_EQ(base.to_lift_mm, 0.05);
  expect_limits(base.lift_error_um, -5.0, 10.0, "base lift");
  expect_limits(base.velocity_error_mm_per_deg, -0.001, 0.001, "base velocity");
  expect_limits(base.acceleration_error_mm_per_deg2, -0.0003, 0.0002, "base acceleration");

  const ZoneTolerance& nose = t.zones[2];
  EXPECT_EQ(nose.zone, LobeZone::kNose);
  EXPECT_EQ(nose.from_deg, 170.0);
  EXPECT_EQ(nose.to_deg, -170.0);
  EXPECT_FALSE(nose.lift_error_um.any());
}

TEST(PartTolerance, RefusesMistakesNamingFileLineAndKey) {
  struct Case {
    std::string tolerance;
    std::string expected;
  };
  const Case cases[] = {
      // The table and its keys.
      {"tolerance = 5\n", "part.toml:9: key `tolerance`: expected a table ([tolerance])"},
      {"[tolerance]\nlift_eror_um = 20\n",
       "part.toml:10: key `tolerance.lift_eror_um`: unknown key; known keys: lift_error, lift_error_um,"},
      {"[tolerance]\nlift_error = \"raw\"\n",
       "part.toml:10: key `tolerance.lift_error`: `raw` is not one of best_fit, nominal"},
      // Symmetric numbers and [lower, upper].
      {"[tolerance]\nlift_error_um = 0\n",
       "part.toml:10: key `tolerance.lift_error_um`: 0 is not a tolerance; give a number x > 0 for [-x, x], or "
       "[lower, upper] with lower < upper"},
      {"[tolerance]\nphase_deg = -0.25\n", "part.toml:10: key `tolerance.phase_deg`: -0.25 is not a tolerance"},
      {"[tolerance]\nlift_error_um = \"20\"\n",
       "part.toml:10: key `tolerance.lift_error_um`: expected a number; give a number x > 0"},
      {"[tolerance]\nlift_error_um = nan\n", "part.toml:10: key `tolerance.lift_error_um`: expected a number"},
      {"[tolerance]\nlift_error_um = inf\n", "part.toml:10: key `tolerance.lift_error_um`: expected a number"},
      {"[tolerance]\nlift_error_um = true\n", "part.toml:10: key `tolerance.lift_error_um`: expected a number"},
      {"[tolerance]\nvelocity_error_mm_per_deg = [0.002, -0.002]\n",
       "part.toml:10: key `tolerance.velocity_error_mm_per_deg`: lower limit 0.002 is not below upper limit -0.002"},
      {"[tolerance]\nphase_deg = [0.25, 0.25]\n",
       "part.toml:10: key `tolerance.phase_deg`: lower limit 0.25 is not below upper limit 0.25"},
      {"[tolerance]\nlift_error_um = [20]\n",
       "part.toml:10: key `tolerance.lift_error_um`: expected [lower, upper], two numbers; got 1"},
      {"[tolerance]\nlift_error_um = [-20, 0, 20]\n",
       "part.toml:10: key `tolerance.lift_error_um`: expected [lower, upper], two numbers; got 3"},
      {"[tolerance]\nlift_error_um = [-20, \"20\"]\n",
       "part.toml:10: key `tolerance.lift_error_um`: expected [lower, upper], two finite numbers"},
      {"[tolerance]\nlift_error_um = [-inf, 20]\n",
       "part.toml:10: key `tolerance.lift_error_um`: expected [lower, upper], two finite numbers"},
      // Upper limits only.
      {"[tolerance]\nbase_circle_runout_um = [0, 8]\n",
       "part.toml:10: key `tolerance.base_circle_runout_um`: [lower, upper] is not allowed here; it has an upper "
       "limit only: give one number > 0, e.g. base_circle_runout_um = 8.0"},
      {"[tolerance]\nroundness_um = 0\n", "part.toml:10: key `tolerance.roundness_um`: 0 is not a limit"},
      {"[tolerance]\nroundness_um = \"5\"\n", "part.toml:10: key `tolerance.roundness_um`: expected a number"},
      // Zones.
      {"[tolerance]\n[tolerance.zone]\nzone = \"nose\"\n",
       "part.toml:10: key `tolerance.zone`: expected [[tolerance.zone]] tables, one per zone"},
      {"[[tolerance.zone]]\nangle_deg = [-10, 10]\n",
       "part.toml:9: [[tolerance.zone]] without key `tolerance.zone.zone`; name the zone: base_circle,"},
      {"[[tolerance.zone]]\nzone = \"flank\"\nangle_deg = [-10, 10]\n",
       "part.toml:10: key `tolerance.zone.zone`: `flank` is not one of base_circle, opening_ramp, opening_flank, "
       "nose, closing_flank, closing_ramp"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nlift_error_um = 20\n",
       "part.toml:9: [[tolerance.zone]]: give exactly one of angle_deg = [from, to] (cam degrees) or lift_mm = "
       "[from, to] (design lift)"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-10, 10]\nlift_mm = [8, 9]\n",
       "part.toml:12: key `tolerance.zone.lift_mm`: give exactly one of angle_deg"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-10, 10]\ncolour = \"red\"\n",
       "part.toml:12: key `tolerance.zone.colour`: unknown key; known keys: zone, angle_deg, lift_mm,"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = 10\n",
       "part.toml:11: key `tolerance.zone.angle_deg`: expected [from, to], the arc from the first angle up to the "
       "second"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-10]\n",
       "part.toml:11: key `tolerance.zone.angle_deg`: expected [from, to] in cam degrees, two numbers; got 1"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-400, 10]\n",
       "part.toml:11: key `tolerance.zone.angle_deg`: -400 is out of range; angles are in [-360, 360]"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-10, 360.5]\n",
       "part.toml:11: key `tolerance.zone.angle_deg`: 360.5 is out of range"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nlift_mm = 8\n",
       "part.toml:11: key `tolerance.zone.lift_mm`: expected [from, to], the design lift in mm"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nlift_mm = [9, 8]\n",
       "part.toml:11: key `tolerance.zone.lift_mm`: [9, 8] is not a lift band; allowed 0 <= from < to"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nlift_mm = [8, 8]\n",
       "part.toml:11: key `tolerance.zone.lift_mm`: [8, 8] is not a lift band"},
      {"[[tolerance.zone]]\nzone = \"base_circle\"\nlift_mm = [-0.1, 0.05]\n",
       "part.toml:11: key `tolerance.zone.lift_mm`: [-0.1, 0.05] is not a lift band"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nlift_mm = [8, nan]\n",
       "part.toml:11: key `tolerance.zone.lift_mm`: expected [from, to] in mm of design lift, two finite numbers"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-10, 10]\nlift_error_um = -3\n",
       "part.toml:12: key `tolerance.zone.lift_error_um`: -3 is not a tolerance"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-10, 10]\nvelocity_error_mm_per_deg = [1, -1]\n",
       "part.toml:12: key `tolerance.zone.velocity_error_mm_per_deg`: lower limit 1 is not below upper limit -1"},
      {"[[tolerance.zone]]\nzone = \"nose\"\nangle_deg = [-10, 10]\n"
       "[[tolerance.zone]]\nzone = \"closing_flank\"\nangle_deg = [11, 60]\n"
       "[[tolerance.zone]]\nzone = \"nose\"\nlift_mm = [8, 9]\n",
       "part.toml:16: key `tolerance.zone.zone`: zone `nose` is given twice (first at part.toml:10); one "
       "[[tolerance.zone]] per zone"},
  };
  for (const Case& c : cases) EXPECT_TRUE(refused(parse_tolerances(part_with(c.tolerance)), c.expected)) << c.tolerance;
}

// The lead's example of the format, as docs/parts.md shows it, read and written back as
// settings lines; the same tolerances in another order and form give the same lines.
TEST(PartTolerance, TheDocumentedExampleReadsAndGivesCanonicalSettings) {
  const std::string example =
      "[tolerance]\n"
      "lift_error = \"best_fit\"\n"
      "lift_error_um = 20.0\n"
      "velocity_error_mm_per_deg = 0.002\n"
      "acceleration_error_mm_per_deg2 = 0.0005\n"
      "phase_deg = 0.25\n"
      "base_circle_runout_um = 8.0\n"
      "roundness_um = 5.0\n"
      "\n"
      "[[tolerance.zone]]\n"
      "zone = \"closing_flank\"\n"
      "lift_mm = [0.3, 7.5]\n"
      "lift_error_um = [-10.0, 15.0]\n"
      "\n"
      "[[tolerance.zone]]\n"
      "zone = \"opening_flank\"\n"
      "angle_deg = [-70.0, -20.0]\n"
      "lift_error_um = 12.0\n"
      "velocity_error_mm_per_deg = 0.001\n"
      "acceleration_error_mm_per_deg2 = 0.0003\n";
  auto pf = parse_tolerances(part_with(example));
  ASSERT_TRUE(pf.ok()) << pf.error().message;
  const std::string expected =
      "tolerance.lift_error = best_fit\n"
      "tolerance.lift_error_um = -20 20\n"
      "tolerance.velocity_error_mm_per_deg = -0.002 0.002\n"
      "tolerance.acceleration_error_mm_per_deg2 = -0.0005 0.0005\n"
      "tolerance.phase_deg = -0.25 0.25\n"
      "tolerance.base_circle_runout_um = none 8\n"
      "tolerance.roundness_um = none 5\n"
      "tolerance.zone.opening_flank.angle_deg = -70 -20\n"
      "tolerance.zone.opening_flank.lift_error_um = -12 12\n"
      "tolerance.zone.opening_flank.velocity_error_mm_per_deg = -0.001 0.001\n"
      "tolerance.zone.opening_flank.acceleration_error_mm_per_deg2 = -0.0003 0.0003\n"
      "tolerance.zone.closing_flank.lift_mm = 0.3 7.5\n"
      "tolerance.zone.closing_flank.lift_error_um = -10 15\n";
  EXPECT_EQ(tolerances_settings_text(pf->part.tolerances), expected);

  // Written another way: keys reordered, the default reference left out, symmetric limits as
  // [lower, upper], zones in the other order. Judged alike, so the same settings.
  auto same =
      parse_tolerances(part_with("[[tolerance.zone]]\n"
                                 "zone = \"opening_flank\"\n"
                                 "acceleration_error_mm_per_deg2 = [-0.0003, 0.0003]\n"
                                 "velocity_error_mm_per_deg = 0.001\n"
                                 "lift_error_um = [-12, 12]\n"
                                 "angle_deg = [-70, -20]\n"
                                 "[[tolerance.zone]]\n"
                                 "zone = \"closing_flank\"\n"
                                 "lift_error_um = [-10, 15]\n"
                                 "lift_mm = [0.3, 7.5]\n"
                                 "[tolerance]\n"
                                 "roundness_um = 5\n"
                                 "base_circle_runout_um = 8\n"
                                 "phase_deg = [-0.25, 0.25]\n"
                                 "acceleration_error_mm_per_deg2 = 0.0005\n"
                                 "velocity_error_mm_per_deg = 0.002\n"
                                 "lift_error_um = 20\n"));
  ASSERT_TRUE(same.ok()) << same.error().message;
  EXPECT_EQ(tolerances_settings_text(same->part.tolerances), expected);

  // A change of one limit shows.
  std::string tighter = example;
  tighter.replace(tighter.find("phase_deg = 0.25"), 16, "phase_deg = 0.2");
  auto changed = parse_tolerances(part_with(tighter));
  ASSERT_TRUE(changed.ok()) << changed.error().message;
  const std::string text = tolerances_settings_text(changed->part.tolerances);
  EXPECT_NE(text, expected);
  EXPECT_NE(text.find("tolerance.phase_deg = -0.2 0.2\n"), std::string::npos) << text;
}

TEST(PartTolerance, SettingsTextOfLimitsSetByHand) {
  LobeTolerances t;
  t.lift_error_reference = LiftErrorReference::kNominal;
  EXPECT_EQ(tolerances_settings_text(t), "") << "a reference alone judges nothing";
  t.lift_error_um = Limits{std::nullopt, 0.1 + 0.2};  // shortest exact text, not rounded
  ZoneTolerance nose;
  nose.zone = LobeZone::kNose;
  nose.from_deg = -0.0;
  nose.to_deg = 12.5;
  t.zones.push_back(nose);
  EXPECT_EQ(tolerances_settings_text(t),
            "tolerance.lift_error = nominal\n"
            "tolerance.lift_error_um = none 0.30000000000000004\n"
            "tolerance.zone.nose.angle_deg = 0 12.5\n");
}

// The sample parts carry a shop's tolerances, zones by design lift on the intake and by cam
// angle on the exhaust, and the intake from the finer table is judged as the intake.
TEST(PartTolerance, TheSamplePartsCarryTolerances) {
  const std::string examples = std::string(GAUGELOOP_SOURCE_DIR) + "/examples/";
  auto intake = read_part_file(examples + "intake_flat.toml");
  auto half = read_part_file(examples + "intake_flat_half_degree.toml");
  auto exhaust = read_part_file(examples + "exhaust_roller.toml");
  ASSERT_TRUE(intake.ok()) << intake.error().message;
  ASSERT_TRUE(half.ok()) << half.error().message;
  ASSERT_TRUE(exhaust.ok()) << exhaust.error().message;

  for (const PartFile* pf : {&*intake, &*exhaust}) {
    const LobeTolerances& t = pf->part.tolerances;
    SCOPED_TRACE(pf->part.name);
    EXPECT_EQ(t.lift_error_reference, LiftErrorReference::kBestFit);
    EXPECT_TRUE(t.lift_error_um.any());
    EXPECT_TRUE(t.velocity_error_mm_per_deg.any());
    EXPECT_TRUE(t.phase_deg.any());
    EXPECT_TRUE(t.base_circle_runout_um.upper.has_value());
    EXPECT_TRUE(t.roundness_um.upper.has_value());
    ASSERT_EQ(t.zones.size(), kLobeZones.size()) << "every zone of the lobe";
    for (const ZoneTolerance& z : t.zones) {
      EXPECT_EQ(z.by_lift, pf == &*intake) << lobe_zone_name(z.zone);
      EXPECT_TRUE(z.lift_error_um.any()) << lobe_zone_name(z.zone);
    }
  }
  EXPECT_EQ(intake->part.tolerances.zones.front().zone, LobeZone::kBaseCircle);
  EXPECT_EQ(intake->part.tolerances.zones.front().lift_error_um.upper, 5.0) << "the base circle tighter";

  const std::string intake_settings = tolerances_settings_text(intake->part.tolerances);
  EXPECT_EQ(tolerances_settings_text(half->part.tolerances), intake_settings) << "the same lobe, judged alike";
  EXPECT_NE(tolerances_settings_text(exhaust->part.tolerances), intake_settings);
}

// The samples' zones placed on their designs' flat-probe reading as a run is judged: every
// zone is one arc, no degree is in two, and together they go round the whole lobe, in the
// order the follower meets them.
TEST(PartTolerance, TheSampleZonesCoverTheirLobesWithoutOverlap) {
  struct Expected {
    const char* part;
    int base_from_deg, base_to_deg, nose_from_deg, nose_to_deg;
  };
  const Expected samples[] = {
      {"intake_flat", 82, -82, -14, 14},
      {"intake_flat_half_degree", 82, -82, -14, 14},
      {"exhaust_roller", 66, -66, -15, 15},
  };
  for (const Expected& e : samples) {
    SCOPED_TRACE(e.part);
    auto pf = read_part_file(std::string(GAUGELOOP_SOURCE_DIR) + "/examples/" + e.part + ".toml");
    ASSERT_TRUE(pf.ok()) << pf.error().message;
    auto table = read_lift_table_csv(pf->part.lift_table);
    ASSERT_TRUE(table.ok()) << table.error().message;
    auto lift = PeriodicSpline::fit(table->angle_deg, table->lift_mm);
    ASSERT_TRUE(lift.ok()) << lift.error().message;
    auto reading = flat_probe_reading(*lift, pf->part);
    ASSERT_TRUE(reading.ok()) << reading.error().message;
    auto arcs = zone_arcs(pf->part.tolerances, *reading);
    ASSERT_TRUE(arcs.ok()) << arcs.error().message;
    ASSERT_EQ(arcs->size(), kLobeZones.size());
    size_t degrees = 0;
    for (size_t i = 0; i < arcs->size(); ++i) {
      const ZoneArc& arc = (*arcs)[i];
      EXPECT_EQ(arc.zone, kLobeZones[i]);
      degrees += arc.degrees.size();
      // Each arc ends the degree before the next one starts: no gap between zones.
      const ZoneArc& next = (*arcs)[(i + 1) % arcs->size()];
      EXPECT_EQ((next.from_deg - arc.to_deg + 360) % 360, 1)
          << lobe_zone_name(arc.zone) << " ends at " << arc.to_deg << ", " << lobe_zone_name(next.zone) << " starts at "
          << next.from_deg;
    }
    EXPECT_EQ(degrees, 360u) << "every degree of the turn in one zone";
    EXPECT_EQ((*arcs)[0].from_deg, e.base_from_deg);
    EXPECT_EQ((*arcs)[0].to_deg, e.base_to_deg);
    EXPECT_EQ((*arcs)[3].from_deg, e.nose_from_deg);
    EXPECT_EQ((*arcs)[3].to_deg, e.nose_to_deg);
  }
}

}  // namespace
}  // namespace gaugeloop
