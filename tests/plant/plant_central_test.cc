// The central history against a real PostgreSQL 15 cluster (tests/support/postgres_server.h):
// syncing grinders' files into it by UUID, resuming a sync stopped half way, answering the same
// queries as the local file, and the errors a user meets.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "core/tolerance.h"
#include "plant/central_history.h"
#include "plant/central_schema.h"
#include "plant/central_sync.h"
#include "storage/run_store.h"
#include "tests/support/postgres_server.h"
#include "tests/support/sample_runs.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using testing::PostgresServer;
using testing::shared_postgres;
using testing::TempDir;

using testing::has;

// Every field of a summary, numbers to 17 digits: equal texts mean equal rows.
std::string describe(const RunSummary& r) {
  auto num = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(buf);
  };
  auto opt = [&num](const std::optional<double>& v) { return v ? num(*v) : std::string("none"); };
  return std::to_string(r.id) + "|" + r.uuid + "|" + r.started_utc + "|" + r.machine + "|" + r.part + "|" +
         std::to_string(r.lobe) + "|" + r.status + "|" + std::to_string(r.revolutions) + "|" +
         std::to_string(r.degrees_captured) + "|" + num(r.max_abs_error_um) + "|" + num(r.rms_error_um) + "|" +
         num(r.repeatability_um) + "|" + r.nc_file + "|" + opt(r.phase_error_deg) + "|" + opt(r.base_circle_runout_um) +
         "|" + num(r.peak_to_valley_um) + "|" + r.settings_hash + "|" + r.note + "|" + r.raw_pruned_utc + "|" +
         r.serial + "|" + r.operator_name + "|" + std::string(verdict_name(r.verdict));
}

std::string describe(const Characteristic& c) {
  auto num = [](double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return std::string(buf);
  };
  return c.key + "|" + c.unit + "|" + num(c.value) + "|" + num(c.min) + "|" + num(c.max) + "|" +
         (c.limits.lower ? num(*c.limits.lower) : "none") + "|" + (c.limits.upper ? num(*c.limits.upper) : "none") +
         "|" + std::string(verdict_name(c.verdict)) + "|" + (c.from_deg ? std::to_string(*c.from_deg) : "none") + "|" +
         (c.to_deg ? std::to_string(*c.to_deg) : "none");
}

std::vector<std::string> rows(const Result<std::vector<RunSummary>>& runs) {
  std::vector<std::string> out;
  if (!runs.ok()) return {"error: " + runs.error().message};
  for (const RunSummary& r : *runs) out.push_back(describe(r));
  return out;
}

std::vector<std::string> rows(const Result<std::vector<RunCharacteristics>>& runs) {
  std::vector<std::string> out;
  if (!runs.ok()) return {"error: " + runs.error().message};
  for (const RunCharacteristics& r : *runs) {
    out.push_back(describe(r.run));
    for (const Characteristic& c : r.characteristics) out.push_back("  " + describe(c));
  }
  return out;
}

// A run of `part` lobe `lobe` on `machine` with characteristics and a verdict that differ from
// run to run: `i` picks the figures; odd numbers are not round in binary, so an inexact copy
// shows.
RunRecord judged_run(const std::string& part, int lobe, const std::string& machine, const std::string& started, int i) {
  RunRecord r = testing::sample_run(part, lobe, machine, started, 3.0 + 1.1 * i + 0.0123456789);
  const double phase = 0.01 * i - 0.03;
  r.characteristics.push_back(single_characteristic("phase", "deg", phase, Limits{-0.05, 0.05}));
  Characteristic zone;
  zone.key = "lift_error.opening_flank";
  zone.unit = "um";
  zone.min = -1.0 - 0.7 * i;
  zone.max = 2.0 + 0.3 * i;
  zone.value = std::abs(zone.min) > std::abs(zone.max) ? zone.min : zone.max;
  zone.limits = Limits{std::nullopt, 4.0};
  zone.verdict = judge(zone.min, zone.max, zone.limits);
  zone.from_deg = -90;
  zone.to_deg = -10;
  r.characteristics.push_back(zone);
  r.characteristics.push_back(single_characteristic("roundness", "um", 0.5 + 0.1 * i, Limits{}));
  r.verdict = combined_verdict({r.characteristics[0].verdict, zone.verdict, r.characteristics[2].verdict});
  if (i % 3 == 0) r.serial = "S-" + std::to_string(100 + i / 3);
  if (i % 4 == 1) r.operator_name = "anna";
  if (i % 5 == 2) r.note = "after the wheel change";
  return r;
}

// A grinder's file in a temporary directory.
struct Grinder {
  TempDir dir;
  std::optional<RunStore> store;
  explicit Grinder(const std::string& label) : dir(label) {
    Result<RunStore> opened = RunStore::open(dir / "gaugeloop.sqlite");
    EXPECT_TRUE(opened.ok()) << opened.error().message;
    if (opened.ok()) store.emplace(std::move(*opened));
  }
  ~Grinder() { store.reset(); }  // closed before the directory goes
};

class CentralTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(shared_postgres().running());
    url_ = shared_postgres().create_database();
    ASSERT_FALSE(url_.empty());
    database_ = url_.substr(url_.rfind('/') + 1);
  }

  // `count` runs on `machine`, lobes 1 and 2 of intake and exhaust, an hour apart from `day`;
  // every third run pushed, and an event per fourth.
  static void fill(RunStore& store, const std::string& machine, const std::string& day, int count, int first = 0) {
    for (int i = first; i < first + count; ++i) {
      char started[32];
      std::snprintf(started, sizeof started, "%sT%02d:%02d:00Z", day.c_str(), 6 + i / 4, (i % 4) * 15);
      const std::string part = i % 2 == 0 ? "intake" : "exhaust";
      Result<std::int64_t> id = store.insert_run(judged_run(part, 1 + (i / 2) % 2, machine, started, i));
      ASSERT_TRUE(id.ok()) << id.error().message;
      if (i % 3 == 0) {
        ASSERT_TRUE(store.record_nc_file(*id, "nc/CAM_" + part + ".SPF").ok());
      }
      if (i % 4 == 0) {
        EventRecord e = testing::sample_refusal_event();
        e.machine = machine;
        e.at_utc = started;
        e.run_id = *id;
        ASSERT_TRUE(store.record_event(e).ok());
      }
    }
  }

  std::string sql(const std::string& statement) const { return sql_in(database_, statement); }
  // The central schema as an older gaugeloop left it: the migrations up to version `last`.
  void make_schema_up_to(int last) const {
    sql("CREATE TABLE central_schema_version (version integer PRIMARY KEY, applied_utc text NOT NULL, "
        "description text NOT NULL)");
    for (const CentralMigration& m : central_migrations()) {
      if (m.version > last) break;
      sql(std::string(m.sql));
      sql("INSERT INTO central_schema_version VALUES (" + std::to_string(m.version) + ", '2026-11-01T00:00:00Z', 'v')");
    }
  }
  static std::string sql_in(const std::string& database, const std::string& statement) {
    return shared_postgres().psql(database, statement);
  }
  std::int64_t count(const std::string& statement) const {
    const std::string out = sql(statement);
    return std::strtoll(out.c_str(), nullptr, 10);
  }
  // The central history's rows, without the time of the sync: equal after equal syncs.
  std::string contents() const { return contents_of(database_); }
  static std::string contents_of(const std::string& db) {
    auto sql = [&db](const std::string& statement) { return sql_in(db, statement); };
    return sql("SELECT uuid, source_machine, local_id, started_utc, machine, part, lobe, status, nc_file, "
               "max_abs_error_um, verdict, serial FROM runs ORDER BY uuid") +
           "\n" + sql("SELECT * FROM run_characteristics ORDER BY run_uuid, position") + "\n" +
           sql("SELECT uuid, run_uuid, local_id, nc_file, table_version FROM nc_pushes ORDER BY uuid") + "\n" +
           sql("SELECT uuid, local_id, at_utc, machine, message FROM events ORDER BY uuid") + "\n" +
           sql("SELECT machine, table_name, last_local_id, last_uuid FROM sync_progress ORDER BY 1, 2");
  }

  std::string url_;
  std::string database_;
};

