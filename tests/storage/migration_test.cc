// Upgrading a database written by schema version 1 (`gaugeloop demo` before the compact tables): the
// data survives, the version-1 names still read the same columns, damage stops the upgrade.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <map>
#include <string>

#include "storage/migrations.h"
#include "storage/run_store.h"
#include "storage/sqlite_db.h"
#include "storage_test_support.h"

namespace gaugeloop {
namespace {

using testing::RawDb;
using testing::TempDir;

// What version 1 kept: lifts as 6-decimal JSON, profile values as REALs.
double v1_lift(int rev, int deg) { return std::round((2.0 + std::sin(deg * 0.01745329) + rev * 1e-3) * 1e6) / 1e6; }
double v1_error(int run, int deg) { return (run == 1 ? 1.0 : -1.0) * 7.25 * std::cos(deg * 0.01745329); }

// Builds a version-1 database with the version-1 SQL exactly as released, holding run 1
// (pushed) and run 2 (measured, built on run 1's correction).
void make_v1_database(const std::filesystem::path& path) {
  std::filesystem::create_directories(path.parent_path());
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  auto exec = [db](const std::string& sql) {
    char* err = nullptr;
    const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err);
    EXPECT_EQ(rc, SQLITE_OK) << (err != nullptr ? err : "") << " in " << sql.substr(0, 200);
    sqlite3_free(err);
  };
  exec("PRAGMA journal_mode = WAL; BEGIN;");
  exec(std::string(storage_internal::schema_v1_sql()));
  exec("PRAGMA user_version = 1;");
  for (int run = 1; run <= 2; ++run) {
    exec(
        "INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, note, status, revolutions,"
        " degrees_captured, polls, reconnects, discarded_revolutions, zero_offset_mm, max_abs_error_um,"
        " rms_error_um, peak_to_valley_um, repeatability_um, nc_file, correction_in_force_run) VALUES ('2026-11-2" +
        std::to_string(run) + "T08:00:00Z', '2026-11-2" + std::to_string(run) +
        "T08:00:05Z', 'grinder-1', 'intake_flat', 1, 'tcp:127.0.0.1:1502', 'run " + std::to_string(run) + "', " +
        (run == 1 ? "'pushed'" : "'measured'") + ", 3, 1080, 410, 0, 0, 0.25, 7.25, 5.1, 14.5, 0.7, " +
        (run == 1 ? "'nc/CAM_INTAKE_L1.SPF'" : "NULL") + ", " + (run == 1 ? "NULL" : "1") + ")");
    for (int rev = 0; rev < 3; ++rev) {
      std::string json = "[";
      for (int deg = 0; deg < 360; ++deg) {
        char buf[32];
        std::snprintf(buf, sizeof buf, "%s%.6f", deg == 0 ? "" : ",", v1_lift(rev, deg));
        json += buf;
      }
      json += "]";
      exec("INSERT INTO run_revolutions VALUES (" + std::to_string(run) + ", " + std::to_string(rev) + ", " +
           std::to_string(40 + rev) + ", '" + json + "')");
    }
    for (int deg = 0; deg < 360; ++deg) {
      char buf[256];
      std::snprintf(buf, sizeof buf, "INSERT INTO run_profile VALUES (%d, %d, %.17g, %.17g, %.17g, %.17g, %.17g)", run,
                    deg, 1.0 + deg * 0.001, 1.0 + deg * 0.001 + v1_error(run, deg) / 1000.0, 0.2 + deg * 1e-4,
                    v1_error(run, deg), -0.5 * v1_error(run, deg));
      exec(buf);
    }
  }
  exec("COMMIT;");
  sqlite3_close(db);
}

TEST(MigrationFromV1, KeepsEveryRunAndItsNumbers) {
  TempDir dir;
  make_v1_database(db_in(dir));
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;

  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_text("PRAGMA integrity_check"), "ok");
  EXPECT_EQ(raw.query_int("PRAGMA foreign_key_check"), 0) << "no row points at a missing parent";

