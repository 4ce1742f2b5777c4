// /metrics benchmarks (figures and the command: docs/PERFORMANCE.md, "/metrics"): one scrape
// of the database's series (append_database_metrics, as the HTTP API answers it) on a database
// of 1,000,000 runs and 5,000,000 events, its time and the growth of the process's peak
// resident memory, against baselines measured in the same run on the same file: a bare
// `SELECT count(*) FROM runs` and a bare `SELECT 1` (bare sqlite3, prepared each time).
//
// GAUGELOOP_BENCH_METRICS_DB: where the database is kept between runs (default:
// <tmp>/gaugeloop-bench-metrics-1m.sqlite, about 1 GB); delete it to rebuild (a minute or two).
#include <benchmark/benchmark.h>
#include <sqlite3.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>

#include "service/metrics_text.h"
#include "storage/migrations.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr std::int64_t kRuns = 1000000;
constexpr std::int64_t kEvents = 5000000;
constexpr std::int64_t kPushed = 666666;  // runs i with i % 3 != 0, i in [0, kRuns)
constexpr std::int64_t kFaults = 500000;  // events i with i % 10 == 0; refusals i % 10 == 1; the rest info
constexpr int kPendingFiles = 40;         // half pending, half rejected

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "metrics_bench: %s\n", what.c_str());
  std::abort();  // a benchmark on a database that failed to build measures nothing
}

void exec(sqlite3* db, const std::string& sql) {
  char* err = nullptr;
  if (sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &err) != SQLITE_OK) {
    die(sql.substr(0, 80) + ": " + (err != nullptr ? err : "?"));
  }
}

std::int64_t query_int(sqlite3* db, const std::string& sql) {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v2(db, sql.c_str(), -1, &s, nullptr) != SQLITE_OK) die(sql + ": " + sqlite3_errmsg(db));
  const std::int64_t v = sqlite3_step(s) == SQLITE_ROW ? sqlite3_column_int64(s, 0) : -1;
  sqlite3_finalize(s);
  return v;
}

// 1,000,000 runs (4 machines x 5 parts x 8 lobes, one every 30 s for 347 days, two in three
// pushed) and 5,000,000 events, in one transaction of three INSERT ... SELECTs over recursive
// CTEs, through the triggers the schema has (so the counts are the triggers' work). Runs carry
// every summary column but no per-degree tables: a scrape never reads those.
void build(const fs::path& path) {
  const auto t0 = Clock::now();
  fs::remove(path);
  fs::remove(path.string() + "-wal");
  fs::remove(path.string() + "-shm");
  {
    Result<RunStore> store = RunStore::open(path);  // the schema, exactly as the service makes it
    if (!store) die(store.error().message);
  }
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) die("cannot open " + path.string());
  // A rollback journal while building: pages new to the file are not journalled, where WAL
  // would write every page twice.
  exec(db, "PRAGMA journal_mode = DELETE; PRAGMA synchronous = OFF; PRAGMA cache_size = -65536; BEGIN");
  exec(db, R"sql(
WITH RECURSIVE s (i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM s WHERE i < )sql" +
               std::to_string(kRuns - 1) + R"sql()
INSERT INTO runs (started_utc, finished_utc, machine, part, lobe, gauge, status, nc_file, revolutions,
                  degrees_captured, polls, zero_offset_mm, max_abs_error_um, rms_error_um, peak_to_valley_um,
                  repeatability_um, phase_error_deg, base_circle_runout_um)
SELECT strftime('%Y-%m-%dT%H:%M:%SZ', 1767225600 + 30 * i, 'unixepoch'),
       strftime('%Y-%m-%dT%H:%M:%SZ', 1767225620 + 30 * i, 'unixepoch'),
       'grinder-' || (1 + i % 4), 'cam_' || ((i / 4) % 5), 1 + (i / 20) % 8, 'tcp:10.0.0.7:502',
       CASE WHEN i % 3 = 0 THEN 'measured' ELSE 'pushed' END,
       CASE WHEN i % 3 = 0 THEN NULL ELSE '/nc/cam_' || ((i / 4) % 5) || '_L' || (1 + (i / 20) % 8) || '.SPF' END,
       3, 1080, 410, 0.25, 16.7 - 10.0 * (i % 7) / 7.0, 7.1, 29.9, 0.7, 0.01 * (i % 11), 1.2
FROM s)sql");
  exec(db, R"sql(
WITH RECURSIVE s (i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM s WHERE i < )sql" +
               std::to_string(kEvents - 1) + R"sql()
INSERT INTO events (at_utc, kind, code, machine, part, lobe, message)
SELECT strftime('%Y-%m-%dT%H:%M:%SZ', 1767225600 + 6 * i, 'unixepoch'),
       CASE i % 10 WHEN 0 THEN 'fault' WHEN 1 THEN 'refusal' ELSE 'info' END,
       CASE i % 10 WHEN 0 THEN 'gauge timeout' WHEN 1 THEN 'refused' ELSE 'plc request' END,
       'grinder-' || (1 + i % 4), 'cam_' || ((i / 4) % 5), 1 + (i / 20) % 8,
       CASE i % 10 WHEN 0 THEN 'gauge 10.0.0.7:502 stopped answering (timeout 200 ms)'
                   WHEN 1 THEN 'correction 31.2 um at cam degree 95 exceeds the 25 um step limit'
                   ELSE 'PLC request ' || i || ': part cam_' || ((i / 4) % 5) END
FROM s)sql");
  exec(db, R"sql(
WITH RECURSIVE s (i) AS (SELECT 0 UNION ALL SELECT i + 1 FROM s WHERE i < )sql" +
               std::to_string(kPendingFiles - 1) + R"sql()
INSERT INTO nc_pending (run_id, created_utc, nc_file, program_text, verdict, status, decided_utc, decided_by)
SELECT 1 + i, '2026-12-01T08:00:00Z', '/nc/file_' || i || '.SPF', 'N10 G1 C0 X0', 'apply',
       CASE WHEN i % 2 = 0 THEN 'pending' ELSE 'rejected' END,
       CASE WHEN i % 2 = 0 THEN NULL ELSE '2026-12-01T09:00:00Z' END,
       CASE WHEN i % 2 = 0 THEN NULL ELSE 'anna' END
FROM s)sql");
  exec(db, "COMMIT; PRAGMA journal_mode = WAL");
  sqlite3_close(db);
  const double s = std::chrono::duration<double>(Clock::now() - t0).count();
  std::fprintf(stderr, "metrics_bench: built %lld runs and %lld events in %s in %.0f s\n",
               static_cast<long long>(kRuns), static_cast<long long>(kEvents), path.c_str(), s);
}

