// Storage benchmarks (figures and the command: docs/PERFORMANCE.md, "Storage"):
//  - storing one run (3 x 360 raw samples, profile, correction, figures) through
//    RunStore::insert_run, against a baseline in the same run: a bare sqlite3 INSERT of the
//    same number of bytes as one BLOB, in its own durable transaction, on the same file system;
//  - on a database of 100,000 runs (GAUGELOOP_BENCH_RUNS; built once, in one transaction, and
//    cached): the last 50 runs of a lobe, of a verdict no run has, a 30-day trend of a lobe, SPC
//    of a lobe and one whole run, each through RunStore as the command line does, against a
//    baseline: a bare SELECT of one runs row by primary key;
//  - bytes stored per run, for this schema (version 2) and for version 1's layout.
//
// GAUGELOOP_BENCH_DB: where the database is kept between runs (default:
// <tmp>/gaugeloop-bench-<runs>.sqlite); delete it to rebuild.
#include <benchmark/benchmark.h>
#include <sqlite3.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include "storage/degree_blob.h"
#include "storage/migrations.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

constexpr int kMachines = 4;
constexpr int kParts = 5;
constexpr int kLobes = 8;                           // per part: 160 lobes, 625 runs each
constexpr std::int64_t kFirstRunUnix = 1767225600;  // 2026-01-01T00:00:00Z
constexpr std::int64_t kRunSpacingS = 300;  // a run every 5 minutes: 100,000 runs in 347 days, 1,000,000 in 9.5 years
constexpr int kCharacteristics = 25;        // a judged lobe's: whole turn, zones, velocity, roundness

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "storage_bench: %s\n", what.c_str());
  std::abort();  // a benchmark on a database that failed to build measures nothing
}

// The history's size: GAUGELOOP_BENCH_RUNS runs (default 100,000; 1,000000 for a grinder's ten
// years at a run every 5 minutes).
int runs_count() {
  static const int n = [] {
    const char* env = std::getenv("GAUGELOOP_BENCH_RUNS");
    const long v = env != nullptr ? std::strtol(env, nullptr, 10) : 100000;
    if (v < 1000 || v > 10000000) die("GAUGELOOP_BENCH_RUNS must be 1000 to 10,000,000");
    return static_cast<int>(v);
  }();
  return n;
}
std::string utc(std::int64_t unix_s) {
  const auto t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

std::string part_name(int p) { return "cam_" + std::to_string(p); }

// A realistic run: a lobe-shaped lift, 0.3 um of noise, a 15 um form error.
RunRecord make_run(const std::string& part, int lobe, const std::string& machine, const std::string& started,
                   int seed) {
  RunRecord r;
  r.started_utc = started;
  r.finished_utc = started;
  r.machine = machine;
  r.part = part;
  r.lobe = lobe;
  r.gauge = "tcp:10.0.0.7:502";
  r.note = "";
  unsigned state = 12345u + static_cast<unsigned>(seed);
  auto noise_mm = [&state] {
    state = state * 1664525u + 1013904223u;
    return (static_cast<double>(state >> 8) / 16777216.0 - 0.5) * 0.001;
  };
  for (int i = 0; i < 3; ++i) {
    RevolutionSamples rev;
    rev.revolution = 100 + i;
    for (int d = 0; d < 360; ++d) {
      const double x = d * 0.0174532925;
      rev.lift_mm[static_cast<std::size_t>(d)] = 0.25 + 8.0 * std::max(0.0, std::cos(x)) + noise_mm();
    }
    r.measured.revolutions.push_back(rev);
  }
  r.measured.polls = 410;
  for (std::size_t d = 0; d < 360; ++d) {
    const double x = static_cast<double>(d) * 0.0174532925;
    r.analysis.design_lift_mm[d] = 8.0 * std::max(0.0, std::cos(x));
    r.analysis.error_um[d] = 15.0 * std::sin(2 * x) + noise_mm() * 300;
    r.analysis.mean_lift_mm[d] = r.analysis.design_lift_mm[d] + r.analysis.error_um[d] / 1000.0;
    r.analysis.spread_um[d] = 0.3 + std::abs(noise_mm()) * 200;
    r.correction_um[d] = r.analysis.error_um[d];
  }
  r.analysis.zero_offset_mm = 0.25;
  r.analysis.max_abs_error_um = 16.7;
  r.analysis.rms_error_um = 7.1;
  r.analysis.peak_to_valley_um = 29.9;
  r.analysis.repeatability_um = 0.7;
  r.analysis.phase_error_deg = 0.05;
  r.analysis.base_circle_runout_um = 1.2;
  for (std::size_t h = 0; h < r.analysis.harmonic_amplitude_um.size(); ++h) {
    r.analysis.harmonic_amplitude_um[h] = 15.0 / (1.0 + static_cast<double>(h));
  }
  r.settings = "analysis.base_circle_window_deg = 150..210\ncompensation.gain = 1\ncompensation.max_harmonic = 30\n";
  Part g;
  g.base_circle_radius_mm = 18.0;
  r.geometry = g;
  return r;
}

void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    die(sql.substr(0, 80) + ": " + (err != nullptr ? err : "?"));
  }
}