  for (int run = 1; run <= 2; ++run) {
    Result<StoredRun> loaded = store->load_run(run);
    ASSERT_TRUE(loaded.ok()) << loaded.error().message;
    EXPECT_EQ(loaded->note, "run " + std::to_string(run));
    EXPECT_EQ(loaded->summary.max_abs_error_um, 7.25);
    EXPECT_FALSE(loaded->summary.phase_error_deg.has_value()) << "version 1 did not compute it";
    EXPECT_FALSE(loaded->geometry.has_value());
    EXPECT_EQ(loaded->settings, "");
    ASSERT_EQ(loaded->revolutions.size(), 3u);
    for (int rev = 0; rev < 3; ++rev) {
      const RevolutionSamples& samples = loaded->revolutions[static_cast<std::size_t>(rev)];
      EXPECT_EQ(samples.revolution, 40 + rev);
      for (int deg = 0; deg < 360; ++deg) {
        // Version 1 kept 1e-6 mm; version 2 keeps 1e-7 mm: the conversion is exact to 1e-12.
        ASSERT_NEAR(samples.lift_mm[static_cast<std::size_t>(deg)], v1_lift(rev, deg), 1e-12) << rev << "/" << deg;
      }
    }
    for (int deg = 0; deg < 360; ++deg) {
      const auto d = static_cast<std::size_t>(deg);
      ASSERT_NEAR(loaded->analysis.error_um[d], v1_error(run, deg), 0.5e-4 + 1e-9) << deg;
      ASSERT_NEAR(loaded->correction_um[d], -0.5 * v1_error(run, deg), 0.5e-4 + 1e-9) << deg;
      ASSERT_NEAR(loaded->analysis.design_lift_mm[d], 1.0 + deg * 0.001, 0.5e-7 + 1e-12) << deg;
    }
  }
  Result<StoredRun> pushed = store->load_run(1);
  ASSERT_TRUE(pushed.ok());
  EXPECT_EQ(pushed->summary.status, "pushed");
  ASSERT_EQ(pushed->pushes.size(), 1u) << "the version-1 push is kept as an nc_pushes row";
  EXPECT_EQ(pushed->pushes[0].nc_file, "nc/CAM_INTAKE_L1.SPF");
  EXPECT_EQ(pushed->pushes[0].pushed_utc, "2026-11-21T08:00:05Z");
  EXPECT_EQ(pushed->pushes[0].table_version, 1) << "and numbered by version 3";
  Result<StoredRun> second = store->load_run(2);
  ASSERT_TRUE(second.ok());
  EXPECT_EQ(second->correction_in_force_run, 1);

  // The version-1 names read the same columns through the views.
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_samples"), 2 * 3 * 360);
  EXPECT_NEAR(raw.query_double("SELECT lift_mm FROM run_samples WHERE run_id = 2 AND revolution_index = 1"
                               " AND angle_deg = 90"),
              v1_lift(1, 90), 1e-12);
  EXPECT_NEAR(raw.query_double("SELECT error_um FROM run_profile WHERE run_id = 1 AND angle_deg = 0"), 7.25, 1e-9);
  EXPECT_EQ(raw.query_text("SELECT type FROM sqlite_schema WHERE name = 'run_profile'"), "view");
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'run_revolutions'"), 0);
  EXPECT_EQ(raw.query_text("SELECT name FROM parts"), "intake_flat");
  EXPECT_EQ(raw.query_int("SELECT lobe FROM lobes WHERE part = 'intake_flat'"), 1);

  // And the upgraded database takes new runs.
  Result<std::int64_t> id = store->insert_run(testing::make_record("intake_flat", "2026-11-23T08:00:00Z"));
  ASSERT_TRUE(id.ok()) << id.error().message;
  EXPECT_EQ(*id, 3);
}