fs::path database_path() {
  const char* env = std::getenv("GAUGELOOP_BENCH_METRICS_DB");
  return env != nullptr ? fs::path(env) : fs::temp_directory_path() / "gaugeloop-bench-metrics-1m.sqlite";
}

// The cached database, rebuilt when missing, incomplete or of another schema version.
const fs::path& database() {
  static const fs::path path = [] {
    const fs::path p = database_path();
    bool ok = false;
    if (fs::exists(p)) {
      sqlite3* db = nullptr;
      if (sqlite3_open_v2(p.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) == SQLITE_OK) {
        ok = query_int(db, "PRAGMA user_version") == storage_internal::latest_schema_version() &&
             query_int(db, "SELECT max(id) FROM runs") == kRuns &&
             query_int(db, "SELECT max(id) FROM events") == kEvents;
      }
      sqlite3_close(db);
    }
    if (!ok) build(p);
    return p;
  }();
  return path;
}

// A figure of /proc/self/status, in KiB ("VmHWM", "VmRSS").
double status_kib(const std::string& field) {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);) {
    if (line.starts_with(field + ":")) return std::strtod(line.c_str() + field.size() + 1, nullptr);
  }
  return -1;
}

// Sets VmHWM back to the current VmRSS (Linux 4.0 and later), so that the peak measured is the
// scrape's, not the database build's. False if the kernel refused.
bool reset_peak_rss() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

// What a scrape must show of the database built above; aborts the benchmark otherwise.
void check(const std::string& text) {
  for (const std::string& line :
       {"gaugeloop_runs_stored{status=\"pushed\"} " + std::to_string(kPushed) + "\n",
        "gaugeloop_runs_stored{status=\"measured\"} " + std::to_string(kRuns - kPushed) + "\n",
        "gaugeloop_events_stored{kind=\"fault\"} " + std::to_string(kFaults) + "\n",
        "gaugeloop_events_stored{kind=\"info\"} " + std::to_string(kEvents - 2 * kFaults) + "\n",
        "gaugeloop_pending_tables " + std::to_string(kPendingFiles / 2) + "\n",
        std::string("gaugeloop_last_run_id{machine=\"grinder-4\",part=\"cam_4\",lobe=\"8\"} 1000000\n")}) {
    if (text.find(line) == std::string::npos) die("the scrape lacks " + line + "in:\n" + text);
  }
}