// ---- sync ----

TEST_F(CentralTest, TwoGrindersFilesMeetInOneCentralHistoryEachRunOnceByUuid) {
  Grinder g1("central-g1");
  Grinder g2("central-g2");
  fill(*g1.store, "g1", "2026-11-20", 9);
  fill(*g2.store, "g2", "2026-11-20", 6);

  Result<CentralSyncCounts> first = sync_to_central(*g1.store, url_, "g1");
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_EQ(first->runs.inserted, 9);
  EXPECT_EQ(first->runs.already_there, 0);
  EXPECT_EQ(first->pushes.inserted, 3);
  EXPECT_EQ(first->events.inserted, 3);
  EXPECT_TRUE(first->caught_up);
  Result<CentralSyncCounts> second = sync_to_central(*g2.store, url_, "g2");
  ASSERT_TRUE(second.ok()) << second.error().message;
  EXPECT_EQ(second->runs.inserted, 6);

  EXPECT_EQ(count("SELECT count(*) FROM runs"), 15);
  EXPECT_EQ(count("SELECT count(DISTINCT uuid) FROM runs"), 15);
  EXPECT_EQ(count("SELECT count(*) FROM runs WHERE machine = 'g2' AND source_machine = 'g2'"), 6);
  EXPECT_EQ(count("SELECT count(*) FROM run_characteristics"), 45);
  EXPECT_EQ(count("SELECT count(*) FROM nc_pushes"), 5);
  EXPECT_EQ(count("SELECT count(*) FROM events"), 5);
  // Both files number their runs from 1: the central history keeps both run 1s apart.
  EXPECT_EQ(count("SELECT count(*) FROM runs WHERE local_id = 1"), 2);

  // Nothing new: a second sync of each copies nothing and reads nothing twice.
  const std::string before = contents();
  Result<CentralSyncCounts> again = sync_to_central(*g1.store, url_, "g1");
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->runs.inserted + again->pushes.inserted + again->events.inserted, 0);
  EXPECT_EQ(again->batches, 0);
  EXPECT_EQ(contents(), before);

  // Read from the start again, every record is found by its UUID.
  CentralSyncOptions from_start;
  from_start.from_start = true;
  Result<CentralSyncCounts> whole = sync_to_central(*g2.store, url_, "g2", from_start);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  EXPECT_EQ(whole->runs.inserted, 0);
  EXPECT_EQ(whole->runs.already_there, 6);
  EXPECT_EQ(whole->pushes.already_there, 2);
  EXPECT_EQ(count("SELECT count(*) FROM runs"), 15);

  // Each machine's runs answer as its own file does.
  Result<CentralHistory> central = CentralHistory::open(url_);
  ASSERT_TRUE(central.ok()) << central.error().message;
  for (auto* g : {&g1, &g2}) {
    RunQuery q;
    q.machine = g == &g1 ? "g1" : "g2";
    EXPECT_EQ(rows(central->list_runs(q)), rows(g->store->list_runs(q))) << q.machine;
  }
}

TEST_F(CentralTest, ASyncStoppedHalfWayResumesToTheSameContentsAsOneWhole) {
  Grinder g("central-resume");
  fill(*g.store, "g1", "2026-11-21", 11);

  // The reference: one whole sync into a database of its own.
  const std::string reference_url = shared_postgres().create_database();
  Result<CentralSyncCounts> whole = sync_to_central(*g.store, reference_url, "g1");
  ASSERT_TRUE(whole.ok()) << whole.error().message;

  // Batches of 3 runs; the third batch fails before its commit (the server went away, the
  // process was killed): the first two batches are there, nothing of the third.
  CentralSyncOptions failing;
  failing.batch_size = 3;
  failing.before_commit = [](std::string_view, int batch) -> Status {
    if (batch == 3) return make_error(ErrorCode::kStorage, "the sync was stopped");
    return {};
  };
  Result<CentralSyncCounts> broken = sync_to_central(*g.store, url_, "g1", failing);
  ASSERT_FALSE(broken.ok());
  EXPECT_TRUE(has(broken.error().message, "the 2 batches before it are in the central history"))
      << broken.error().message;
  EXPECT_EQ(count("SELECT count(*) FROM runs"), 6);
  EXPECT_EQ(count("SELECT count(*) FROM run_characteristics"), 18);
  EXPECT_EQ(count("SELECT last_local_id FROM sync_progress WHERE table_name = 'runs'"), 6);

  // One more batch only (a sync limited to one transaction): not caught up.
  CentralSyncOptions one;
  one.batch_size = 3;
  one.max_batches = 1;
  Result<CentralSyncCounts> step = sync_to_central(*g.store, url_, "g1", one);
  ASSERT_TRUE(step.ok()) << step.error().message;
  EXPECT_FALSE(step->caught_up);
  EXPECT_EQ(step->runs.inserted, 3);
  EXPECT_EQ(count("SELECT count(*) FROM runs"), 9);

  // The rest: exactly what was missing, and then the same central history as the whole sync.
  CentralSyncOptions rest;
  rest.batch_size = 3;
  Result<CentralSyncCounts> resumed = sync_to_central(*g.store, url_, "g1", rest);
  ASSERT_TRUE(resumed.ok()) << resumed.error().message;
  EXPECT_TRUE(resumed->caught_up);
  EXPECT_EQ(resumed->runs.inserted, 2);
  EXPECT_EQ(resumed->runs.already_there, 0);
  EXPECT_EQ(resumed->pushes.inserted, 4);
  EXPECT_EQ(resumed->events.inserted, 3);
  const std::string reference_db = reference_url.substr(reference_url.rfind('/') + 1);
  const std::string got = contents();
  EXPECT_EQ(got, contents_of(reference_db));
  EXPECT_TRUE(has(got, "g1|runs|11|")) << got;
}