TEST(MigrationFromV1, ADamagedRunStopsTheUpgradeAndLeavesVersion1Intact) {
  TempDir dir;
  make_v1_database(db_in(dir));
  {
    RawDb raw(db_in(dir));
    ASSERT_EQ(raw.exec("DELETE FROM run_profile WHERE run_id = 2 AND angle_deg = 100"), SQLITE_OK);
  }
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().code, ErrorCode::kStorage);
  EXPECT_NE(store.error().message.find("run 2 is damaged"), std::string::npos) << store.error().message;
  EXPECT_NE(store.error().message.find("cam degree 100"), std::string::npos) << store.error().message;
  EXPECT_NE(store.error().message.find(db_in(dir).string()), std::string::npos) << store.error().message;

  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 1);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM run_revolutions"), 6);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name IN ('run_raw', 'parts', 'events')"), 0);
}

TEST(MigrationFromV1, StepsOneVersionAtATime) {
  TempDir dir;
  std::filesystem::create_directories(db_in(dir).parent_path());
  storage_internal::Connection conn;
  conn.path = db_in(dir);
  ASSERT_EQ(sqlite3_open(db_in(dir).c_str(), &conn.db), SQLITE_OK);
  ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, 1).ok());
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 1);
  EXPECT_EQ(raw.query_text("SELECT type FROM sqlite_schema WHERE name = 'run_profile'"), "table");
  Status s = storage_internal::apply_migrations_up_to(conn, 2);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 2);
  EXPECT_EQ(raw.query_text("SELECT type FROM sqlite_schema WHERE name = 'run_profile'"), "view");
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_pending'"), 0);
  s = storage_internal::apply_migrations_up_to(conn, 3);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 3);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_pending'"), 1);
  ASSERT_EQ(raw.exec("INSERT INTO events (id, at_utc, kind, code, message) VALUES "
                     "(7, '2026-11-22T02:00:00Z', 'fault', 'gauge timeout', 'no reply')"),
            SQLITE_OK);
  EXPECT_NE(raw.exec("INSERT INTO events (at_utc, kind, code, message) VALUES "
                     "('2026-11-22T02:00:01Z', 'info', 'plc request', 'part 1 lobe 1')"),
            SQLITE_OK)
      << "version 3 knows no info events";
  s = storage_internal::apply_migrations_up_to(conn, 4);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 4);
  EXPECT_EQ(raw.query_text("SELECT code FROM events WHERE id = 7"), "gauge timeout") << "events keep their ids";
  EXPECT_EQ(raw.exec("INSERT INTO events (at_utc, kind, code, message) VALUES "
                     "('2026-11-22T02:00:01Z', 'info', 'plc request', 'part 1 lobe 1')"),
            SQLITE_OK);
  EXPECT_EQ(raw.query_int("SELECT id FROM events WHERE kind = 'info'"), 8) << "AUTOINCREMENT goes on after 7";
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'events_by_time'"), 1);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_push_intents'"), 0);
  s = storage_internal::apply_migrations_up_to(conn, 5);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 5);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'nc_push_intents'"), 1);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM pragma_table_info('runs') WHERE name IN "
                          "('ground_with_version', 'ground_with_source', 'inspection')"),
            3);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'row_counts'"), 0);
  s = storage_internal::apply_migrations_up_to(conn, 6);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 6);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name IN ('row_counts', 'runs_by_lobe_started')"),
            2);
  EXPECT_EQ(raw.query_text("SELECT group_concat(value || '=' || row_count) FROM"
                           " (SELECT * FROM row_counts WHERE table_name = 'events' ORDER BY value)"),
            "fault=1,info=1")
      << "the events already stored are counted";
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM pragma_table_info('runs') WHERE name IN ('serial', 'operator')"), 0);
  s = storage_internal::apply_migrations_up_to(conn, 7);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), 7);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM pragma_table_info('runs') WHERE name IN ('serial', 'operator')"), 2);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM sqlite_schema WHERE name = 'runs_by_serial'"), 1);
  s = storage_internal::apply_migrations(conn);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
}