// Mean seconds of one bare query through its own sqlite3 connection, prepared each time.
double bare_query_s(const std::string& sql, int times) {
  sqlite3* db = nullptr;
  sqlite3_open_v2(database().c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  query_int(db, sql);  // warm
  const auto t0 = Clock::now();
  for (int i = 0; i < times; ++i) benchmark::DoNotOptimize(query_int(db, sql));
  const double s = std::chrono::duration<double>(Clock::now() - t0).count() / times;
  sqlite3_close(db);
  return s;
}

// One scrape through a connection kept open, as the HTTP API's pool keeps it.
void BM_ScrapeOnePooledConnection(benchmark::State& state) {
  Result<RunStore> store = RunStore::open(database());
  if (!store) die(store.error().message);
  std::string text;
  if (Status s = append_database_metrics(*store, text); !s.ok()) die(s.error().message);
  check(text);
  const bool reset = reset_peak_rss();
  const double rss_before_kib = status_kib("VmRSS");
  double scrape_s = 0.0;
  for (auto _ : state) {
    text.clear();
    const auto t0 = Clock::now();
    if (Status s = append_database_metrics(*store, text); !s.ok()) die(s.error().message);
    scrape_s += std::chrono::duration<double>(Clock::now() - t0).count();
    benchmark::DoNotOptimize(text.data());
  }
  const double peak_growth_kib = status_kib("VmHWM") - rss_before_kib;
  scrape_s /= static_cast<double>(state.iterations());
  state.counters["peak_rss_growth_kib"] = reset ? peak_growth_kib : -1;
  state.counters["text_bytes"] = static_cast<double>(text.size());
  state.counters["ratio_to_count_runs"] = scrape_s / bare_query_s("SELECT count(*) FROM runs", 20);
  state.counters["ratio_to_select_1"] = scrape_s / bare_query_s("SELECT 1", 1000);
}

// The first scrape after a restart, or after the pool dropped a failed connection: opening
// the file (schema check) and one scrape.
void BM_OpenAndScrape(benchmark::State& state) {
  (void)database();
  const bool reset = reset_peak_rss();
  const double rss_before_kib = status_kib("VmRSS");
  for (auto _ : state) {
    Result<RunStore> store = RunStore::open(database());
    if (!store) die(store.error().message);
    std::string text;
    if (Status s = append_database_metrics(*store, text); !s.ok()) die(s.error().message);
    benchmark::DoNotOptimize(text.data());
  }
  state.counters["peak_rss_growth_kib"] = reset ? status_kib("VmHWM") - rss_before_kib : -1;
}

// Baselines on the same file: what SQLite takes to count the runs (one pass over the smallest
// index of runs), and to answer nothing.
void BM_Baseline_BareCountOfRuns(benchmark::State& state) {
  sqlite3* db = nullptr;
  sqlite3_open_v2(database().c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  for (auto _ : state) {
    if (query_int(db, "SELECT count(*) FROM runs") != kRuns) die("count(*) of runs is not 1,000,000");
  }
  sqlite3_close(db);
}

void BM_Baseline_BareSelect1(benchmark::State& state) {
  sqlite3* db = nullptr;
  sqlite3_open_v2(database().c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  for (auto _ : state) benchmark::DoNotOptimize(query_int(db, "SELECT 1"));
  sqlite3_close(db);
}

// What the counts would cost without row_counts: events by kind, counted by SQLite.
void BM_Baseline_BareCountOfEventsByKind(benchmark::State& state) {
  sqlite3* db = nullptr;
  sqlite3_open_v2(database().c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  for (auto _ : state) {
    sqlite3_stmt* s = nullptr;
    sqlite3_prepare_v2(db, "SELECT kind, count(*) FROM events GROUP BY kind", -1, &s, nullptr);
    while (sqlite3_step(s) == SQLITE_ROW) benchmark::DoNotOptimize(sqlite3_column_int64(s, 1));
    sqlite3_finalize(s);
  }
  sqlite3_close(db);
}

}  // namespace

BENCHMARK(BM_ScrapeOnePooledConnection)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_OpenAndScrape)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Baseline_BareCountOfRuns)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Baseline_BareSelect1)->Unit(benchmark::kMicrosecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Baseline_BareCountOfEventsByKind)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace gaugeloop

BENCHMARK_MAIN();