TEST_F(CentralTest, AServerThatGoesAwayDuringASyncLosesOnlyTheBatchUnderWay) {
  // A server of its own: this test stops it.
  PostgresServer server;
  ASSERT_EQ(server.start(), "");
  const std::string url = server.create_database();
  ASSERT_FALSE(url.empty());
  const std::string db = url.substr(url.rfind('/') + 1);
  Grinder g("central-server-gone");
  fill(*g.store, "g1", "2026-11-21", 10);

  CentralSyncOptions dying;
  dying.batch_size = 4;
  dying.before_commit = [&server](std::string_view, int batch) -> Status {
    if (batch == 2) {
      EXPECT_EQ(server.kill_server(), "");
    }
    return {};
  };
  Result<CentralSyncCounts> broken = sync_to_central(*g.store, url, "g1", dying);
  ASSERT_FALSE(broken.ok());
  EXPECT_EQ(broken.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(has(broken.error().message, "was lost")) << broken.error().message;
  EXPECT_TRUE(has(broken.error().message, "the batch before it is in the central history")) << broken.error().message;

  ASSERT_EQ(server.start_again(), "");
  EXPECT_EQ(server.psql(db, "SELECT count(*) FROM runs"), "4");
  Result<CentralSyncCounts> resumed = sync_to_central(*g.store, url, "g1");
  ASSERT_TRUE(resumed.ok()) << resumed.error().message;
  EXPECT_EQ(resumed->runs.inserted, 6);
  EXPECT_EQ(resumed->runs.already_there, 0);
  EXPECT_EQ(server.psql(db, "SELECT count(*), count(DISTINCT uuid) FROM runs"), "10|10");
  EXPECT_EQ(server.psql(db, "SELECT count(*) FROM run_characteristics"), "30");
}

TEST_F(CentralTest, ANoteTypedInAnotherEncodingSyncsWithItsStrayBytesReplaced) {
  // "Maß" typed on a Latin-1 terminal: PostgreSQL refuses bytes that are not UTF-8, and would
  // refuse this run at every sync if they went in as they are.
  Grinder g("latin1");
  RunRecord r = testing::sample_run("intake", 1, "g1", "2026-11-22T08:00:00Z", 5.0);
  r.note =
      "Ma\xDF gepr\xFC"
      "ft";
  ASSERT_TRUE(g.store->insert_run(r).ok());
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url_, "g1");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->runs.inserted, 1);
  EXPECT_EQ(shared_postgres().psql(database_, "SELECT note FROM runs"),
            "Ma\xEF\xBF\xBD gepr\xEF\xBF\xBD"
            "ft");
}

TEST_F(CentralTest, ARunPushedAfterItWasSyncedIsPushedInTheCentralHistoryToo) {
  Grinder g("central-pushed-later");
  ASSERT_TRUE(g.store->insert_run(judged_run("intake", 1, "g1", "2026-11-22T08:00:00Z", 1)).ok());
  ASSERT_TRUE(sync_to_central(*g.store, url_, "g1").ok());
  EXPECT_EQ(sql("SELECT status || coalesce(nc_file, '-') FROM runs"), "measured-");
  ASSERT_TRUE(g.store->record_nc_file(1, "nc/A.SPF").ok());
  ASSERT_TRUE(g.store->record_nc_file(1, "nc/B.SPF").ok());
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url_, "g1");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pushes.inserted, 2);
  Result<CentralHistory> central = CentralHistory::open(url_);
  ASSERT_TRUE(central.ok()) << central.error().message;
  EXPECT_EQ(rows(central->list_runs(RunQuery{})), rows(g.store->list_runs(RunQuery{})));
  EXPECT_EQ(sql("SELECT status || ' ' || nc_file FROM runs"), "pushed nc/B.SPF");
}

// A push's program text is copied when asked (--programs): not by a plain sync; a later sync
// with programs gives the pushes copied without it their text, without counting them as new or
// copying anything twice.
TEST_F(CentralTest, ProgramTextsAreCopiedWhenAskedAndGivenToPushesCopiedWithout) {
  Grinder g("central-programs");
  Result<std::int64_t> run = g.store->insert_run(judged_run("intake", 1, "g1", "2026-11-22T08:00:00Z", 1));
  ASSERT_TRUE(run.ok()) << run.error().message;
  const std::string v1 =
      "; CAM_INTAKE_L1 version 1\r\nCTABDEF(1,1)\r\nC0 X0\r\n\tN10 ; a tab, a \\ and a \"\r\nCTABEND\r\n";
  NcPush push;
  push.nc_file = "nc/CAM_INTAKE_L1.SPF";
  ASSERT_TRUE(g.store->record_push(*run, push, v1).ok());
  ASSERT_TRUE(sync_to_central(*g.store, url_, "g1").ok());
  EXPECT_EQ(count("SELECT count(*) FROM nc_pushes WHERE program_text IS NULL"), 1) << "not asked";
  // Texts compared as hex: psql's output would lose a last line end.
  auto hex_of = [](const std::string& text) {
    static const char* const kDigits = "0123456789abcdef";
    std::string hex;
    for (const unsigned char c : text) {
      hex += kDigits[c >> 4];
      hex += kDigits[c & 15];
    }
    return hex;
  };
  auto text_of_version = [this](int version) {
    return sql("SELECT encode(convert_to(program_text, 'UTF8'), 'hex') FROM nc_pushes WHERE table_version = " +
               std::to_string(version));
  };

  const std::string v2 = "; CAM_INTAKE_L1 version 2\r\nCTABDEF(1,1)\r\nC0 X0.001\r\nCTABEND\r\n";
  ASSERT_TRUE(g.store->record_push(*run, push, v2).ok());
  CentralSyncOptions with;
  with.programs = true;
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url_, "g1", with);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pushes.inserted, 1);
  EXPECT_EQ(text_of_version(2), hex_of(v2)) << "the text byte for byte";
  EXPECT_EQ(count("SELECT count(*) FROM nc_pushes WHERE program_text IS NULL"), 1) << "the first, copied before";

  with.from_start = true;
  s = sync_to_central(*g.store, url_, "g1", with);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pushes.inserted, 0);
  EXPECT_EQ(s->pushes.already_there, 2);
  EXPECT_EQ(count("SELECT count(*) FROM nc_pushes"), 2);
  EXPECT_EQ(count("SELECT count(*) FROM nc_pushes WHERE program_text IS NULL"), 0);
  EXPECT_EQ(text_of_version(1), hex_of(v1)) << "the text byte for byte";
}

// The numbers of a float8 array PostgreSQL printed (array_to_string, ' '): PostgreSQL prints
// the shortest text that reads back as the same double, so equal numbers mean an exact copy.
std::vector<double> numbers_in(const std::string& text) {
  std::vector<double> out;
  const char* p = text.c_str();
  char* end = nullptr;
  for (double v = std::strtod(p, &end); end != p; v = std::strtod(p, &end)) {
    out.push_back(v);
    p = end;
  }
  return out;
}

std::vector<double> as_vector(const DegreeTable& t) { return {t.begin(), t.end()}; }