// A database migrated only up to `version`, holding one run (id 5, machine g1, part intake,
// lobe 1) as that version stored it: its summary row only.
void write_old_database_with_run_5(const std::filesystem::path& db, int version) {
  std::filesystem::create_directories(db.parent_path());
  storage_internal::Connection conn;
  conn.path = db;
  ASSERT_EQ(sqlite3_open(db.c_str(), &conn.db), SQLITE_OK);
  ASSERT_TRUE(storage_internal::apply_migrations_up_to(conn, version).ok());
  ASSERT_EQ(sqlite3_exec(conn.db,
                         "INSERT INTO runs (id, started_utc, finished_utc, machine, part, lobe, gauge, revolutions,"
                         " degrees_captured, zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um,"
                         " repeatability_um) VALUES (5, '2026-11-21T08:00:00Z', '2026-11-21T08:00:09Z', 'g1',"
                         " 'intake', 1, 'tcp:127.0.0.1:1502', 3, 1080, 2.0, 12.0, 5.0, 20.0, 0.5)",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
}

// A database of version 6 holding a run: opening it copies the file, then adds serial and
// operator; the old run reads them as not given and a new run stores them.
TEST(MigrationFromV6, OldRunsHaveNoSerialAndNewRunsKeepTheirs) {
  TempDir dir;
  ASSERT_NO_FATAL_FAILURE(write_old_database_with_run_5(db_in(dir), 6));
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  ASSERT_TRUE(store->schema_upgrade().has_value()) << "upgraded without a backup";
  EXPECT_EQ(store->schema_upgrade()->from_version, 6);
  EXPECT_EQ(RawDb(store->schema_upgrade()->backup).query_int("PRAGMA user_version"), 6) << "the file as it was";
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM runs WHERE id = 5 AND serial IS NULL AND operator IS NULL"), 1);

  RunRecord marked = testing::make_record("intake", "2026-11-22T08:00:00Z");
  marked.serial = "CS-0042";
  marked.operator_name = "anna";
  Result<std::int64_t> id = store->insert_run(marked);
  ASSERT_TRUE(id.ok()) << id.error().message;
  Result<std::vector<RunSummary>> runs = store->list_runs({});
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 2u);
  EXPECT_EQ((*runs)[0].serial, "CS-0042");
  EXPECT_EQ((*runs)[0].operator_name, "anna");
  EXPECT_EQ((*runs)[1].id, 5);
  EXPECT_EQ((*runs)[1].serial, "");
  EXPECT_EQ((*runs)[1].operator_name, "");
}

// A run judged against its tolerances, as judge_lobe leaves it: a zone figure, a single figure
// with an upper limit only, and one not judged.
RunRecord judged_record(const std::string& started_utc, Verdict nose_verdict) {
  RunRecord r = testing::make_record("intake", started_utc);
  Characteristic nose;
  nose.key = "lift_error.nose";
  nose.unit = "um";
  nose.value = nose_verdict == Verdict::kOut ? 12.5 : 3.25;
  nose.min = -1.5;
  nose.max = nose.value;
  nose.limits = {-10.0, 10.0};
  nose.verdict = nose_verdict;
  nose.from_deg = -14;
  nose.to_deg = 14;
  Characteristic runout;
  runout.key = "base_circle_runout";
  runout.unit = "um";
  runout.value = runout.min = runout.max = 2.0;
  runout.limits = {std::nullopt, 8.0};
  runout.verdict = Verdict::kIn;
  Characteristic h1;
  h1.key = "base_circle_runout_h1";
  h1.unit = "um";
  h1.value = h1.min = h1.max = 4.0;
  r.characteristics = {nose, runout, h1};
  r.verdict = combined_verdict({nose.verdict, runout.verdict, h1.verdict});
  r.lift_error_reference = LiftErrorReference::kNominal;
  r.analysis.residual_error_um[17] = -2.5;
  r.analysis.max_abs_residual_um = 2.5;
  r.analysis.dial_runout_um = 2.0;
  r.analysis.roundness_um = 0.75;
  return r;
}

TEST(MigrationFromV7, OldRunsAreNotJudgedAndNewRunsKeepTheirCharacteristics) {
  TempDir dir;
  ASSERT_NO_FATAL_FAILURE(write_old_database_with_run_5(db_in(dir), 7));
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  ASSERT_TRUE(store->schema_upgrade().has_value());
  EXPECT_EQ(store->schema_upgrade()->from_version, 7);

  Result<std::int64_t> out_id = store->insert_run(judged_record("2026-11-22T08:00:00Z", Verdict::kOut));
  ASSERT_TRUE(out_id.ok()) << out_id.error().message;
  Result<std::int64_t> in_id = store->insert_run(judged_record("2026-11-22T09:00:00Z", Verdict::kIn));
  ASSERT_TRUE(in_id.ok()) << in_id.error().message;

  // Read back whole, in the order stored, limits absent where none were given.
  Result<StoredRun> out = store->load_run(*out_id);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->summary.verdict, Verdict::kOut);
  EXPECT_EQ(out->lift_error_reference, LiftErrorReference::kNominal);
  ASSERT_EQ(out->characteristics.size(), 3u);
  const Characteristic& nose = out->characteristics[0];
  EXPECT_EQ(nose.key, "lift_error.nose");
  EXPECT_EQ(nose.value, 12.5);
  EXPECT_EQ(nose.min, -1.5);
  EXPECT_EQ(nose.limits.lower, -10.0);
  EXPECT_EQ(nose.limits.upper, 10.0);
  EXPECT_EQ(nose.verdict, Verdict::kOut);
  EXPECT_EQ(nose.from_deg, -14);
  EXPECT_EQ(nose.to_deg, 14);
  EXPECT_FALSE(out->characteristics[1].limits.lower.has_value());
  EXPECT_EQ(out->characteristics[1].limits.upper, 8.0);
  EXPECT_FALSE(out->characteristics[2].limits.any());
  EXPECT_FALSE(out->characteristics[2].from_deg.has_value());
  EXPECT_NEAR(out->analysis.residual_error_um[17], -2.5, 5e-5);
  EXPECT_EQ(out->analysis.max_abs_residual_um, 2.5);
  EXPECT_EQ(out->analysis.roundness_um, 0.75);

  // Filters and the characteristics of a selection, oldest first.
  RunQuery q;
  q.verdict = Verdict::kOut;
  Result<std::vector<RunSummary>> outs = store->list_runs(q);
  ASSERT_TRUE(outs.ok());
  ASSERT_EQ(outs->size(), 1u);
  EXPECT_EQ((*outs)[0].id, *out_id);
  q.verdict = Verdict::kNotJudged;
  outs = store->list_runs(q);
  ASSERT_TRUE(outs.ok());
  ASSERT_EQ(outs->size(), 1u);
  EXPECT_EQ((*outs)[0].id, 5);
  Result<std::vector<RunCharacteristics>> all = store->characteristics({});
  ASSERT_TRUE(all.ok()) << all.error().message;
  ASSERT_EQ(all->size(), 3u);
  // The run stored before: not judged, no characteristics.
  EXPECT_EQ((*all)[0].run.id, 5);
  EXPECT_EQ((*all)[0].run.verdict, Verdict::kNotJudged);
  EXPECT_TRUE((*all)[0].characteristics.empty());
  EXPECT_EQ((*all)[1].run.id, *out_id);
  EXPECT_EQ((*all)[2].characteristics[0].value, 3.25);

  // /metrics counts them by verdict, the run from before as not judged.
  Result<StoreMetrics> m = store->metrics_snapshot();
  ASSERT_TRUE(m.ok()) << m.error().message;
  EXPECT_EQ(m->runs_by_verdict, (std::map<std::string, std::int64_t>{{"in", 1}, {"not_judged", 1}, {"out", 1}}));
  ASSERT_EQ(m->last_runs.size(), 2u);  // g1's old run and the newer of the two judged ones
  for (const LobeLastRun& last : m->last_runs) {
    EXPECT_EQ(last.verdict, last.run_id == 5 ? Verdict::kNotJudged : Verdict::kIn) << last.run_id;
  }
}

