// A gear run in the AQDEF export: its ISO 1328-1 figures as characteristics, titled as a gear
// checker's report titles them, F_beta judged against the run's tolerance, read back by the
// test's own reader.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "report/dfq.h"
#include "report/gear_characteristics.h"
#include "storage/run_store.h"
#include "tests/support/dfq_reader.h"

namespace gaugeloop {
namespace {

StoredGearRun gear_run(std::int64_t id, const std::string& started, double worst_um) {
  StoredGearRun g;
  g.id = id;
  GearRunRecord& r = g.record;
  r.started_utc = started;
  r.machine = "gear-grinder-2";
  r.part = "gear_71";
  r.source = "checker";
  r.serial = "G-" + std::to_string(id);
  r.nc_file = "/data/nc/GEAR_71.SPF";
  r.required_class = 5;
  r.total_tolerance_um = 8.598;
  r.verdict = worst_um <= 8.598 ? Verdict::kIn : Verdict::kOut;
  r.tolerance_class = 5;
  r.total_max_um = worst_um;
  r.total_mean_um = worst_um - 1.0;
  r.form_mean_um = 1.5;
  r.slope_mean_abs_um = 2.25;
  for (const char* flank : {"left", "right"}) {
    GearTraceRecord t;
    t.gap = 20;
    t.flank = flank;
    t.total_um = std::string(flank) == "left" ? worst_um : worst_um - 2.0;
    t.form_um = 1.5;
    t.slope_um = std::string(flank) == "left" ? 2.25 : -2.25;
    t.tolerance_class = 5;
    t.z_mm = {-1.0, 0.0, 1.0};
    t.deviation_um = {0.0, 0.1, 0.2};
    r.traces.push_back(t);
  }
  return g;
}

TEST(GearDfq, AGearsBlockCarriesItsLeadFiguresWithF_betaJudgedAgainstItsClass) {
  const std::vector<RunCharacteristics> runs = {gear_run_characteristics(gear_run(7, "2026-12-01T08:00:00Z", 9.25)),
                                                gear_run_characteristics(gear_run(8, "2026-12-01T09:00:00Z", 2.5))};
  Result<std::string> text = write_dfq(runs, {.harmonics = 0, .operation = "gear grinding"});
  ASSERT_TRUE(text.ok()) << text.error().message;
  Result<testing::DfqFile> file = testing::read_dfq(*text);
  ASSERT_TRUE(file.ok()) << file.error().message;
  ASSERT_EQ(file->parts.size(), 1u);
  EXPECT_EQ(file->parts[0].fields.at("K1001"), "gear_71");
  EXPECT_EQ(file->parts[0].fields.at("K1002"), "gear teeth");
  EXPECT_EQ(file->parts[0].fields.at("K1086"), "gear grinding");
  // 4 for the gear, 3 for each of its 2 traces.
  ASSERT_EQ(file->total_characteristics, 10);
  const auto& c = file->characteristics;
  EXPECT_EQ(c[0].fields.at("K2001"), "lead.F_beta");
  EXPECT_EQ(c[0].fields.at("K2002"), "Total helix deviation F_beta, worst flank");
  EXPECT_EQ(c[0].fields.at("K2111"), "8.598");
  EXPECT_EQ(c[0].fields.at("K2110"), "0.000");  // a band's width: 0 is its natural boundary
  EXPECT_EQ(c[0].fields.at("K2120"), "1");
  EXPECT_EQ(c[4].fields.at("K2001"), "lead.F_beta.20.left");
  EXPECT_EQ(c[4].fields.at("K2002"), "Total helix deviation F_beta, gap 20, left flank");
  EXPECT_EQ(c[4].fields.at("K2111"), "8.598");
  EXPECT_EQ(c[6].fields.at("K2001"), "lead.f_H_beta.20.left");
  EXPECT_EQ(c[6].fields.at("K2002"), "Helix slope deviation f_H_beta, gap 20, left flank");
  EXPECT_EQ(c[6].fields.count("K2110"), 0u) << "f_H_beta is signed: no lower boundary";
  EXPECT_EQ(c[6].fields.count("K2111"), 0u) << "f_H_beta is not judged";
  EXPECT_EQ(c[9].fields.at("K2001"), "lead.f_H_beta.20.right");
  // Values: run 7 first (oldest), with its gear run id and serial.
  ASSERT_EQ(c[0].values.size(), 2u);
  EXPECT_EQ(c[0].values[0].fields.at("K0001"), "9.250");
  EXPECT_EQ(c[0].values[0].fields.at("K0006"), "7");
  EXPECT_EQ(c[0].values[0].fields.at("K0014"), "G-7");
  EXPECT_EQ(c[9].values[1].fields.at("K0001"), "-2.250");
}

TEST(GearDfq, TheRunsCharacteristicsJudgeF_betaOnly) {
  const RunCharacteristics r = gear_run_characteristics(gear_run(7, "2026-12-01T08:00:00Z", 9.25));
  EXPECT_EQ(r.run.id, 7);
  EXPECT_EQ(r.run.verdict, Verdict::kOut);
  EXPECT_EQ(part_kind_of(r.characteristics), PartKind::kGear);
  ASSERT_EQ(r.characteristics.size(), 10u);
  EXPECT_EQ(r.characteristics[0].verdict, Verdict::kOut);  // 9.25 over 8.598
  EXPECT_EQ(r.characteristics[4].verdict, Verdict::kOut);  // gap 20 left: 9.25
  EXPECT_EQ(r.characteristics[7].verdict, Verdict::kIn);   // gap 20 right: 7.25
  EXPECT_EQ(r.characteristics[2].verdict, Verdict::kNotJudged);
  // A gear of a part without a class: nothing judged.
  StoredGearRun free = gear_run(9, "2026-12-01T08:00:00Z", 9.25);
  free.record.required_class.reset();
  free.record.total_tolerance_um.reset();
  free.record.verdict = Verdict::kNotJudged;
  for (const Characteristic& c : gear_run_characteristics(free).characteristics) {
    EXPECT_EQ(c.verdict, Verdict::kNotJudged) << c.key;
  }
}

TEST(GearDfq, AnUnknownLeadKeyKeepsItsName) {
  EXPECT_EQ(characteristic_title("lead.F_beta.x.left", PartKind::kGear), "lead.F_beta.x.left");
  EXPECT_EQ(characteristic_title("lead.profile.1.left", PartKind::kGear), "lead.profile.1.left");
  EXPECT_EQ(characteristic_title("lead.f_f_beta.mean"), "Helix form deviation f_f_beta, mean of the flanks");
}

}  // namespace
}  // namespace gaugeloop