// A run's per-degree tables and raw revolutions are copied when asked (--per-degree), exactly
// as the grinder's file reads them back; a later sync from the start with them gives the runs
// copied without them theirs.
TEST_F(CentralTest, PerDegreeTablesAreCopiedWhenAskedExactlyAndGivenToRunsCopiedWithout) {
  Grinder g("central-per-degree");
  fill(*g.store, "g1", "2026-11-22", 2);
  ASSERT_TRUE(sync_to_central(*g.store, url_, "g1").ok());
  EXPECT_EQ(count("SELECT count(*) FROM run_tables"), 0) << "not asked";
  EXPECT_EQ(count("SELECT count(*) FROM run_raw"), 0) << "not asked";

  fill(*g.store, "g1", "2026-11-22", 1, 2);
  CentralSyncOptions with;
  with.per_degree = true;
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url_, "g1", with);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->runs.inserted, 1);
  EXPECT_EQ(count("SELECT count(*) FROM run_tables"), 1) << "the new run's";
  EXPECT_EQ(count("SELECT count(*) FROM run_raw"), 1);

  with.from_start = true;
  s = sync_to_central(*g.store, url_, "g1", with);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->runs.inserted, 0);
  EXPECT_EQ(s->runs.already_there, 3);
  EXPECT_EQ(count("SELECT count(*) FROM run_tables"), 3) << "given to the runs copied before";
  EXPECT_EQ(count("SELECT count(*) FROM run_raw"), 3);

  for (std::int64_t id = 1; id <= 3; ++id) {
    Result<StoredRun> run = g.store->load_run(id);
    ASSERT_TRUE(run.ok()) << run.error().message;
    const std::string where = " WHERE run_uuid = '" + run->summary.uuid + "'";
    auto column = [&](const std::string& name, const std::string& table) {
      return numbers_in(sql("SELECT array_to_string(" + name + ", ' ') FROM " + table + where));
    };
    const LobeAnalysis& a = run->analysis;
    EXPECT_EQ(column("design_lift_mm", "run_tables"), as_vector(a.design_lift_mm)) << "run " << id;
    EXPECT_EQ(column("mean_lift_mm", "run_tables"), as_vector(a.mean_lift_mm)) << "run " << id;
    EXPECT_EQ(column("spread_um", "run_tables"), as_vector(a.spread_um)) << "run " << id;
    EXPECT_EQ(column("error_um", "run_tables"), as_vector(a.error_um)) << "run " << id;
    EXPECT_EQ(column("correction_um", "run_tables"), as_vector(run->correction_um)) << "run " << id;
    EXPECT_EQ(column("residual_error_um", "run_tables"), as_vector(a.residual_error_um)) << "run " << id;
    // Revolution by revolution: lift_mm[r][d] is revolution r's reading at degree d of C.
    std::vector<double> lift;
    std::vector<double> counts;
    for (const RevolutionSamples& rev : run->revolutions) {
      lift.insert(lift.end(), rev.lift_mm.begin(), rev.lift_mm.end());
      counts.push_back(static_cast<double>(rev.revolution));
    }
    ASSERT_EQ(run->revolutions.size(), 3u);
    EXPECT_EQ(column("lift_mm", "run_raw"), lift) << "run " << id;
    EXPECT_EQ(column("amplifier_revolutions", "run_raw"), counts) << "run " << id;
    EXPECT_EQ(sql("SELECT array_length(lift_mm, 1) || 'x' || array_length(lift_mm, 2) FROM run_raw" + where), "3x360");
    // Degree 91 of the error as SQL reads it: index d + 1.
    EXPECT_EQ(numbers_in(sql("SELECT error_um[91] FROM run_tables" + where)), std::vector<double>{a.error_um[90]});
  }
}

// A prune on the grinder (runs prune) after its runs were copied is followed: the runs are
// marked pruned at the prune's time and their raw revolutions deleted, by a sync with or
// without the per-degree tables, once; a run pruned before it was copied comes marked and
// without them; a sync from the start does not send the prunes' progress back.
TEST_F(CentralTest, TheGrindersPrunesAreFollowedOnce) {
  Grinder g("central-prunes");
  fill(*g.store, "g1", "2026-11-20", 2);     // runs 1 and 2
  fill(*g.store, "g1", "2026-11-22", 2, 2);  // runs 3 and 4
  CentralSyncOptions with;
  with.per_degree = true;
  ASSERT_TRUE(sync_to_central(*g.store, url_, "g1", with).ok());
  EXPECT_EQ(count("SELECT count(*) FROM run_raw"), 4);

  ASSERT_TRUE(g.store->prune_raw_samples("2026-11-21T00:00:00Z", "2026-11-25T00:00:00Z").ok());
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url_, "g1", with);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pruned, 2);
  EXPECT_EQ(sql("SELECT string_agg(local_id || ':' || coalesce(raw_pruned_utc, '-'), ' ' ORDER BY local_id) FROM runs"),
            "1:2026-11-25T00:00:00Z 2:2026-11-25T00:00:00Z 3:- 4:-");
  EXPECT_EQ(sql("SELECT string_agg(r.local_id::text, ' ' ORDER BY r.local_id) FROM run_raw JOIN runs AS r ON "
                "r.uuid = run_raw.run_uuid"),
            "3 4");
  EXPECT_EQ(count("SELECT count(*) FROM run_tables"), 4) << "the tables stay";
  Result<CentralHistory> central = CentralHistory::open(url_);
  ASSERT_TRUE(central.ok()) << central.error().message;
  EXPECT_EQ(rows(central->list_runs(RunQuery{})), rows(g.store->list_runs(RunQuery{})));

  s = sync_to_central(*g.store, url_, "g1", with);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pruned, 0) << "followed once";

  // A plain sync follows them too; a run pruned before its copy comes marked, without raw.
  fill(*g.store, "g1", "2026-11-23", 1, 4);  // run 5, not copied yet
  ASSERT_TRUE(g.store->prune_raw_samples("2026-11-24T00:00:00Z", "2026-11-26T00:00:00Z").ok());
  s = sync_to_central(*g.store, url_, "g1");
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->runs.inserted, 1);
  EXPECT_EQ(s->pruned, 2) << "runs 3 and 4; run 5 came marked";
  EXPECT_EQ(count("SELECT count(*) FROM run_raw"), 0);
  EXPECT_EQ(count("SELECT count(*) FROM runs WHERE raw_pruned_utc = '2026-11-26T00:00:00Z'"), 3);
  const std::string through =
      "SELECT pruned_through_utc || ' ' || pruned_through_id FROM sync_progress WHERE "
      "table_name = 'runs'";
  EXPECT_EQ(sql(through), "2026-11-26T00:00:00Z 5");

  // A sync from the start follows every prune again (finding them followed) and leaves the
  // progress where it was ahead of it.
  sql("UPDATE sync_progress SET pruned_through_id = 99 WHERE table_name = 'runs'");
  CentralSyncOptions again;
  again.from_start = true;
  s = sync_to_central(*g.store, url_, "g1", again);
  ASSERT_TRUE(s.ok()) << s.error().message;
  EXPECT_EQ(s->pruned, 0);
  EXPECT_EQ(sql(through), "2026-11-26T00:00:00Z 99") << "not moved back";
  EXPECT_EQ(rows(central->list_runs(RunQuery{})), rows(g.store->list_runs(RunQuery{})));
}

TEST_F(CentralTest, AReplacedFileIsRefusedUntilSyncedFromTheStart) {
  auto g = std::make_unique<Grinder>("central-replaced");
  fill(*g->store, "g1", "2026-11-22", 4);
  ASSERT_TRUE(sync_to_central(*g->store, url_, "g1").ok());
  // The same path, a new file: its run 4 is another run than the one synced.
  const std::filesystem::path file = g->store->path();
  g->store.reset();
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(file.string() + suffix);
  {
    Result<RunStore> fresh = RunStore::open(file);
    ASSERT_TRUE(fresh.ok()) << fresh.error().message;
    g->store.emplace(std::move(*fresh));
  }
  fill(*g->store, "g1", "2026-11-23", 5, 20);
  Result<CentralSyncCounts> refused = sync_to_central(*g->store, url_, "g1");
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.error().code, ErrorCode::kRefused);
  EXPECT_TRUE(has(refused.error().message, "holds another run under id 4")) << refused.error().message;
  EXPECT_TRUE(has(refused.error().message, "--from-start")) << refused.error().message;
  EXPECT_EQ(count("SELECT count(*) FROM runs"), 4);

  CentralSyncOptions from_start;
  from_start.from_start = true;
  Result<CentralSyncCounts> whole = sync_to_central(*g->store, url_, "g1", from_start);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  EXPECT_EQ(whole->runs.inserted, 5);
  EXPECT_EQ(count("SELECT count(*) FROM runs"), 9);
  // And the next plain sync accepts the file: its progress names the new file's records.
  Result<CentralSyncCounts> next = sync_to_central(*g->store, url_, "g1");
  ASSERT_TRUE(next.ok()) << next.error().message;
  EXPECT_EQ(next->runs.inserted, 0);
}