// Version 10 to 11: a run stored before version 8 (no verdict) says `not_judged`, and the
// verdict filter finds it with the runs judged so since.
TEST(MigrationFromV10, AnOldRunWithoutAVerdictIsNotJudgedAndFilteredSo) {
  TempDir dir;
  ASSERT_NO_FATAL_FAILURE(write_old_database_with_run_5(db_in(dir), 10));
  {
    RawDb raw(db_in(dir));
    ASSERT_EQ(raw.exec("UPDATE runs SET verdict = NULL WHERE id = 5"), SQLITE_OK);
  }
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM runs WHERE verdict IS NULL"), 0);
  RunQuery q;
  q.verdict = Verdict::kNotJudged;
  Result<std::vector<RunSummary>> runs = store->list_runs(q);
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 1u);
  EXPECT_EQ((*runs)[0].id, 5);
}

TEST(Characteristics, ARunWithANonFiniteOrRepeatedCharacteristicIsRefusedAndNothingWritten) {
  TempDir dir;
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok());
  RunRecord bad = judged_record("2026-11-22T08:00:00Z", Verdict::kIn);
  bad.characteristics[1].limits.upper = std::nan("");
  Result<std::int64_t> id = store->insert_run(bad);
  ASSERT_FALSE(id.ok());
  EXPECT_THAT(id.error().message, ::testing::HasSubstr("base_circle_runout"));
  bad = judged_record("2026-11-22T08:00:00Z", Verdict::kIn);
  bad.characteristics[2].key = bad.characteristics[0].key;
  id = store->insert_run(bad);
  ASSERT_FALSE(id.ok());
  EXPECT_THAT(id.error().message, ::testing::HasSubstr("given twice"));
  Result<std::vector<RunSummary>> runs = store->list_runs({});
  ASSERT_TRUE(runs.ok());
  EXPECT_TRUE(runs->empty());
}