sqlite3_stmt* prepare(sqlite3* db, const std::string& sql) {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) die(sql + ": " + sqlite3_errmsg(db));
  return s;
}

void step_done(sqlite3* db, sqlite3_stmt* s) {
  if (sqlite3_step(s) != SQLITE_DONE) die(std::string("step: ") + sqlite3_errmsg(db));
  sqlite3_reset(s);
}

std::int64_t query_int(sqlite3* db, const std::string& sql) {
  sqlite3_stmt* s = prepare(db, sql);
  const std::int64_t v = sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int64(s, 0) : -1;
  sqlite3_finalize(s);
  return v;
}

// Builds the 100,000-run database in one transaction with the schema RunStore creates and
// rows laid out as insert_run lays them out (the same tables, columns and BLOB sizes); the
// per-degree BLOBs are encoded once and reused, which changes no byte count.
void build_history(const fs::path& path) {
  const auto t0 = std::chrono::steady_clock::now();
  fs::remove(path);
  fs::remove(path.string() + "-wal");
  fs::remove(path.string() + "-shm");
  {
    Result<RunStore> store = RunStore::open(path);  // schema, at the current version
    if (!store) die(store.error().message);
  }
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) die("open " + path.string());
  exec(db, "PRAGMA synchronous = OFF; PRAGMA cache_size = -200000; BEGIN");
  const RunRecord r = make_run("x", 1, "m", "2026-01-01T00:00:00Z", 1);
  std::string lift, design, mean, spread, error, correction;
  for (const auto& rev : r.measured.revolutions) {
    (void)storage_internal::append_degree_blob(rev.lift_mm, storage_internal::kCountsPerMm, "lift", lift);
  }
  (void)storage_internal::append_degree_blob(r.analysis.design_lift_mm, storage_internal::kCountsPerMm, "d", design);
  (void)storage_internal::append_degree_blob(r.analysis.mean_lift_mm, storage_internal::kCountsPerMm, "m", mean);
  (void)storage_internal::append_degree_blob(r.analysis.spread_um, storage_internal::kCountsPerUm, "s", spread);
  (void)storage_internal::append_degree_blob(r.analysis.error_um, storage_internal::kCountsPerUm, "e", error);
  (void)storage_internal::append_degree_blob(r.correction_um, storage_internal::kCountsPerUm, "c", correction);
  std::string harmonics = "[";
  for (std::size_t h = 0; h < 31; ++h)
    harmonics += (h ? "," : "") + std::to_string(15.0 / (1.0 + static_cast<double>(h)));
  harmonics += "]";
  const std::string hash = settings_hash(r.settings);
  exec(db, "INSERT INTO settings VALUES ('" + hash + "', '" + r.settings + "')");

  sqlite3_stmt* run = prepare(
      db,
      "INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, note, status, revolutions,"
      " degrees_captured, polls, reconnects, discarded_revolutions, zero_offset_mm, max_abs_error_um, rms_error_um,"
      " peak_to_valley_um, repeatability_um, nc_file, settings_hash, phase_error_deg, base_circle_runout_um,"
      " harmonic_amplitude_um, rotation_sense, c_offset_deg, probe_offset_deg)"
      " VALUES (?1, ?1, ?2, ?3, ?4, 'tcp:10.0.0.7:502', '', ?5, 3, 1080, 410, 0, 0, 0.25, ?6, 7.1, 29.9, 0.7, ?7,"
      " ?8, ?9, 1.2, ?10, 1, 0, 0)");
  // With the checksums a run stored today carries (schema 19), which reading a run checks.
  const std::int64_t raw_sum = storage_internal::raw_checksum("[100,101,102]", lift);
  const std::int64_t tables_sum = storage_internal::tables_checksum(
      {std::string_view(design).substr(0, 1440), std::string_view(mean).substr(0, 1440),
       std::string_view(spread).substr(0, 1440), std::string_view(error).substr(0, 1440),
       std::string_view(correction).substr(0, 1440)},
      std::nullopt);
  sqlite3_stmt* raw = prepare(db, "INSERT INTO run_raw VALUES (?1, '[100,101,102]', ?2, ?3)");
  sqlite3_stmt* tables = prepare(db,
                                 "INSERT INTO run_tables (run_id, design_lift, mean_lift, spread, error, correction,"
                                 " checksum) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
  sqlite3_stmt* push =
      prepare(db,
              "INSERT INTO nc_pushes (run_id, pushed_utc, nc_file, point_count, correction_max_um, program_hash,"
              " table_version, reason, interpolation, block_count, command_error_um)"
              " VALUES (?1, ?2, ?3, 361, 16.6, 'abcdef0123456789',"
              " (SELECT coalesce(max(table_version), 0) + 1 FROM nc_pushes WHERE nc_file = ?3),"
              " 'run ' || ?1, 'cspline', 55, 0.47)");
  sqlite3_stmt* characteristic =
      prepare(db, "INSERT INTO run_characteristics VALUES (?1, ?2, ?3, 'um', ?4, ?4, ?4, -12.0, 12.0, ?5, NULL, NULL)");
  for (int i = 0; i < runs_count(); ++i) {
    const std::string started = utc(kFirstRunUnix + static_cast<std::int64_t>(i) * kRunSpacingS);
    const std::string machine = "grinder-" + std::to_string(1 + i % kMachines);
    const std::string part = part_name((i / kMachines) % kParts);
    const int lobe = 1 + (i / (kMachines * kParts)) % kLobes;
    const bool pushed = i % 3 != 0;
    const std::string nc = "/nc/" + part + "_L" + std::to_string(lobe) + ".SPF";
    sqlite3_bind_text(run, 1, started.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(run, 2, machine.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_text(run, 3, part.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_int(run, 4, lobe);
    sqlite3_bind_text(run, 5, pushed ? "pushed" : "measured", -1, SQLITE_STATIC);
    sqlite3_bind_double(run, 6, 16.7 - 10.0 * (i % 7) / 7.0);
    if (pushed) {
      sqlite3_bind_text(run, 7, nc.c_str(), -1, SQLITE_TRANSIENT);
    } else {
      sqlite3_bind_null(run, 7);
    }
    sqlite3_bind_text(run, 8, hash.c_str(), -1, SQLITE_TRANSIENT);
    sqlite3_bind_double(run, 9, 0.01 * (i % 11));
    sqlite3_bind_text(run, 10, harmonics.c_str(), -1, SQLITE_TRANSIENT);
    step_done(db, run);
    const sqlite3_int64 id = sqlite3_last_insert_rowid(db);
    sqlite3_bind_int64(raw, 1, id);
    sqlite3_bind_blob(raw, 2, lift.data(), static_cast<int>(lift.size()), SQLITE_STATIC);
    sqlite3_bind_int64(raw, 3, raw_sum);
    step_done(db, raw);
    sqlite3_bind_int64(tables, 1, id);
    sqlite3_bind_blob(tables, 2, design.data(), 1440, SQLITE_STATIC);
    sqlite3_bind_blob(tables, 3, mean.data(), 1440, SQLITE_STATIC);
    sqlite3_bind_blob(tables, 4, spread.data(), 1440, SQLITE_STATIC);
    sqlite3_bind_blob(tables, 5, error.data(), 1440, SQLITE_STATIC);
    sqlite3_bind_blob(tables, 6, correction.data(), 1440, SQLITE_STATIC);
    sqlite3_bind_int64(tables, 7, tables_sum);
    step_done(db, tables);
    if (pushed) {
      sqlite3_bind_int64(push, 1, id);
      sqlite3_bind_text(push, 2, started.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_text(push, 3, nc.c_str(), -1, SQLITE_TRANSIENT);
      step_done(db, push);
    }
    for (int k = 0; k < kCharacteristics; ++k) {
      const std::string key = "lift_error.zone" + std::to_string(k);
      const double value = 13.0 * std::sin(0.37 * i + k);
      sqlite3_bind_int64(characteristic, 1, id);
      sqlite3_bind_int(characteristic, 2, k);
      sqlite3_bind_text(characteristic, 3, key.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_double(characteristic, 4, value);
      sqlite3_bind_text(characteristic, 5, std::fabs(value) > 12.0 ? "out" : "in", -1, SQLITE_STATIC);
      step_done(db, characteristic);
    }
  }
  for (sqlite3_stmt* s : {run, raw, tables, push, characteristic}) sqlite3_finalize(s);
  exec(db, "COMMIT; PRAGMA wal_checkpoint(TRUNCATE)");
  sqlite3_close(db);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::fprintf(stderr, "storage_bench: built %d runs in %s in %.1f s\n", runs_count(), path.c_str(), s);
}

fs::path history_path() {
  const char* env = std::getenv("GAUGELOOP_BENCH_DB");
  return env != nullptr ? fs::path(env)
                        : fs::temp_directory_path() / ("gaugeloop-bench-" + std::to_string(runs_count()) + ".sqlite");
}

// The cached database, rebuilt when missing, incomplete or of another schema version.
const fs::path& history() {
  static const fs::path path = [] {
    const fs::path p = history_path();
    bool ok = false;
    if (fs::exists(p)) {
      sqlite3* db = nullptr;
      if (sqlite3_open_v2(p.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
        ok = query_int(db, "PRAGMA user_version") == storage_internal::latest_schema_version() &&
             query_int(db, "SELECT count(*) FROM runs") == runs_count() &&
             query_int(db, "SELECT count(*) FROM run_characteristics") == std::int64_t{runs_count()} * kCharacteristics;
      }
      sqlite3_close(db);
    }
    if (!ok) build_history(p);
    return p;
  }();
  return path;
}

// Bytes of the database file per run, with the WAL checkpointed into it.
double bytes_per_run(const fs::path& path, int runs) {
  sqlite3* db = nullptr;
  sqlite3_open(path.c_str(), &db);
  exec(db, "PRAGMA wal_checkpoint(TRUNCATE)");
  const double bytes = static_cast<double>(query_int(db, "PRAGMA page_count") * query_int(db, "PRAGMA page_size") -
                                           query_int(db, "PRAGMA freelist_count") * query_int(db, "PRAGMA page_size"));
  sqlite3_close(db);
  return bytes / runs;
}

struct TempDb {
  fs::path dir = fs::temp_directory_path() / ("gaugeloop-bench-" + std::to_string(::getpid()));
  TempDb() {
    fs::remove_all(dir);
    fs::create_directories(dir);
  }
  ~TempDb() { fs::remove_all(dir); }
};

// ---- Storing one run ----

void BM_StoreOneRun(benchmark::State& state) {
  TempDb tmp;
  Result<RunStore> store = RunStore::open(tmp.dir / "runs.sqlite");
  if (!store) die(store.error().message);
  const RunRecord record = make_run("intake", 1, "grinder-1", "2026-11-22T02:34:44Z", 7);
  int stored = 0;
  for (auto _ : state) {
    Result<std::int64_t> id = store->insert_run(record);
    if (!id) die(id.error().message);
    benchmark::DoNotOptimize(*id);
    ++stored;
  }
  state.counters["bytes_per_run"] = bytes_per_run(tmp.dir / "runs.sqlite", stored);
}

// Baseline: the same bytes as one BLOB row, one durable transaction, same pragmas.
void BM_Baseline_BareInsertOfTheSameBytes(benchmark::State& state) {
  TempDb tmp;
  sqlite3* db = nullptr;
  sqlite3_open((tmp.dir / "bare.sqlite").c_str(), &db);
  exec(db, "PRAGMA journal_mode = WAL; CREATE TABLE t (id INTEGER PRIMARY KEY, b BLOB)");
  // 3 x 1440 raw + 5 x 1440 tables + about 400 bytes of run row and settings.
  const std::string bytes(8 * 1440 + 400, 'x');
  sqlite3_stmt* ins = prepare(db, "INSERT INTO t (b) VALUES (?1)");
  for (auto _ : state) {
    exec(db, "BEGIN IMMEDIATE");
    sqlite3_bind_blob(ins, 1, bytes.data(), static_cast<int>(bytes.size()), SQLITE_STATIC);
    step_done(db, ins);
    exec(db, "COMMIT");
  }
  sqlite3_finalize(ins);
  sqlite3_close(db);
}

// ---- Queries on the history ----

class History : public benchmark::Fixture {
 public:
  void SetUp(benchmark::State&) override {
    if (!store_) {
      Result<RunStore> s = RunStore::open(history());
      if (!s) die(s.error().message);
      store_.emplace(std::move(*s));
    }
  }
  void TearDown(benchmark::State&) override {}

 protected:
  std::optional<RunStore> store_;
  std::uint64_t rng_ = 88172645463325252ull;
  // A different lobe and run each iteration, so no query is answered from a warm row alone.
  std::uint64_t next() {
    rng_ ^= rng_ << 13;
    rng_ ^= rng_ >> 7;
    rng_ ^= rng_ << 17;
    return rng_;
  }

  // A baseline, bare sqlite3: the characteristics' values of a random lobe's newest
  // state.range(0) runs by the index (those `join` keeps of them), summed.
  void bare_sum_of_window(benchmark::State& state, const std::string& join) {
    sqlite3* db = nullptr;
    sqlite3_open_v2(history().c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
    const std::string sql =
        "SELECT c.value FROM (SELECT id FROM runs WHERE part = ?1 AND lobe = ?2"
        " ORDER BY started_utc DESC, id DESC LIMIT ?3) AS w JOIN run_characteristics AS c ON " +
        join;
    for (auto _ : state) {
      sqlite3_stmt* s = prepare(db, sql);
      const std::string part = part_name(static_cast<int>(next() % kParts));
      sqlite3_bind_text(s, 1, part.c_str(), -1, SQLITE_TRANSIENT);
      sqlite3_bind_int(s, 2, 1 + static_cast<int>(next() % kLobes));
      sqlite3_bind_int64(s, 3, state.range(0));
      double sum = 0.0;
      while (sqlite3_step(s) == SQLITE_ROW) sum += sqlite3_column_double(s, 0);
      benchmark::DoNotOptimize(sum);
      sqlite3_finalize(s);
    }
    sqlite3_close(db);
  }
};

BENCHMARK_DEFINE_F(History, ListLast50RunsOfALobe)(benchmark::State& state) {
  for (auto _ : state) {
    RunQuery q;
    q.part = part_name(static_cast<int>(next() % kParts));
    q.lobe = 1 + static_cast<int>(next() % kLobes);
    q.limit = 50;
    Result<std::vector<RunSummary>> runs = store_->list_runs(q);
    if (!runs || runs->size() != 50u) die("list of a lobe did not return 50 runs");
    benchmark::DoNotOptimize(runs->data());
  }
}

// `runs list --verdict in` where no run is judged: the filter an index serves finds none at once.
BENCHMARK_DEFINE_F(History, ListAVerdictNoRunHas)(benchmark::State& state) {
  for (auto _ : state) {
    RunQuery q;
    q.verdict = Verdict::kIn;
    q.limit = 50;
    Result<std::vector<RunSummary>> runs = store_->list_runs(q);
    if (!runs || !runs->empty()) die("the verdict filter found runs where none is judged");
    benchmark::DoNotOptimize(runs->data());
  }
}

BENCHMARK_DEFINE_F(History, Trend30DaysOfALobe)(benchmark::State& state) {
  const std::int64_t last = kFirstRunUnix + static_cast<std::int64_t>(runs_count() - 1) * kRunSpacingS;
  std::size_t points = 0;
  for (auto _ : state) {
    RunQuery q;
    q.part = part_name(static_cast<int>(next() % kParts));
    q.lobe = 1 + static_cast<int>(next() % kLobes);
    q.limit = 1000000;
    q.since_utc = utc(last - 30 * 86400);
    Result<std::vector<RunSummary>> runs = store_->trend(q);
    if (!runs || runs->empty()) die("trend returned nothing");
    points = runs->size();
    benchmark::DoNotOptimize(runs->data());
  }
  state.counters["runs_in_trend"] = static_cast<double>(points);
}

BENCHMARK_DEFINE_F(History, ShowOneRun)(benchmark::State& state) {
  for (auto _ : state) {
    Result<StoredRun> run = store_->load_run(1 + static_cast<std::int64_t>(next() % runs_count()));
    if (!run) die(run.error().message);
    benchmark::DoNotOptimize(run->analysis.error_um.data());
  }
}

// `runs spc` of a random lobe over its newest state.range(0) runs (25 characteristics each),
// summed up in SQL (RunStore::characteristic_summaries), then the figures.
BENCHMARK_DEFINE_F(History, SpcOfALobe)(benchmark::State& state) {
  for (auto _ : state) {
    RunQuery q;
    q.part = part_name(static_cast<int>(next() % kParts));
    q.lobe = 1 + static_cast<int>(next() % kLobes);
    q.limit = static_cast<int>(state.range(0));
    Result<CharacteristicSummaries> s = store_->characteristic_summaries(q);
    if (!s || s->by_key.size() != static_cast<std::size_t>(kCharacteristics)) die("spc summed up no keys");
    benchmark::DoNotOptimize(s->by_key.data());
  }
}

// The same window read as before: every run and its characteristics, summed up in C++.
BENCHMARK_DEFINE_F(History, SpcOfALobeFromEveryRun)(benchmark::State& state) {
  for (auto _ : state) {
    RunQuery q;
    q.part = part_name(static_cast<int>(next() % kParts));
    q.lobe = 1 + static_cast<int>(next() % kLobes);
    q.limit = static_cast<int>(state.range(0));
    Result<std::vector<RunCharacteristics>> runs = store_->characteristics(q);
    if (!runs || runs->empty()) die("spc read no runs");
    benchmark::DoNotOptimize(runs->data());
  }
}

// Baseline: the same rows' values, bare sqlite3: the lobe's newest state.range(0) runs by
// the index and their characteristics' values, summed.
BENCHMARK_DEFINE_F(History, Baseline_BareSelectOfTheSpcRows)(benchmark::State& state) {
  bare_sum_of_window(state, "c.run_id = w.id");
}

// What a trend plot reads (`runs trend --plot`, /api/trend.svg): the newest state.range(0)
// runs of a lobe, oldest first, each with the one characteristic plotted.
BENCHMARK_DEFINE_F(History, TrendPlotRunsOfALobe)(benchmark::State& state) {
  for (auto _ : state) {
    RunQuery q;
    q.part = part_name(static_cast<int>(next() % kParts));
    q.lobe = 1 + static_cast<int>(next() % kLobes);
    q.limit = static_cast<int>(state.range(0));
    Result<std::vector<RunCharacteristics>> runs = store_->characteristics(q, "lift_error.zone3");
    if (!runs || runs->size() != static_cast<std::size_t>(q.limit) || runs->back().characteristics.size() != 1) {
      die("the trend plot read no runs or not their one characteristic");
    }
    benchmark::DoNotOptimize(runs->data());
  }
}

// Baseline: the same runs' values of that key, bare sqlite3.
BENCHMARK_DEFINE_F(History, Baseline_BareSelectOfTheTrendPlotRows)(benchmark::State& state) {
  bare_sum_of_window(state, "c.run_id = w.id AND c.key = 'lift_error.zone3'");
}

// What the command line pays before its query: opening the file and checking the schema.
BENCHMARK_DEFINE_F(History, OpenTheDatabase)(benchmark::State& state) {
  for (auto _ : state) {
    Result<RunStore> s = RunStore::open(history());
    if (!s) die(s.error().message);
  }
}

// Baseline: one runs row by primary key, bare sqlite3, prepared each time as RunStore does.
BENCHMARK_DEFINE_F(History, Baseline_BareSelectByPrimaryKey)(benchmark::State& state) {
  sqlite3* db = nullptr;
  sqlite3_open_v2(history().c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  for (auto _ : state) {
    sqlite3_stmt* s = prepare(db, "SELECT * FROM runs WHERE id = ?1");
    sqlite3_bind_int64(s, 1, 1 + static_cast<std::int64_t>(next() % runs_count()));
    if (sqlite3_step(s) != SQLITE_ROW) die("no row");
    benchmark::DoNotOptimize(sqlite3_column_double(s, 14));
    sqlite3_finalize(s);
  }
  sqlite3_close(db);
  state.counters["bytes_per_run"] = static_cast<double>(fs::file_size(history())) / runs_count();
}

// ---- Bytes per run, version 1 layout against version 2, same 1,000 runs ----

void BM_BytesPerRunByLayout(benchmark::State& state) {
  const bool v1 = state.range(0) == 1;
  constexpr int kSample = 1000;
  double per_run = 0;
  for (auto _ : state) {
    TempDb tmp;
    const fs::path path = tmp.dir / "layout.sqlite";
    if (v1) {
      sqlite3* db = nullptr;
      sqlite3_open(path.c_str(), &db);
      exec(db, "PRAGMA journal_mode = WAL; BEGIN");
      exec(db, std::string(storage_internal::schema_v1_sql()));
      sqlite3_stmt* run = prepare(db,
                                  "INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge,"
                                  " revolutions, degrees_captured, zero_offset_mm, max_abs_error_um, rms_error_um,"
                                  " peak_to_valley_um, repeatability_um) VALUES ('2026-01-01T00:00:00Z',"
                                  " '2026-01-01T00:00:00Z', 'grinder-1', 'cam_1', 1, 'tcp:10.0.0.7:502', 3, 1080,"
                                  " 0.25, 16.7, 7.1, 29.9, 0.7)");
      sqlite3_stmt* rev = prepare(db, "INSERT INTO run_revolutions VALUES (?1, ?2, ?3, ?4)");
      sqlite3_stmt* prof = prepare(db, "INSERT INTO run_profile VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
      for (int i = 0; i < kSample; ++i) {
        const RunRecord r = make_run("cam_1", 1, "grinder-1", "2026-01-01T00:00:00Z", i);
        step_done(db, run);
        const sqlite3_int64 id = sqlite3_last_insert_rowid(db);
        for (int k = 0; k < 3; ++k) {
          std::string json = "[";
          char buf[32];
          for (int d = 0; d < 360; ++d) {
            std::snprintf(buf, sizeof buf, "%s%.6f", d ? "," : "", r.measured.revolutions[k].lift_mm[d]);
            json += buf;
          }
          json += "]";
          sqlite3_bind_int64(rev, 1, id);
          sqlite3_bind_int(rev, 2, k);
          sqlite3_bind_int(rev, 3, 100 + k);
          sqlite3_bind_text(rev, 4, json.c_str(), -1, SQLITE_TRANSIENT);
          step_done(db, rev);
        }
        for (std::size_t d = 0; d < 360; ++d) {
          sqlite3_bind_int64(prof, 1, id);
          sqlite3_bind_int(prof, 2, static_cast<int>(d));
          sqlite3_bind_double(prof, 3, r.analysis.design_lift_mm[d]);
          sqlite3_bind_double(prof, 4, r.analysis.mean_lift_mm[d]);
          sqlite3_bind_double(prof, 5, r.analysis.spread_um[d]);
          sqlite3_bind_double(prof, 6, r.analysis.error_um[d]);
          sqlite3_bind_double(prof, 7, r.correction_um[d]);
          step_done(db, prof);
        }
      }
      for (sqlite3_stmt* s : {run, rev, prof}) sqlite3_finalize(s);
      exec(db, "COMMIT");
      sqlite3_close(db);
    } else {
      Result<RunStore> store = RunStore::open(path);
      if (!store) die(store.error().message);
      for (int i = 0; i < kSample; ++i) {
        // Distinct data per run, through the real insert path, one transaction per run.
        if (!store->insert_run(make_run("cam_1", 1, "grinder-1", "2026-01-01T00:00:00Z", i))) die("insert");
      }
    }
    per_run = bytes_per_run(path, kSample);
  }
  state.counters["bytes_per_run"] = per_run;
  state.SetLabel(v1 ? "schema v1: JSON revolutions, one REAL row per degree" : "schema v2: int32 BLOBs per run");
}

BENCHMARK(BM_StoreOneRun)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Baseline_BareInsertOfTheSameBytes)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK_REGISTER_F(History, ListLast50RunsOfALobe)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK_REGISTER_F(History, ListAVerdictNoRunHas)->Unit(benchmark::kMillisecond);
BENCHMARK_REGISTER_F(History, Trend30DaysOfALobe)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK_REGISTER_F(History, SpcOfALobe)->Arg(125)->Arg(625)->Unit(benchmark::kMillisecond);
BENCHMARK_REGISTER_F(History, SpcOfALobeFromEveryRun)->Arg(125)->Arg(625)->Unit(benchmark::kMillisecond);
BENCHMARK_REGISTER_F(History, Baseline_BareSelectOfTheSpcRows)->Arg(125)->Arg(625)->Unit(benchmark::kMillisecond);
BENCHMARK_REGISTER_F(History, TrendPlotRunsOfALobe)->Arg(200)->Unit(benchmark::kMillisecond);
BENCHMARK_REGISTER_F(History, Baseline_BareSelectOfTheTrendPlotRows)->Arg(200)->Unit(benchmark::kMillisecond);
BENCHMARK_REGISTER_F(History, ShowOneRun)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK_REGISTER_F(History, OpenTheDatabase)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK_REGISTER_F(History, Baseline_BareSelectByPrimaryKey)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);
BENCHMARK(BM_BytesPerRunByLayout)->Arg(1)->Arg(2)->Iterations(1)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace gaugeloop

BENCHMARK_MAIN();