// A sync from the start stopped part-way keeps its own place: the plain sync's progress stays
// where it was (not sent back over what it had copied), and the next sync from the start goes
// on from where the stopped one ended.
TEST_F(CentralTest, ASyncFromTheStartStoppedPartWayResumesAndNeverMovesTheProgressBack) {
  auto g = std::make_unique<Grinder>("central-rescan");
  fill(*g->store, "g1", "2026-11-22", 10);
  ASSERT_TRUE(sync_to_central(*g->store, url_, "g1").ok());
  auto progress = [&] {
    return sql(
        "SELECT last_local_id || ' ' || coalesce(rescan_local_id::text, '-') FROM sync_progress "
        "WHERE table_name = 'runs'");
  };
  EXPECT_TRUE(has(progress(), "10 -")) << progress();

  CentralSyncOptions o;
  o.from_start = true;
  o.batch_size = 2;
  o.max_batches = 2;
  Result<CentralSyncCounts> part = sync_to_central(*g->store, url_, "g1", o);
  ASSERT_TRUE(part.ok()) << part.error().message;
  EXPECT_FALSE(part->caught_up);
  EXPECT_EQ(part->runs.already_there, 4);
  EXPECT_TRUE(has(progress(), "10 4")) << progress();

  // A plain sync meanwhile goes on from run 10: nothing to read again.
  fill(*g->store, "g1", "2026-11-23", 1, 10);
  Result<CentralSyncCounts> plain = sync_to_central(*g->store, url_, "g1");
  ASSERT_TRUE(plain.ok()) << plain.error().message;
  EXPECT_EQ(plain->runs.inserted, 1);
  EXPECT_EQ(plain->runs.already_there, 0);
  EXPECT_TRUE(has(progress(), "11 4")) << progress();

  o.max_batches = 0;
  Result<CentralSyncCounts> rest = sync_to_central(*g->store, url_, "g1", o);
  ASSERT_TRUE(rest.ok()) << rest.error().message;
  EXPECT_EQ(rest->runs.resumed_after, 4);
  EXPECT_EQ(rest->runs.already_there, 7) << "runs 5 to 11";
  EXPECT_EQ(rest->runs.inserted, 0);
  EXPECT_TRUE(has(progress(), "11 -")) << progress();

  // Finished, the next sync from the start reads the whole file again.
  Result<CentralSyncCounts> again = sync_to_central(*g->store, url_, "g1", o);
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->runs.resumed_after, 0);
  EXPECT_EQ(again->runs.already_there, 11);
  EXPECT_EQ(count("SELECT count(*) FROM runs"), 11);
}

// A central history made by a gaugeloop of schema 1 is
// brought to the latest schema by the next sync, which then keeps its progress there.
TEST_F(CentralTest, ASchemaOneHistoryIsMigratedBySyncingIntoIt) {
  const CentralMigration& v1 = central_migrations()[0];
  ASSERT_EQ(v1.version, 1);
  sql("CREATE TABLE central_schema_version (version integer PRIMARY KEY, applied_utc text NOT NULL, "
      "description text NOT NULL)");
  sql(std::string(v1.sql));
  sql("INSERT INTO central_schema_version VALUES (1, '2026-11-01T00:00:00Z', 'v1')");
  auto g = std::make_unique<Grinder>("central-v1");
  fill(*g->store, "g1", "2026-11-22", 3);
  Result<CentralSyncCounts> first = sync_to_central(*g->store, url_, "g1");
  ASSERT_TRUE(first.ok()) << first.error().message;
  EXPECT_EQ(count("SELECT max(version) FROM central_schema_version"), latest_central_schema_version());
  EXPECT_GE(latest_central_schema_version(), 2);
  EXPECT_TRUE(has(sql("SELECT last_local_id || ' ' || coalesce(rescan_local_id::text, '-') FROM sync_progress "
                      "WHERE table_name = 'runs'"),
                  "3 -"));
}

// Events name their run by the run's UUID, the central history's key, beside the file's local
// id: an event of g2's run 1 is not g1's run 1's.
TEST_F(CentralTest, EventsCarryTheirRunsUuid) {
  Grinder g1("central-ev1");
  Grinder g2("central-ev2");
  fill(*g1.store, "g1", "2026-11-20", 9);
  fill(*g2.store, "g2", "2026-11-20", 6);
  EventRecord lone = testing::sample_refusal_event();  // no run
  lone.machine = "g1";
  ASSERT_TRUE(g1.store->record_event(lone).ok());
  ASSERT_TRUE(sync_to_central(*g1.store, url_, "g1").ok());
  ASSERT_TRUE(sync_to_central(*g2.store, url_, "g2").ok());
  EXPECT_EQ(count("SELECT count(*) FROM events"), 6);
  EXPECT_EQ(count("SELECT count(*) FROM events WHERE local_run_id IS NULL AND run_uuid IS NULL"), 1);
  // Every event with a run names that run: the same file's run under the local id.
  EXPECT_EQ(count("SELECT count(*) FROM events AS e JOIN runs AS r ON r.uuid = e.run_uuid "
                  "WHERE r.source = e.source AND r.local_id = e.local_run_id"),
            5);
  EXPECT_EQ(count("SELECT count(*) FROM events AS e JOIN runs AS r ON r.uuid = e.run_uuid "
                  "WHERE r.source <> e.source OR r.local_id <> e.local_run_id"),
            0);
}

// Each filter `runs list --db` offers is an index scan in time order, with at most an
// incremental sort of the runs that tie on their start (a serial's few runs: any sort), on a history of 40,000 runs (4
// machines, 5 parts of 8 lobes, serials on a tenth, analysed) so the planner weighs it as a
// grinder's years.
TEST_F(CentralTest, EveryListFilterIsServedByAnIndexInTimeOrder) {
  auto g = std::make_unique<Grinder>("central-plans");
  fill(*g->store, "g1", "2026-11-22", 2);
  ASSERT_TRUE(sync_to_central(*g->store, url_, "g1").ok());
  EXPECT_EQ(sql("INSERT INTO runs (uuid, source_machine, source, local_id, started_utc, finished_utc, machine, part, "
                "lobe, gauge, status, revolutions, degrees_captured, polls, reconnects, discarded_revolutions, "
                "zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um, repeatability_um, inspection, "
                "verdict, serial, lift_error_reference, synced_utc) "
                "SELECT md5(i::text)::uuid::text, 'g' || (i % 4), 'f', i, to_char(timestamp '2020-01-01' + i * "
                "interval '5 min', "
                "'YYYY-MM-DD\"T\"HH24:MI:SS\"Z\"'), 'f', 'g' || (i % 4), 'p' || (i / 4 % 5), 1 + i / 20 % 8, 'g', "
                "'measured', 3, 360, 0, 0, 0, 0, 0, 0, 0, 0, false, CASE WHEN i % 7 = 0 THEN 'out' ELSE 'in' END, "
                "CASE WHEN i % 10 = 0 THEN 's' || i END, 'best_fit', 'now' FROM generate_series(1, 40000) AS i; "
                "ANALYZE runs"),
            "");
  const std::pair<const char*, const char*> filters[] = {
      {"r.part = 'p1'", "runs_by_part_started"},
      {"r.part = 'p1' AND r.lobe = 3", "runs_by_part_lobe_started"},
      {"r.machine = 'g1'", "runs_by_machine_started"},
      {"r.machine = 'g1' AND r.part = 'p1' AND r.lobe = 3", "runs_by_machine_part_lobe_started"},
      {"r.serial = 's40'", "runs_by_serial"},
      {"r.verdict = 'out'", "runs_by_verdict"},
      {"r.started_utc >= '2020-02'", "runs_by_started"},
  };
  for (const auto& [where, index] : filters) {
    const std::string plan =
        sql("EXPLAIN (COSTS OFF) SELECT * FROM runs AS r WHERE " + std::string(where) +
            " ORDER BY r.started_utc DESC, r.local_id DESC, r.source_machine DESC, r.uuid DESC LIMIT 50");
    EXPECT_NE(plan.find(index), std::string::npos) << where << "\n" << plan;
    std::string full_sorts = plan;  // what is left when the incremental sort and its keys are taken out
    for (const std::string_view allowed : {"Incremental Sort", "Sort Key", "Presorted Key"}) {
      for (std::size_t at; (at = full_sorts.find(allowed)) != std::string::npos;) full_sorts.erase(at, allowed.size());
    }
    // One serial's few runs may be sorted whole; every other filter selects a grinder's years.
    if (std::string_view(where).find("serial") != std::string_view::npos) continue;
    EXPECT_EQ(full_sorts.find("Sort"), std::string::npos) << where << ": a sort of every run it selects\n" << plan;
  }
}