// Version 9 to 10: a push may have no run behind it (a program written from the drawing). The
// pushes, pending tables and intents a version-9 file holds are kept as they were, with their
// links, and the file then takes a push of run 0 and lists it.
TEST(MigrationFromV9, KeepsEveryPushAndTakesOneWithNoRun) {
  TempDir dir;
  ASSERT_NO_FATAL_FAILURE(write_old_database_with_run_5(db_in(dir), 9));
  {
    RawDb raw(db_in(dir));
    ASSERT_EQ(raw.exec("INSERT INTO nc_pushes (id, run_id, pushed_utc, nc_file, table_version, reason, program_text)"
                       " VALUES (7, 5, '2026-11-21T08:01:00Z', '/nc/CAM.SPF', 1, 'run 5', 'text 1')"),
              SQLITE_OK);
    ASSERT_EQ(raw.exec("INSERT INTO nc_pending (id, run_id, created_utc, nc_file, program_text, verdict, reason,"
                       " status, decided_utc, decided_by, push_id) VALUES (3, 5, '2026-11-21T08:01:00Z',"
                       " '/nc/CAM.SPF', 'text 1', 'hold', 'held', 'approved', '2026-11-21T08:02:00Z', 'anna', 7)"),
              SQLITE_OK);
  }
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes WHERE id = 7 AND run_id = 5 AND uuid IS NOT NULL"), 1);
  EXPECT_EQ(raw.query_int("SELECT push_id FROM nc_pending WHERE id = 3"), 7) << "the approval still names its push";
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM pragma_foreign_key_check"), 0);
  NcPush authored;
  authored.nc_file = "/nc/CAM.SPF";
  authored.reason = "new program from cam.toml by ben";
  ASSERT_TRUE(store->record_push(0, authored, "text 2").ok());
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pushes WHERE run_id IS NULL AND table_version = 2"), 1);
  Result<std::vector<NcPush>> history = store->list_pushes({});
  ASSERT_TRUE(history.ok()) << history.error().message;
  ASSERT_EQ(history->size(), 2u);
  EXPECT_EQ((*history)[0].run_id, 0);
  EXPECT_EQ((*history)[0].reason, "new program from cam.toml by ben");
  EXPECT_EQ((*history)[1].run_id, 5);
  // A run that never was is still refused: only run 0 means none.
  EXPECT_FALSE(store->record_push(99, authored, "text 3").ok());
}

