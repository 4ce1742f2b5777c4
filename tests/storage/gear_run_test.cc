// Gear runs in the run database: stored and read back whole, listed by the filters people use,
// and refused before a row is written when the record contradicts itself.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "storage/run_store.h"
#include "storage_test_support.h"

namespace gaugeloop {
namespace {

using testing::RawDb;

GearTraceRecord sample_trace(int gap, const std::string& flank, double total_um) {
  GearTraceRecord t;
  t.gap = gap;
  t.flank = flank;
  t.total_um = total_um;
  t.form_um = total_um / 3.0;
  t.slope_um = -total_um / 2.0;
  t.tolerance_class = 4;
  t.from_mm = -10.8;
  t.to_mm = 10.8;
  // Values not on the 6-decimal grid beyond their last place, so a rounding mix-up shows.
  for (int i = 0; i < 5; ++i) {
    t.z_mm.push_back(-12.0 + 6.0 * i);
    t.deviation_um.push_back(0.125 * i * (flank == "left" ? 1 : -1) + 0.0000004 * gap);
  }
  return t;
}

GearRunRecord sample_gear(const std::string& part, const std::string& started, double worst_um) {
  GearRunRecord r;
  r.started_utc = started;
  r.machine = "gear-grinder-2";
  r.part = part;
  r.source = "/srv/checker/gear.csv";
  r.serial = "G-77";
  r.operator_name = "Jo";
  r.nc_file = "/data/nc/GEAR_71.SPF";
  r.ground_with_version = 3;
  r.required_class = 5;
  r.total_tolerance_um = 8.6;
  r.verdict = worst_um <= 8.6 ? Verdict::kIn : Verdict::kOut;
  r.tolerance_class = 6;
  r.total_max_um = worst_um;
  r.total_mean_um = worst_um * 0.8;
  r.form_mean_um = 1.25;
  r.slope_mean_abs_um = 2.5;
  r.traces = {sample_trace(1, "left", worst_um), sample_trace(1, "right", worst_um * 0.6),
              sample_trace(20, "left", worst_um * 0.7)};
  return r;
}

class GearRunStoreTest : public testing::StoreTest {};

TEST_F(GearRunStoreTest, AGearRunReadsBackAsStored) {
  const GearRunRecord in = sample_gear("gear_71", "2026-12-01T08:00:00Z", 11.5);
  Result<std::int64_t> id = store().insert_gear_run(in);
  ASSERT_TRUE(id.ok()) << id.error().message;
  ASSERT_TRUE(store().record_gear_correction(*id, 0.52, 4).ok());
  Result<StoredGearRun> out = store().load_gear_run(*id);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->id, *id);
  const GearRunRecord& r = out->record;
  EXPECT_EQ(r.started_utc, in.started_utc);
  EXPECT_EQ(r.machine, in.machine);
  EXPECT_EQ(r.part, in.part);
  EXPECT_EQ(r.source, in.source);
  EXPECT_EQ(r.serial, in.serial);
  EXPECT_EQ(r.operator_name, in.operator_name);
  EXPECT_EQ(r.nc_file, in.nc_file);
  EXPECT_EQ(r.ground_with_version, 3);
  EXPECT_EQ(r.required_class, 5);
  EXPECT_EQ(r.total_tolerance_um, 8.6);
  EXPECT_EQ(r.verdict, Verdict::kOut);
  EXPECT_EQ(r.tolerance_class, 6);
  EXPECT_DOUBLE_EQ(r.total_max_um, 11.5);
  EXPECT_DOUBLE_EQ(r.total_mean_um, 11.5 * 0.8);
  EXPECT_EQ(out->pushed_version, 4);
  EXPECT_DOUBLE_EQ(*out->mesh_residual_rms_um, 0.52);
  ASSERT_EQ(r.traces.size(), 3u);
  // Ordered by gap, then flank; every number of a trace as written to 6 decimals (0.5e-6 um).
  EXPECT_EQ(r.traces[0].gap, 1);
  EXPECT_EQ(r.traces[0].flank, "left");
  EXPECT_EQ(r.traces[1].flank, "right");
  EXPECT_EQ(r.traces[2].gap, 20);
  for (std::size_t k = 0; k < 3; ++k) {
    const GearTraceRecord& want = in.traces[k];
    const GearTraceRecord& got = r.traces[k];
    EXPECT_DOUBLE_EQ(got.total_um, want.total_um);
    EXPECT_DOUBLE_EQ(got.slope_um, want.slope_um);
    ASSERT_EQ(got.z_mm.size(), want.z_mm.size());
    for (std::size_t i = 0; i < want.z_mm.size(); ++i) {
      EXPECT_NEAR(got.z_mm[i], want.z_mm[i], 0.5e-6);
      EXPECT_NEAR(got.deviation_um[i], want.deviation_um[i], 0.5e-6);
    }
  }
}

// Profiles kept beside the leads: each as written, the F_alpha tolerance with them; a gear
// without profiles reads back without (and older gears have none).
TEST_F(GearRunStoreTest, AGearsProfilesReadBackAsStored) {
  GearRunRecord in = sample_gear("gear_71", "2026-12-01T08:00:00Z", 4.5);
  for (const auto& [gap, flank] : {std::pair{20, "left"}, std::pair{1, "right"}}) {
    GearProfileRecord p;
    p.gap = gap;
    p.flank = flank;
    p.total_um = 3.25 + gap;
    p.form_um = 1.5;
    p.slope_um = -2.125;
    p.tolerance_class = 4;
    p.from_roll_mm = 10.5;
    p.to_roll_mm = 21.75;
    for (int i = 0; i < 12; ++i) {
      p.roll_mm.push_back(10.0 + i);
      p.deviation_um.push_back(0.1 * i - 0.0000003 * gap);
    }
    in.profiles.push_back(p);
  }
  in.profile_tolerance_um = 8.4;
  Result<std::int64_t> id = store().insert_gear_run(in);
  ASSERT_TRUE(id.ok()) << id.error().message;
  Result<StoredGearRun> out = store().load_gear_run(*id);
  ASSERT_TRUE(out.ok()) << out.error().message;
  const GearRunRecord& r = out->record;
  EXPECT_EQ(r.profile_tolerance_um, 8.4);
  ASSERT_EQ(r.profiles.size(), 2u);
  // Ordered by gap, then flank.
  EXPECT_EQ(r.profiles[0].gap, 1);
  EXPECT_EQ(r.profiles[0].flank, "right");
  EXPECT_EQ(r.profiles[1].gap, 20);
  EXPECT_DOUBLE_EQ(r.profiles[1].total_um, 23.25);
  EXPECT_DOUBLE_EQ(r.profiles[1].slope_um, -2.125);
  EXPECT_DOUBLE_EQ(r.profiles[1].to_roll_mm, 21.75);
  EXPECT_EQ(r.profiles[1].tolerance_class, 4);
  ASSERT_EQ(r.profiles[1].roll_mm.size(), 12u);
  for (std::size_t i = 0; i < 12; ++i) {
    EXPECT_NEAR(r.profiles[1].roll_mm[i], in.profiles[0].roll_mm[i], 0.5e-6);
    EXPECT_NEAR(r.profiles[1].deviation_um[i], in.profiles[0].deviation_um[i], 0.5e-6);
  }
  Result<std::int64_t> bare = store().insert_gear_run(sample_gear("gear_71", "2026-12-02T08:00:00Z", 4.5));
  ASSERT_TRUE(bare.ok()) << bare.error().message;
  Result<StoredGearRun> without = store().load_gear_run(*bare);
  ASSERT_TRUE(without.ok());
  EXPECT_TRUE(without->record.profiles.empty());
  EXPECT_FALSE(without->record.profile_tolerance_um.has_value());
}

// A profile that contradicts itself, or an F_alpha tolerance without profiles, is refused before
// anything is written, naming what is wrong.
TEST_F(GearRunStoreTest, AProfileThatCannotBeRightIsRefusedNamingIt) {
  GearProfileRecord good;
  good.gap = 3;
  good.flank = "left";
  good.tolerance_class = 5;
  good.roll_mm = {10.0, 11.0, 12.0};
  good.deviation_um = {0.0, 0.5, 1.0};
  struct Case {
    std::string want;
    std::function<void(GearRunRecord&)> spoil;
  };
  const std::vector<Case> cases = {{"profile of gap 3, left flank has 3 roll lengths and 2 deviations",
                                    [&](GearRunRecord& r) {
                                      r.profiles = {good};
                                      r.profiles[0].deviation_um.pop_back();
                                      r.profile_tolerance_um = 8.4;
                                    }},
                                   {"two profiles of gap 3, left flank",
                                    [&](GearRunRecord& r) {
                                      r.profiles = {good, good};
                                      r.profile_tolerance_um = 8.4;
                                    }},
                                   {"F_alpha tolerance", [&](GearRunRecord& r) { r.profile_tolerance_um = 8.4; }},
                                   {"F_alpha tolerance", [&](GearRunRecord& r) { r.profiles = {good}; }},
                                   {"roll length 2 is", [&](GearRunRecord& r) {
                                      r.profiles = {good};
                                      r.profiles[0].roll_mm[1] = std::nan("");
                                      r.profile_tolerance_um = 8.4;
                                    }}};
  for (const Case& c : cases) {
    GearRunRecord r = sample_gear("gear_71", "2026-12-01T08:00:00Z", 4.0);
    c.spoil(r);
    Result<std::int64_t> id = store().insert_gear_run(r);
    ASSERT_FALSE(id.ok()) << c.want;
    EXPECT_EQ(id.error().code, ErrorCode::kInvalidInput);
    EXPECT_NE(id.error().message.find(c.want), std::string::npos) << id.error().message;
  }
  Result<std::vector<StoredGearRun>> all = store().list_gear_runs({});
  ASSERT_TRUE(all.ok());
  EXPECT_TRUE(all->empty());
}

TEST_F(GearRunStoreTest, ListsNewestFirstByPartVerdictSerialAndTime) {
  ASSERT_TRUE(store().insert_gear_run(sample_gear("gear_71", "2026-12-01T08:00:00Z", 11.5)).ok());
  ASSERT_TRUE(store().insert_gear_run(sample_gear("gear_71", "2026-12-02T08:00:00Z", 2.5)).ok());
  GearRunRecord other = sample_gear("gear_40", "2026-12-03T08:00:00Z", 3.0);
  other.serial = "G-78";
  ASSERT_TRUE(store().insert_gear_run(other).ok());

  auto parts_of = [&](const GearRunQuery& q) {
    Result<std::vector<StoredGearRun>> runs = store().list_gear_runs(q);
    EXPECT_TRUE(runs.ok()) << runs.error().message;
    std::vector<std::string> out;
    if (runs.ok()) {
      for (const StoredGearRun& g : *runs) {
        out.push_back(g.record.part + "@" + g.record.started_utc.substr(8, 2));
        EXPECT_TRUE(g.record.traces.empty());  // lists leave the traces out
      }
    }
    return out;
  };
  GearRunQuery all;
  EXPECT_EQ(parts_of(all), (std::vector<std::string>{"gear_40@03", "gear_71@02", "gear_71@01"}));
  GearRunQuery part;
  part.part = "gear_71";
  EXPECT_EQ(parts_of(part), (std::vector<std::string>{"gear_71@02", "gear_71@01"}));
  GearRunQuery out;
  out.verdict = Verdict::kOut;
  EXPECT_EQ(parts_of(out), (std::vector<std::string>{"gear_71@01"}));
  GearRunQuery serial;
  serial.serial = "G-78";
  EXPECT_EQ(parts_of(serial), (std::vector<std::string>{"gear_40@03"}));
  GearRunQuery window;
  window.since_utc = "2026-12-02T00:00:00Z";
  window.until_utc = "2026-12-03T00:00:00Z";
  EXPECT_EQ(parts_of(window), (std::vector<std::string>{"gear_71@02"}));
  GearRunQuery one;
  one.limit = 1;
  EXPECT_EQ(parts_of(one), (std::vector<std::string>{"gear_40@03"}));

  GearRunQuery bad;
  bad.since_utc = "yesterday";
  Result<std::vector<StoredGearRun>> refused = store().list_gear_runs(bad);
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(refused.error().message.find("yesterday"), std::string::npos) << refused.error().message;
}

TEST_F(GearRunStoreTest, APartsListIsServedByItsIndex) {
  const std::string details = RawDb(db()).query_plan(
      "SELECT id FROM gear_runs AS g WHERE g.part = 'gear_71' ORDER BY g.started_utc DESC, g.id DESC LIMIT 50");
  EXPECT_NE(details.find("gear_runs_by_part_started"), std::string::npos) << details;
}

TEST_F(GearRunStoreTest, ARecordThatContradictsItselfIsRefusedBeforeARowIsWritten) {
  struct Case {
    const char* what;
    void (*spoil)(GearRunRecord&);
    const char* says;
  };
  const std::vector<Case> cases = {
      {"no trace", [](GearRunRecord& r) { r.traces.clear(); }, "no lead trace"},
      {"short trace", [](GearRunRecord& r) { r.traces[1].deviation_um.pop_back(); }, "gap 1, right flank"},
      {"two of one flank", [](GearRunRecord& r) { r.traces[2] = r.traces[0]; }, "two traces of gap 1, left flank"},
      {"unknown flank", [](GearRunRecord& r) { r.traces[0].flank = "top"; }, "'top'"},
      {"NaN deviation",
       [](GearRunRecord& r) { r.traces[2].deviation_um[3] = std::numeric_limits<double>::quiet_NaN(); },
       "gap 20, left flank's deviation 4 is NaN"},
      {"class without tolerance", [](GearRunRecord& r) { r.total_tolerance_um.reset(); }, "F_beta tolerance"},
      {"verdict without class",
       [](GearRunRecord& r) {
         r.required_class.reset();
         r.total_tolerance_um.reset();
       },
       "tolerance class"},
      {"bad time", [](GearRunRecord& r) { r.started_utc = "1.12.2026"; }, "1.12.2026"},
  };
  for (const Case& c : cases) {
    GearRunRecord r = sample_gear("gear_71", "2026-12-01T08:00:00Z", 4.0);
    c.spoil(r);
    Result<std::int64_t> id = store().insert_gear_run(r);
    ASSERT_FALSE(id.ok()) << c.what;
    EXPECT_EQ(id.error().code, ErrorCode::kInvalidInput) << c.what;
    EXPECT_NE(id.error().message.find(c.says), std::string::npos) << c.what << ": " << id.error().message;
  }
  RawDb raw(db());
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM gear_runs"), 0);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM gear_run_traces"), 0);
}