// A central history of schema 2 (events without their run's UUID) is migrated by the next sync,
// and the events copied before get their runs' UUIDs from the runs copied from the same file.
TEST_F(CentralTest, ASchemaTwoHistoryGivesItsEventsTheirRunsUuid) {
  make_schema_up_to(2);
  auto g = std::make_unique<Grinder>("central-v2");
  fill(*g->store, "g1", "2026-11-22", 8);
  // What a schema-2 sync copied: the runs, and the events without run_uuid.
  const std::string source = std::filesystem::weakly_canonical(g->store->path()).string();
  Result<std::vector<StoredEvent>> events = g->store->events_after(0, 100);
  ASSERT_TRUE(events.ok()) << events.error().message;
  ASSERT_EQ(events->size(), 2u);
  for (const StoredEvent& e : *events) {
    EXPECT_EQ(
        sql("INSERT INTO runs (uuid, source_machine, source, local_id, started_utc, finished_utc, machine, part, lobe, "
            "gauge, status, revolutions, degrees_captured, polls, reconnects, discarded_revolutions, zero_offset_mm, "
            "max_abs_error_um, rms_error_um, peak_to_valley_um, repeatability_um, inspection, verdict, "
            "lift_error_reference, synced_utc) VALUES ('" +
            e.run_uuid + "', 'g1', '" + source + "', " + std::to_string(*e.event.run_id) +
            ", 's', 'f', 'g1', 'p', 1, 'g', 'measured', 3, 360, 0, 0, 0, 0, 0, 0, 0, 0, false, 'in', 'best_fit', "
            "'now')"),
        "");
    EXPECT_EQ(sql("INSERT INTO events (uuid, source_machine, source, local_id, at_utc, kind, code, machine, part, "
                  "lobe, local_run_id, message, synced_utc) VALUES ('" +
                  e.event.uuid + "', 'g1', '" + source + "', " + std::to_string(e.id) +
                  ", 'a', 'refusal', 'c', 'g1', 'p', 1, " + std::to_string(*e.event.run_id) + ", 'm', 'now')"),
              "");
  }
  ASSERT_EQ(count("SELECT count(*) FROM events"), 2);
  CentralSyncOptions from_start;
  from_start.from_start = true;
  Result<CentralSyncCounts> synced = sync_to_central(*g->store, url_, "g1", from_start);
  ASSERT_TRUE(synced.ok()) << synced.error().message;
  EXPECT_EQ(count("SELECT max(version) FROM central_schema_version"), latest_central_schema_version());
  EXPECT_EQ(count("SELECT count(*) FROM events WHERE run_uuid IS NULL"), 0);
  EXPECT_EQ(count("SELECT count(*) FROM events AS e JOIN runs AS r ON r.uuid = e.run_uuid AND r.local_id = "
                  "e.local_run_id"),
            2);
}

// A schema-4 history kept each characteristic as a row: the migration to one row of arrays a
// run keeps every value, position and NULL, and the rows read back are the file's.
TEST_F(CentralTest, ASchemaFourHistorysCharacteristicsAreTheSameRowsAfterTheMigration) {
  make_schema_up_to(4);
  auto g = std::make_unique<Grinder>("central-v4");
  fill(*g->store, "g1", "2026-11-22", 6);
  // What a schema-4 sync wrote: the runs, and each characteristic as a row, numbers exact.
  const std::string source = std::filesystem::weakly_canonical(g->store->path()).string();
  auto number = [](std::optional<double> v) {
    if (!v) return std::string("NULL");
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", *v);
    return std::string(buf);
  };
  auto integer = [](std::optional<int> v) { return v ? std::to_string(*v) : std::string("NULL"); };
  Result<std::vector<StoredRun>> runs = g->store->run_records_after(0, 100);
  ASSERT_TRUE(runs.ok()) << runs.error().message;
  ASSERT_EQ(runs->size(), 6u);
  for (const StoredRun& run : *runs) {
    const RunSummary& r = run.summary;
    EXPECT_EQ(sql("INSERT INTO runs (uuid, source_machine, source, local_id, started_utc, finished_utc, machine, "
                  "part, lobe, gauge, status, revolutions, degrees_captured, polls, reconnects, "
                  "discarded_revolutions, zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um, "
                  "repeatability_um, inspection, verdict, lift_error_reference, serial, note, operator, "
                  "synced_utc) VALUES ('" +
                  r.uuid + "', 'g1', '" + source + "', " + std::to_string(r.id) + ", '" + r.started_utc + "', 'f', '" +
                  r.machine + "', '" + r.part + "', " + std::to_string(r.lobe) + ", 'g', '" + r.status + "', " +
                  std::to_string(r.revolutions) + ", " + std::to_string(r.degrees_captured) + ", 0, 0, 0, 0, " +
                  number(r.max_abs_error_um) + ", " + number(r.rms_error_um) + ", " + number(r.peak_to_valley_um) +
                  ", " + number(r.repeatability_um) + ", false, '" + std::string(verdict_name(r.verdict)) +
                  "', 'best_fit', " + (r.serial.empty() ? "NULL" : "'" + r.serial + "'") + ", '" + r.note + "', " +
                  (r.operator_name.empty() ? "NULL" : "'" + r.operator_name + "'") + ", 'now')"),
              "");
    for (std::size_t i = 0; i < run.characteristics.size(); ++i) {
      const Characteristic& c = run.characteristics[i];
      EXPECT_EQ(
          sql("INSERT INTO run_characteristics VALUES ('" + r.uuid + "', " + std::to_string(i) + ", '" + c.key +
              "', '" + c.unit + "', " + number(c.value) + ", " + number(c.min) + ", " + number(c.max) + ", " +
              number(c.limits.lower) + ", " + number(c.limits.upper) + ", '" + std::string(verdict_name(c.verdict)) +
              "', " + integer(c.from_deg) + ", " + integer(c.to_deg) + ")"),
          "");
    }
  }
  ASSERT_EQ(count("SELECT count(*) FROM run_characteristics"), 18);
  const std::string before = sql("SELECT * FROM run_characteristics ORDER BY run_uuid, position");

  CentralSyncOptions from_start;
  from_start.from_start = true;
  Result<CentralSyncCounts> synced = sync_to_central(*g->store, url_, "g1", from_start);
  ASSERT_TRUE(synced.ok()) << synced.error().message;
  EXPECT_EQ(count("SELECT max(version) FROM central_schema_version"), latest_central_schema_version());
  EXPECT_EQ(synced->runs.already_there, 6);
  EXPECT_EQ(count("SELECT count(*) FROM run_characteristic_sets"), 6);  // one row a run
  EXPECT_EQ(sql("SELECT * FROM run_characteristics ORDER BY run_uuid, position"), before);
  Result<CentralHistory> central = CentralHistory::open(url_);
  ASSERT_TRUE(central.ok()) << central.error().message;
  // The characteristics' lines (the runs' own rows above were written by hand, in part).
  auto characteristic_lines = [](const std::vector<std::string>& lines) {
    std::vector<std::string> out;
    for (const std::string& l : lines) {
      if (l.rfind("  ", 0) == 0) out.push_back(l);
    }
    return out;
  };
  const std::vector<std::string> local = characteristic_lines(rows(g->store->characteristics(RunQuery{})));
  EXPECT_EQ(local.size(), 18u);
  EXPECT_EQ(characteristic_lines(rows(central->characteristics(RunQuery{}))), local);
}