TEST(MigrationFromV12, KeepsEveryPendingTableAndTakesAGearsStroke) {
  TempDir dir;
  ASSERT_NO_FATAL_FAILURE(write_old_database_with_run_5(db_in(dir), 12));
  {
    RawDb raw(db_in(dir));
    ASSERT_EQ(raw.exec("INSERT INTO nc_pending (id, run_id, created_utc, nc_file, program_text, verdict, reason)"
                       " VALUES (3, 5, '2026-11-21T08:01:00Z', '/nc/CAM.SPF', 'text 1', 'apply', 'approval required')"),
              SQLITE_OK);
    // Before version 13 a pending table without a run is refused.
    EXPECT_NE(raw.exec("INSERT INTO nc_pending (run_id, created_utc, nc_file, program_text, verdict)"
                       " VALUES (NULL, '2026-11-21T08:01:00Z', '/nc/G.SPF', 'x', 'apply')"),
              SQLITE_OK);
    ASSERT_EQ(raw.exec("INSERT INTO gear_runs (id, started_utc, machine, part, source, nc_file, verdict,"
                       " tolerance_class, total_max_um, total_mean_um, form_mean_um, slope_mean_abs_um)"
                       " VALUES (2, '2026-11-21T08:00:00Z', 'g1', 'gear_71', 'checker', '/nc/G.SPF', 'not_judged',"
                       " 4, 3.0, 2.5, 1.0, 0.5)"),
              SQLITE_OK);
  }
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pending WHERE id = 3 AND run_id = 5 AND gear_run_id IS NULL"), 1);
  EXPECT_EQ(raw.query_text("PRAGMA integrity_check"), "ok");
  PendingTable stroke;
  stroke.gear_run_id = 2;
  stroke.nc_file = "/nc/G.SPF";
  stroke.program_text = "stroke text";
  stroke.reason = "approval required";
  Result<std::int64_t> id = store->add_pending(stroke);
  ASSERT_TRUE(id.ok()) << id.error().message;
  Result<PendingTable> back = store->load_pending(*id);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_EQ(back->gear_run_id, 2);
  EXPECT_EQ(back->run_id, 0);
  EXPECT_EQ(raw.query_int("SELECT count(*) FROM nc_pending WHERE run_id IS NULL AND gear_run_id = 2"), 1);
  // A gear run that never was, or a table naming both a lobe run and a gear run: refused.
  stroke.gear_run_id = 9;
  Result<std::int64_t> unknown = store->add_pending(stroke);
  ASSERT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().message.find("gear run 9"), std::string::npos) << unknown.error().message;
  stroke.gear_run_id = 2;
  stroke.run_id = 5;
  EXPECT_FALSE(store->add_pending(stroke).ok());
}

TEST(MigrationFromV13, KeepsEveryRunAndTakesAPartGroundWithTheMainProgramsTable) {
  TempDir dir;
  ASSERT_NO_FATAL_FAILURE(write_old_database_with_run_5(db_in(dir), 13));
  {
    RawDb raw(db_in(dir));
    ASSERT_EQ(raw.exec("UPDATE runs SET ground_with_version = 2, ground_with_source = 'plc' WHERE id = 5"), SQLITE_OK);
    // Before version 14 the main program is no source.
    EXPECT_NE(raw.exec("UPDATE runs SET ground_with_source = 'main_program' WHERE id = 5"), SQLITE_OK);
  }
  Result<RunStore> store = RunStore::open(db_in(dir));
  ASSERT_TRUE(store.ok()) << store.error().message;
  RawDb raw(db_in(dir));
  EXPECT_EQ(raw.query_int("PRAGMA user_version"), storage_internal::latest_schema_version());
  EXPECT_EQ(raw.query_text("SELECT ground_with_source FROM runs WHERE id = 5"), "plc");
  EXPECT_EQ(raw.query_text("PRAGMA integrity_check"), "ok");
  EXPECT_EQ(raw.exec("UPDATE runs SET ground_with_source = 'main_program' WHERE id = 5"), SQLITE_OK);
  EXPECT_NE(raw.exec("UPDATE runs SET ground_with_source = 'a guess' WHERE id = 5"), SQLITE_OK) << "still checked";
  EXPECT_EQ(raw.query_text("SELECT ground_with_source FROM runs WHERE id = 5"), "main_program");
}

}  // namespace
}  // namespace gaugeloop