TEST_F(GearRunStoreTest, AnUnknownGearRunIsNotFoundNamingItsId) {
  Result<StoredGearRun> r = store().load_gear_run(42);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotFound);
  EXPECT_NE(r.error().message.find("gear run 42"), std::string::npos) << r.error().message;
  Status pushed = store().record_gear_correction(42, 0.5, 2);
  ASSERT_FALSE(pushed.ok());
  EXPECT_EQ(pushed.error().code, ErrorCode::kNotFound);
}

TEST_F(GearRunStoreTest, ATraceDamagedInTheFileIsReportedNotReadAsNumbers) {
  Result<std::int64_t> id = store().insert_gear_run(sample_gear("gear_71", "2026-12-01T08:00:00Z", 4.0));
  ASSERT_TRUE(id.ok());
  RawDb raw(db());
  // The CHECK keeps a malformed array out; a well-formed one of another length gets in only
  // with the CHECK off, as a damaged or hand-edited file would have it.
  EXPECT_NE(raw.exec("UPDATE gear_run_traces SET z_mm = '[1,2' WHERE gap = 20"), SQLITE_OK);
  raw.exec("PRAGMA ignore_check_constraints = ON");
  raw.exec("UPDATE gear_run_traces SET deviation_um = '[1,2,3]' WHERE gap = 20");
  Result<StoredGearRun> r = store().load_gear_run(*id);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kStorage);
  EXPECT_NE(r.error().message.find("gap 20, left flank"), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace gaugeloop