// Deleting runs in the central history (by hand: a plant's retention) deletes their
// characteristics with them, as the foreign key's cascade did when they were rows.
TEST_F(CentralTest, DeletingARunDeletesItsCharacteristics) {
  Grinder g("central-delete");
  fill(*g.store, "g1", "2026-11-20", 4);
  ASSERT_TRUE(sync_to_central(*g.store, url_, "g1").ok());
  ASSERT_EQ(count("SELECT count(*) FROM run_characteristics"), 12);
  EXPECT_EQ(sql("DELETE FROM nc_pushes; DELETE FROM events; DELETE FROM runs WHERE local_id <= 2"), "");
  EXPECT_EQ(count("SELECT count(*) FROM run_characteristics"), 6);
  EXPECT_EQ(count("SELECT count(*) FROM run_characteristics AS c LEFT JOIN runs AS r ON r.uuid = c.run_uuid "
                  "WHERE r.uuid IS NULL"),
            0);
}

// A characteristic's key and unit are copied as they are, whatever they hold: the quotes,
// backslashes, commas and braces an array literal gives meaning to, tabs and new lines that
// COPY does, and a run without characteristics.
TEST_F(CentralTest, CharacteristicTextsWithTheCharactersCopyAndArraysUseArriveAsTheyAre) {
  Grinder g("central-odd-texts");
  RunRecord odd = judged_run("intake", 1, "g1", "2026-11-20T06:00:00Z", 1);
  odd.characteristics[0].key = R"(zone "A", {nose}\flank)";
  odd.characteristics[0].unit = "um\tper\nmm NULL";
  odd.characteristics[1].key = "NULL";
  odd.characteristics[2].key = "{}";
  Result<std::int64_t> stored = g.store->insert_run(odd);
  ASSERT_TRUE(stored.ok()) << stored.error().message;
  RunRecord none = judged_run("intake", 1, "g1", "2026-11-20T07:00:00Z", 2);
  none.characteristics.clear();
  none.verdict = Verdict::kNotJudged;
  ASSERT_TRUE(g.store->insert_run(none).ok());
  Result<CentralSyncCounts> synced = sync_to_central(*g.store, url_, "g1");
  ASSERT_TRUE(synced.ok()) << synced.error().message;
  EXPECT_EQ(synced->runs.inserted, 2);
  Result<CentralHistory> central = CentralHistory::open(url_);
  ASSERT_TRUE(central.ok()) << central.error().message;
  const std::vector<std::string> local = rows(g.store->characteristics(RunQuery{}));
  EXPECT_EQ(rows(central->characteristics(RunQuery{})), local);
  ASSERT_EQ(local.size(), 5u);  // two runs, three characteristics of the first
  EXPECT_TRUE(has(local[1], R"(zone "A", {nose}\flank|um)")) << local[1];
  EXPECT_EQ(count("SELECT count(*) FROM run_characteristic_sets"), 1);
}

// ---- queries ----

TEST_F(CentralTest, EveryQueryAnswersWithTheLocalFilesRowsInItsOrder) {
  Grinder g("central-queries");
  // Two machines in one file, and runs that tie on their start time.
  fill(*g.store, "g1", "2026-11-20", 14);
  fill(*g.store, "g2", "2026-11-20", 10, 3);
  fill(*g.store, "g2", "2026-11-21", 5, 7);
  ASSERT_TRUE(sync_to_central(*g.store, url_, "cell-1").ok());
  Result<CentralHistory> central = CentralHistory::open(url_);
  ASSERT_TRUE(central.ok()) << central.error().message;

  std::vector<RunQuery> queries;
  queries.push_back(RunQuery{});
  RunQuery q;
  q.machine = "g2";
  queries.push_back(q);
  q = {};
  q.part = "intake";
  q.lobe = 1;
  queries.push_back(q);
  q.machine = "g1";
  q.limit = 2;
  queries.push_back(q);
  q = {};
  q.verdict = Verdict::kOut;
  queries.push_back(q);
  q.verdict = Verdict::kIn;
  q.part = "exhaust";
  queries.push_back(q);
  q = {};
  q.since_utc = "2026-11-20T08:00:00Z";
  q.until_utc = "2026-11-21T07:00:00Z";
  queries.push_back(q);
  q.limit = 3;
  q.status = "pushed";
  queries.push_back(q);
  q = {};
  q.serial = "S-101";
  queries.push_back(q);
  q = {};
  q.status = "measured";
  q.lobe = 2;
  q.limit = 4;
  queries.push_back(q);
  q = {};
  q.part = "nothing";
  queries.push_back(q);

  for (const RunQuery& query : queries) {
    const std::string what = "part " + query.part + " lobe " + std::to_string(query.lobe) + " machine " +
                             query.machine + " limit " + std::to_string(query.limit) + " status " + query.status +
                             " since " + query.since_utc + " until " + query.until_utc;
    const std::vector<std::string> local_list = rows(g.store->list_runs(query));
    EXPECT_EQ(rows(central->list_runs(query)), local_list) << what;
    EXPECT_EQ(rows(central->trend(query)), rows(g.store->trend(query))) << what;
    EXPECT_EQ(rows(central->characteristics(query)), rows(g.store->characteristics(query))) << what;
    EXPECT_EQ(rows(central->characteristics(query, "lift_error")), rows(g.store->characteristics(query, "lift_error")))
        << what;
  }
  // The comparison compares something: the queries select different, non-empty sets.
  EXPECT_EQ(rows(g.store->list_runs(queries[0])).size(), 29u);
  EXPECT_EQ(rows(g.store->list_runs(queries[3])).size(), 2u);
  EXPECT_FALSE(rows(g.store->list_runs(queries[4])).empty());

  // A bad query: the same error, the same words.
  for (auto bad : {+[](RunQuery& b) { b.limit = 0; }, +[](RunQuery& b) { b.since_utc = "yesterday"; },
                   +[](RunQuery& b) { b.status = "lost"; }, +[](RunQuery& b) { b.lobe = -1; }}) {
    RunQuery b;
    bad(b);
    Result<std::vector<RunSummary>> local = g.store->list_runs(b);
    Result<std::vector<RunSummary>> remote = central->list_runs(b);
    ASSERT_FALSE(local.ok());
    ASSERT_FALSE(remote.ok());
    EXPECT_EQ(remote.error().code, local.error().code);
    EXPECT_EQ(remote.error().message, local.error().message);
  }
}

// ---- errors ----

TEST_F(CentralTest, AServerNobodyListensOnIsAClearErrorAndNothingIsWritten) {
  Grinder g("central-unreachable");
  fill(*g.store, "g1", "2026-11-20", 2);
  const int port = testing::free_loopback_port();
  const std::string url = "postgresql://postgres@127.0.0.1:" + std::to_string(port) + "/plant";
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url, "g1");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kStorage);
  const std::string& m = s.error().message;
  EXPECT_TRUE(has(m, "cannot reach the central history at host 127.0.0.1 port " + std::to_string(port))) << m;
  EXPECT_TRUE(has(m, "check that PostgreSQL runs there")) << m;
  Result<CentralHistory> h = CentralHistory::open(url);
  ASSERT_FALSE(h.ok());
  EXPECT_TRUE(has(h.error().message, "port " + std::to_string(port))) << h.error().message;
}

TEST_F(CentralTest, AUrlItCannotUseIsRefusedNamingTheWrongPart) {
  struct Case {
    std::string url;
    std::string says;
  };
  const std::vector<Case> cases = {
      {"mysql://db/plant", "the scheme 'mysql' is not postgresql"},
      {"/var/lib/gaugeloop/gaugeloop.sqlite", "it is not a URL"},
      {"postgresql://central:99999/plant", "the port '99999' is not 1 to 65535"},
      {"postgresql://central:http/plant", "the port 'http' is not 1 to 65535"},
      {"postgresql://central:5432", "the database name after the host is missing"},
      {"postgresql://central:5432/", "the database name after the host is missing"},
  };
  for (const Case& c : cases) {
    Result<CentralUrl> u = parse_central_url(c.url);
    ASSERT_FALSE(u.ok()) << c.url;
    EXPECT_EQ(u.error().code, ErrorCode::kInvalidInput);
    EXPECT_TRUE(has(u.error().message, c.says)) << u.error().message;
    EXPECT_TRUE(has(u.error().message, "postgresql://USER@HOST:PORT/DATABASE")) << u.error().message;
    Result<CentralHistory> h = CentralHistory::open(c.url);
    ASSERT_FALSE(h.ok());
    EXPECT_EQ(h.error().code, ErrorCode::kInvalidInput);
  }
  // A password is never shown.
  Result<CentralUrl> secret = parse_central_url("postgresql://anna:s3cret@central:0/plant");
  ASSERT_FALSE(secret.ok());
  EXPECT_FALSE(has(secret.error().message, "s3cret")) << secret.error().message;
  EXPECT_TRUE(has(secret.error().message, "postgresql://anna:***@central:0/plant")) << secret.error().message;
  Result<CentralUrl> good = parse_central_url("postgres://anna:s3cret@[::1]:6543/plant?sslmode=disable");
  ASSERT_TRUE(good.ok()) << good.error().message;
  EXPECT_EQ(good->host, "::1");
  EXPECT_EQ(good->port, "6543");
  EXPECT_EQ(good->database, "plant");
  EXPECT_EQ(good->shown, "postgres://anna:***@[::1]:6543/plant?sslmode=disable");
  EXPECT_EQ(good->url, "postgres://anna:s3cret@[::1]:6543/plant?sslmode=disable&connect_timeout=10");
  EXPECT_TRUE(good->has_password);
  // Nor one given as a parameter.
  Result<CentralUrl> in_query = parse_central_url("postgresql://anna@central/plant?sslmode=require&password=s3cret");
  ASSERT_TRUE(in_query.ok()) << in_query.error().message;
  EXPECT_EQ(in_query->shown, "postgresql://anna@central/plant?sslmode=require&password=***");
  EXPECT_TRUE(in_query->has_password);
  Result<CentralUrl> none = parse_central_url("postgresql://anna@central/plant?passfile=/etc/gaugeloop/pgpass");
  ASSERT_TRUE(none.ok()) << none.error().message;
  EXPECT_FALSE(none->has_password);
  EXPECT_EQ(none->shown, "postgresql://anna@central/plant?passfile=/etc/gaugeloop/pgpass");
}

TEST_F(CentralTest, ACentralSchemaNewerThanThisGaugeloopIsRefused) {
  Grinder g("central-newer");
  fill(*g.store, "g1", "2026-11-20", 2);
  // An empty database is no central history yet: the queries say to sync first.
  Result<CentralHistory> empty = CentralHistory::open(url_);
  ASSERT_FALSE(empty.ok());
  EXPECT_TRUE(has(empty.error().message, "holds no central history yet")) << empty.error().message;
  EXPECT_TRUE(has(empty.error().message, "gaugeloop plant sync --to")) << empty.error().message;

  ASSERT_TRUE(sync_to_central(*g.store, url_, "g1").ok());
  EXPECT_EQ(count("SELECT max(version) FROM central_schema_version"), latest_central_schema_version());
  const int newer = latest_central_schema_version() + 1;
  sql("INSERT INTO central_schema_version VALUES (" + std::to_string(newer) + ", '2027-01-01T00:00:00Z', 'later')");
  Result<CentralHistory> h = CentralHistory::open(url_);
  ASSERT_FALSE(h.ok());
  EXPECT_EQ(h.error().code, ErrorCode::kStorage);
  EXPECT_TRUE(
      has(h.error().message, "has schema version " + std::to_string(newer) + ", newer than this gaugeloop understands"))
      << h.error().message;
  fill(*g.store, "g1", "2026-11-21", 1, 5);
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url_, "g1");
  ASSERT_FALSE(s.ok());
  EXPECT_TRUE(has(s.error().message, "newer than this gaugeloop understands")) << s.error().message;
  EXPECT_EQ(count("SELECT count(*) FROM runs"), 2);
}

TEST_F(CentralTest, AGrindersUserWithoutCreateSyncsIntoASchemaAnAdministratorMade) {
  Grinder g("central-privileges");
  fill(*g.store, "g1", "2026-11-20", 3);
  const std::string role = "grinder_" + database_.substr(1, database_.find('_') - 1);
  sql("CREATE ROLE " + role + " LOGIN");
  const std::string grinder_url = "postgresql://" + role + "@" + url_.substr(url_.find("@") + 1);
  // PostgreSQL 15 gives nobody CREATE on the public schema: the grinder cannot make the tables.
  Result<CentralSyncCounts> refused = sync_to_central(*g.store, grinder_url, "g1");
  ASSERT_FALSE(refused.ok());
  EXPECT_TRUE(has(refused.error().message, "migrate the central history to schema version 1"))
      << refused.error().message;
  EXPECT_TRUE(has(refused.error().message, "permission denied")) << refused.error().message;

  Grinder admin("central-privileges-admin");
  ASSERT_TRUE(sync_to_central(*admin.store, url_, "admin").ok());  // an empty file: the schema only
  sql("GRANT SELECT, INSERT, UPDATE ON ALL TABLES IN SCHEMA public TO " + role);
  Result<CentralSyncCounts> synced = sync_to_central(*g.store, grinder_url, "g1");
  ASSERT_TRUE(synced.ok()) << synced.error().message;
  EXPECT_EQ(synced->runs.inserted, 3);
  Result<CentralHistory> read = CentralHistory::open(grinder_url);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(rows(read->list_runs(RunQuery{})), rows(g.store->list_runs(RunQuery{})));
}

TEST_F(CentralTest, AMachineNameOrBatchSizeItCannotUseIsRefusedBeforeConnecting) {
  Grinder g("central-bad-options");
  Result<CentralSyncCounts> nameless = sync_to_central(*g.store, url_, "");
  ASSERT_FALSE(nameless.ok());
  EXPECT_TRUE(has(nameless.error().message, "--machine")) << nameless.error().message;
  CentralSyncOptions zero;
  zero.batch_size = 0;
  Result<CentralSyncCounts> s = sync_to_central(*g.store, url_, "g1", zero);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(count("SELECT count(*) FROM pg_tables WHERE tablename = 'runs'"), 0);
}

}  // namespace
}  // namespace gaugeloop
