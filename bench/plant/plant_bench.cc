// Plant benchmarks (figures and the command: docs/PERFORMANCE.md, "Plant"). A real mosquitto
// broker and a real PostgreSQL 15 cluster are started on loopback for the run, as the tests
// start them (tests/support), and stopped after.
//  - messages per second through the outbox: runs stored with the outbox on, then one
//    OutboxSender delivering them (load each run, render its JSON, publish at QoS 1, delete on
//    the broker's acknowledgement), against a baseline in the same run: a bare libmosquitto
//    client publishing the same number of payloads of the same size at QoS 1 to the same
//    broker and waiting for every acknowledgement;
//  - runs per second synced into the central history (plant sync: runs with their
//    characteristics, in batches of 200, progress in the same transaction), against a baseline:
//    bare libpqxx inserts of as many rows of the same width, 200 per transaction;
//  - cross-machine queries on a central history of 1,000,000 runs (20 machines, 5 parts of 8
//    lobes, generated in SQL): the last 50 runs of a lobe on every machine, a lobe's 30-day
//    trend across machines, and the last 50 runs of one machine, through CentralHistory as
//    `runs list --db` reads them, against a baseline: a bare SELECT of one run by its UUID.
#include <benchmark/benchmark.h>
#include <mosquitto.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <optional>
#include <pqxx/pqxx>
#include <string>
#include <vector>

#include "core/utc_time.h"
#include "plant/central_history.h"
#include "plant/central_sync.h"
#include "plant/outbox_sender.h"
#include "plant/plant_messages.h"
#include "report/run_json.h"
#include "storage/run_store.h"
#include "tests/support/mosquitto_broker.h"
#include "tests/support/postgres_server.h"
#include "tests/support/sample_runs.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;

constexpr int kMessages = 2000;        // runs through the outbox per iteration
constexpr int kSyncRuns = 2000;        // runs synced per iteration
constexpr int kCentralRuns = 1000000;  // the central history the queries read

[[noreturn]] void die(const std::string& what) {
  std::fprintf(stderr, "plant_bench: %s\n", what.c_str());
  std::abort();  // a benchmark whose servers failed measures nothing
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("gaugeloop-plant-bench-" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

// A run as the job stores it, with the six characteristics of a judged lobe.
RunRecord bench_run(int i, const std::string& machine, int characteristics = 6) {
  RunRecord r =
      testing::sample_run("cam_" + std::to_string(i % 5), 1 + i % 8, machine,
                          format_utc(static_cast<std::time_t>(1767225600 + 60 * i)), 2.0 + 0.001 * (i % 1000));
  for (int k = 0; k < characteristics; ++k) {
    Characteristic c;
    c.key = "lift_error_" + std::to_string(k);
    c.unit = "um";
    c.value = 1.0 + k;
    c.min = -1.0;
    c.max = 1.0 + k;
    c.limits.upper = 10.0;
    c.verdict = Verdict::kIn;
    r.characteristics.push_back(c);
  }
  r.verdict = Verdict::kIn;
  return r;
}

RunStore store_with_runs(const fs::path& db, int runs, bool outbox, int characteristics = 6) {
  Result<RunStore> store = RunStore::open(db);
  if (!store) die(store.error().message);
  if (outbox && !store->configure_outbox({true, 1000000}).ok()) die("cannot enable the outbox");
  for (int i = 0; i < runs; ++i) {
    Result<std::int64_t> id = store->insert_run(bench_run(i, "grinder-01", characteristics));
    if (!id) die(id.error().message);
  }
  return std::move(store).value();
}

struct Servers {
  fs::path broker_dir = scratch("broker");
  testing::MosquittoBroker broker{broker_dir};
  testing::PostgresServer postgres;
  Servers() {
    if (!broker.started()) die("the broker did not start");
    // GAUGELOOP_BENCH_PG_DURABLE=1: the server flushes its commits (fsync on), as a plant's does.
    postgres.durable = std::getenv("GAUGELOOP_BENCH_PG_DURABLE") != nullptr;
    if (std::string e = postgres.start(); !e.empty()) die("PostgreSQL did not start: " + e);
  }
};

Servers& servers() {
  static Servers s;
  return s;
}

std::string new_database(const std::string& name) {
  const std::string out = servers().postgres.psql("postgres", "CREATE DATABASE " + name);
  if (out.find("ERROR") != std::string::npos) die(out);
  return servers().postgres.url(name);
}

// ---- messages through the outbox ----

void BM_OutboxThroughSender(benchmark::State& state) {
  MqttSettings settings;
  settings.host = "127.0.0.1";
  settings.port = servers().broker.port();
  settings.site = "bench";
  int iteration = 0;
  for (auto _ : state) {
    const fs::path db = scratch("outbox-" + std::to_string(iteration++)) / "runs.sqlite";
    std::int64_t queued = 0;
    {
      RunStore store = store_with_runs(db, kMessages, true);
      queued = store.outbox_counts()->depth;
    }
    Result<RunStore> watch = RunStore::open(db);
    if (!watch) die(watch.error().message);
    const auto start = std::chrono::steady_clock::now();
    {
      OutboxSender sender(db, settings, "grinder-01");
      sender.notify();
      if (!testing::wait_until([&] { return watch->outbox_counts()->depth == 0; }, std::chrono::minutes(10))) {
        die("the outbox did not drain");
      }
    }
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    state.counters["messages"] = static_cast<double>(queued);
    state.SetItemsProcessed(state.items_processed() + queued);
  }
}
BENCHMARK(BM_OutboxThroughSender)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);

// The payload of a run message as the sender renders it, for the bare client to send.
std::string sample_payload() {
  const fs::path db = scratch("payload") / "runs.sqlite";
  RunStore store = store_with_runs(db, 1, false);
  Result<StoredRun> run = store.load_run(1);
  if (!run) die(run.error().message);
  return run_detail_json(*run).dump();
}

struct BareClient {
  std::mutex mutex;
  std::condition_variable acked_cv;
  int acked = 0;
  bool connected = false;
};

void BM_BareMosquittoQos1(benchmark::State& state) {
  const std::string payload = sample_payload();
  mosquitto_lib_init();
  BareClient client;
  mosquitto* m = mosquitto_new("bench-bare", true, &client);
  mosquitto_connect_callback_set(m, [](mosquitto*, void* self, int rc) {
    auto* c = static_cast<BareClient*>(self);
    std::lock_guard lock(c->mutex);
    c->connected = rc == 0;
    c->acked_cv.notify_all();
  });
  mosquitto_publish_callback_set(m, [](mosquitto*, void* self, int) {
    auto* c = static_cast<BareClient*>(self);
    std::lock_guard lock(c->mutex);
    ++c->acked;
    c->acked_cv.notify_all();
  });
  // No limit on messages in flight, as the broker allows (its max_inflight_messages).
  mosquitto_int_option(m, MOSQ_OPT_SEND_MAXIMUM, 65535);
  if (mosquitto_connect(m, "127.0.0.1", servers().broker.port(), 30) != MOSQ_ERR_SUCCESS) die("bare connect");
  mosquitto_loop_start(m);
  {
    std::unique_lock lock(client.mutex);
    if (!client.acked_cv.wait_for(lock, std::chrono::seconds(30), [&] { return client.connected; })) die("connack");
  }
  for (auto _ : state) {
    {
      std::lock_guard lock(client.mutex);
      client.acked = 0;
    }
    const auto start = std::chrono::steady_clock::now();
    for (int i = 0; i < kMessages; ++i) {
      if (mosquitto_publish(m, nullptr, "gaugeloop/bench/grinder-01/run", static_cast<int>(payload.size()),
                            payload.data(), 1, false) != MOSQ_ERR_SUCCESS) {
        die("bare publish");
      }
    }
    std::unique_lock lock(client.mutex);
    if (!client.acked_cv.wait_for(lock, std::chrono::minutes(5), [&] { return client.acked >= kMessages; })) {
      die("bare acknowledgements");
    }
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    state.SetItemsProcessed(state.items_processed() + kMessages);
  }
  state.counters["payload_bytes"] = static_cast<double>(payload.size());
  mosquitto_disconnect(m);
  mosquitto_loop_stop(m, false);
  mosquitto_destroy(m);
}
BENCHMARK(BM_BareMosquittoQos1)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);

// ---- the sync into PostgreSQL ----

// state.range(0): characteristics per run. With `per_degree`, each run's per-degree tables and
// raw revolutions too (plant sync --per-degree).
void sync_into_central(benchmark::State& state, bool per_degree) {
  const int characteristics = static_cast<int>(state.range(0));
  const std::string name = std::string(per_degree ? "sync_per_degree_" : "sync_") + std::to_string(characteristics);
  const fs::path db = scratch(name) / "runs.sqlite";
  RunStore store = store_with_runs(db, kSyncRuns, false, characteristics);
  const fs::path empty_db = scratch(name + "_empty") / "runs.sqlite";
  RunStore empty = store_with_runs(empty_db, 0, false);
  CentralSyncOptions options;
  options.per_degree = per_degree;
  int iteration = 0;
  for (auto _ : state) {
    const std::string url = new_database(name + "_" + std::to_string(iteration++));
    // The central schema made first, untimed, as it is once for a plant: what is timed is the
    // copy (connecting, checking the schema, reading the file and writing PostgreSQL).
    if (Result<CentralSyncCounts> made = sync_to_central(empty, url, "schema-maker"); !made) die(made.error().message);
    const auto start = std::chrono::steady_clock::now();
    Result<CentralSyncCounts> counts = sync_to_central(store, url, "grinder-01", options);
    if (!counts) die(counts.error().message);
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    if (counts->runs.inserted != kSyncRuns) die("the sync copied " + std::to_string(counts->runs.inserted));
    state.SetItemsProcessed(state.items_processed() + kSyncRuns);
  }
}
void BM_SyncIntoCentral(benchmark::State& state) { sync_into_central(state, false); }
BENCHMARK(BM_SyncIntoCentral)->Arg(6)->Arg(25)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);
void BM_SyncIntoCentralPerDegree(benchmark::State& state) { sync_into_central(state, true); }
BENCHMARK(BM_SyncIntoCentralPerDegree)->Arg(25)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);

// The bare baselines' tables: runs of the central runs table's width (45 columns) and
// characteristics of four, a primary key each.
void make_bare_tables(pqxx::connection& c) {
  pqxx::work w(c);
  std::string cols;
  for (int k = 0; k < 44; ++k) cols += ", c" + std::to_string(k) + (k % 2 ? " float8" : " text");
  w.exec("CREATE TABLE runs (uuid text PRIMARY KEY" + cols + ")");
  w.exec("CREATE TABLE chars (run_uuid text, position int, key text, value float8, PRIMARY KEY (run_uuid, position))");
  w.commit();
}

// As many rows of the central runs table's width (45 columns) and state.range(0)
// characteristic rows each, inserted by prepared statements one row each, 200 runs per
// transaction.
void BM_BarePqxxInsert(benchmark::State& state) {
  const int characteristics = static_cast<int>(state.range(0));
  int iteration = 0;
  for (auto _ : state) {
    const std::string url = new_database("bare_" + std::to_string(characteristics) + "_" + std::to_string(iteration++));
    pqxx::connection c(url);
    make_bare_tables(c);
    std::string params = "$1";
    for (int k = 0; k < 44; ++k) params += ", $" + std::to_string(k + 2);
    c.prepare("run", "INSERT INTO runs VALUES (" + params + ")");
    c.prepare("char", "INSERT INTO chars VALUES ($1, $2, $3, $4)");
    const auto start = std::chrono::steady_clock::now();
    for (int batch = 0; batch < kSyncRuns / 200; ++batch) {
      pqxx::work w(c);
      for (int i = 0; i < 200; ++i) {
        const std::string uuid = "run-" + std::to_string(batch * 200 + i);
        std::vector<std::string> v{uuid};
        for (int k = 0; k < 44; ++k) v.push_back(k % 2 ? std::to_string(1.5 * k) : "text-" + std::to_string(k));
        w.exec_prepared("run", pqxx::prepare::make_dynamic_params(v));
        for (int p = 0; p < characteristics; ++p) w.exec_prepared("char", uuid, p, "lift_error", 1.0 + p);
      }
      w.commit();
    }
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    state.SetItemsProcessed(state.items_processed() + kSyncRuns);
  }
}
BENCHMARK(BM_BarePqxxInsert)->Arg(6)->Arg(25)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);

// The same rows as BM_BarePqxxInsert, sent by COPY (libpqxx's stream_to) into the same bare
// tables, 200 runs per transaction: what PostgreSQL takes at its fastest, without a file to
// read, a conflict to check or progress to keep.
void BM_BarePqxxCopy(benchmark::State& state) {
  const int characteristics = static_cast<int>(state.range(0));
  int iteration = 0;
  for (auto _ : state) {
    const std::string url =
        new_database("bare_copy_" + std::to_string(characteristics) + "_" + std::to_string(iteration++));
    pqxx::connection c(url);
    make_bare_tables(c);
    const auto start = std::chrono::steady_clock::now();
    for (int batch = 0; batch < kSyncRuns / 200; ++batch) {
      pqxx::work w(c);
      std::vector<std::string> uuids;
      {
        pqxx::stream_to runs(w, "runs");
        for (int i = 0; i < 200; ++i) {
          std::array<std::string, 45> v;
          v[0] = "run-" + std::to_string(batch * 200 + i);
          uuids.push_back(v[0]);
          for (int k = 0; k < 44; ++k) {
            v[static_cast<std::size_t>(k) + 1] = k % 2 ? std::to_string(1.5 * k) : "text-" + std::to_string(k);
          }
          runs << v;
        }
        runs.complete();
      }
      pqxx::stream_to chars(w, "chars");
      for (const std::string& uuid : uuids) {
        for (int p = 0; p < characteristics; ++p) {
          chars << std::make_tuple(uuid, std::to_string(p), std::string("lift_error"), std::to_string(1.0 + p));
        }
      }
      chars.complete();
      w.commit();
    }
    state.SetIterationTime(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    state.SetItemsProcessed(state.items_processed() + kSyncRuns);
  }
}
BENCHMARK(BM_BarePqxxCopy)->Arg(6)->Arg(25)->UseManualTime()->Iterations(3)->Unit(benchmark::kMillisecond);

// ---- cross-machine queries at 1,000,000 central runs ----

// The central history with kCentralRuns runs: its schema made by a real sync of 8 runs, the
// rest generated in SQL (20 machines, 5 parts of 8 lobes, a run every 30 s per machine).
bool million_built = false;  // whether a benchmark asked for the history (print_server_times)

const std::string& million_url() {
  static const std::string url = [] {
    million_built = true;
    const std::string u = new_database("million");
    const fs::path db = scratch("million") / "runs.sqlite";
    RunStore store = store_with_runs(db, 8, false);
    Result<CentralSyncCounts> counts = sync_to_central(store, u, "grinder-01");
    if (!counts) die(counts.error().message);
    pqxx::connection c(u);
    pqxx::work w(c);
    w.exec(
        "INSERT INTO runs (uuid, source_machine, source, local_id, started_utc, finished_utc, machine, part, lobe,"
        " gauge, status, revolutions, degrees_captured, polls, reconnects, discarded_revolutions, zero_offset_mm,"
        " max_abs_error_um, rms_error_um, peak_to_valley_um, repeatability_um, phase_error_deg,"
        " base_circle_runout_um, inspection, verdict, lift_error_reference, synced_utc)"
        " SELECT md5(g::text)::uuid::text, 'grinder-' || lpad((g % 20)::text, 2, '0'), '/bench', g,"
        " to_char(timestamp '2026-01-01' + (g / 20) * interval '30 seconds', 'YYYY-MM-DD\"T\"HH24:MI:SS\"Z\"'),"
        " to_char(timestamp '2026-01-01' + (g / 20) * interval '30 seconds', 'YYYY-MM-DD\"T\"HH24:MI:SS\"Z\"'),"
        " 'grinder-' || lpad((g % 20)::text, 2, '0'), 'cam_' || ((g / 20) % 5), 1 + (g / 100) % 8,"
        " 'tcp:127.0.0.1:1502', 'measured', 3, 1080, 1200, 0, 0, 0.0, 2.0 + (g % 100) * 0.01, 1.0, 4.0, 0.2,"
        " 0.01, 0.5, false, CASE WHEN g % 50 = 0 THEN 'out' ELSE 'in' END, 'best_fit', '2026-12-01T00:00:00Z'"
        " FROM generate_series(1, " +
        std::to_string(kCentralRuns - 8) + ") AS g");
    // 25 characteristics a run, the size of a judged lobe, one row of arrays a run.
    w.exec(
        "INSERT INTO run_characteristic_sets SELECT r.uuid, k.keys, k.units,"
        " ARRAY(SELECT (r.local_id % 100) * 0.01 + i * 0.5 FROM generate_series(1, 25) AS i),"
        " k.zeros, k.zeros, k.lower, k.upper, k.verdicts, k.nulls, k.nulls"
        " FROM runs AS r, (SELECT array_agg('zone_' || i) AS keys, array_agg('um'::text) AS units,"
        " array_agg(0.0::float8) AS zeros, array_agg(-12.0::float8) AS lower, array_agg(12.0::float8) AS upper,"
        " array_agg('in'::text) AS verdicts, array_agg(NULL::integer) AS nulls FROM generate_series(1, 25) AS i) AS k"
        " WHERE r.source = '/bench'");
    w.commit();
    pqxx::nontransaction(c).exec("VACUUM ANALYZE runs");
    pqxx::nontransaction(c).exec("VACUUM ANALYZE run_characteristic_sets");
    // The generated gigabyte written out now, not by a checkpoint during the measurements.
    pqxx::nontransaction(c).exec("CHECKPOINT");
    // Every statement of the queries' sessions in the server's log with its duration: the
    // server's own time, printed at the end (server_times).
    pqxx::nontransaction(c).exec("ALTER DATABASE " + std::string(c.dbname()) + " SET log_min_duration_statement = 0");
    return u;
  }();
  return url;
}

const CentralHistory& million() {
  static CentralHistory history = [] {
    Result<CentralHistory> h = CentralHistory::open(million_url());
    if (!h) die(h.error().message);
    return std::move(h).value();
  }();
  return history;
}

void run_query(benchmark::State& state, const RunQuery& q, bool trend) {
  const CentralHistory& h = million();
  std::size_t rows = 0;
  for (auto _ : state) {
    Result<std::vector<RunSummary>> r = trend ? h.trend(q) : h.list_runs(q);
    if (!r) die(r.error().message);
    rows = r->size();
    benchmark::DoNotOptimize(rows);
  }
  state.counters["rows"] = static_cast<double>(rows);
}

void BM_CentralLastRunsOfALobeAllMachines(benchmark::State& state) {
  RunQuery q;
  q.part = "cam_3";
  q.lobe = 4;
  run_query(state, q, false);
}
BENCHMARK(BM_CentralLastRunsOfALobeAllMachines)->Unit(benchmark::kMillisecond);

void BM_CentralTrend30DaysAllMachines(benchmark::State& state) {
  RunQuery q;
  q.part = "cam_3";
  q.lobe = 4;
  q.since_utc = "2026-01-10T00:00:00Z";
  q.until_utc = "2026-02-09T00:00:00Z";
  q.limit = 100000;
  run_query(state, q, true);
}
BENCHMARK(BM_CentralTrend30DaysAllMachines)->Unit(benchmark::kMillisecond);

// The same 30 days, the newest 1,000 runs of them (`runs trend --limit 1000`; its default is 200).
void BM_CentralTrend30DaysDefaultWindow(benchmark::State& state) {
  RunQuery q;
  q.part = "cam_3";
  q.lobe = 4;
  q.since_utc = "2026-01-10T00:00:00Z";
  q.until_utc = "2026-02-09T00:00:00Z";
  q.limit = 1000;
  run_query(state, q, true);
}
BENCHMARK(BM_CentralTrend30DaysDefaultWindow)->Unit(benchmark::kMillisecond);

void BM_CentralLastRunsOfOneMachine(benchmark::State& state) {
  RunQuery q;
  q.machine = "grinder-07";
  run_query(state, q, false);
}
BENCHMARK(BM_CentralLastRunsOfOneMachine)->Unit(benchmark::kMillisecond);

// What a query command pays beyond its process start: connect, check the schema, list the
// newest 50 runs of one lobe on every machine.
void BM_CentralOpenAndListRuns(benchmark::State& state) {
  const std::string url = million_url();
  RunQuery q;
  q.part = "cam_3";
  q.lobe = 4;
  for (auto _ : state) {
    Result<CentralHistory> h = CentralHistory::open(url);
    if (!h) die(h.error().message);
    Result<std::vector<RunSummary>> r = h->list_runs(q);
    if (!r || r->size() != 50) die("the list found no runs");
  }
}
BENCHMARK(BM_CentralOpenAndListRuns)->Unit(benchmark::kMillisecond);

// `runs spc --db` of one lobe with its default window (125 runs of 25 characteristics), the
// connection open.
void BM_CentralSpcOfALobe(benchmark::State& state) {
  const CentralHistory& h = million();
  RunQuery q;
  q.part = "cam_3";
  q.lobe = 4;
  q.limit = 125;
  for (auto _ : state) {
    Result<CharacteristicSummaries> s = h.characteristic_summaries(q);
    if (!s || s->runs != 125 || s->by_key.size() != 25) die("the SPC summed up no runs");
    benchmark::DoNotOptimize(s);
  }
}
BENCHMARK(BM_CentralSpcOfALobe)->Unit(benchmark::kMillisecond);

// The bare baseline of a command's connection: libpqxx connects and selects one run by UUID.
void BM_BareConnectAndSelectOneRun(benchmark::State& state) {
  const std::string url = million_url();
  const std::string uuid = pqxx::nontransaction(*std::make_unique<pqxx::connection>(url))
                               .exec1("SELECT md5('4711')::uuid::text")[0]
                               .as<std::string>();
  for (auto _ : state) {
    pqxx::connection c(url);
    pqxx::nontransaction w(c);
    pqxx::result r = w.exec_params("SELECT * FROM runs WHERE uuid = $1", uuid);
    if (r.size() != 1) die("the bare select found no run");
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_BareConnectAndSelectOneRun)->Unit(benchmark::kMillisecond);

void BM_BareSelectOneRunByUuid(benchmark::State& state) {
  pqxx::connection c(million_url());
  c.prepare("one", "SELECT * FROM runs WHERE uuid = $1");
  const std::string uuid = pqxx::nontransaction(c).exec1("SELECT md5('4711')::uuid::text")[0].as<std::string>();
  for (auto _ : state) {
    pqxx::nontransaction w(c);
    pqxx::result r = w.exec_prepared("one", uuid);
    if (r.size() != 1) die("the bare select found no run");
    benchmark::DoNotOptimize(r);
  }
}
BENCHMARK(BM_BareSelectOneRunByUuid)->Unit(benchmark::kMillisecond);

// The server's own time for each statement the 1,000,000-run history answered, from its log
// (log_min_duration_statement = 0 on that database): the medians of parse, bind (planning) and
// execute, per statement and parameters, printed after the benchmarks.
void print_server_times() {
  if (!million_built) return;
  std::ifstream log(servers().postgres.log_path());
  std::map<std::string, std::vector<double>> phases;  // "<phase> <statement>" -> ms
  std::string line, pending_phase, pending_sql;
  double pending_ms = 0.0;
  auto flush = [&](const std::string& parameters) {
    if (pending_phase.empty()) return;
    phases[pending_sql + (parameters.empty() ? "" : " [" + parameters + "]") + "\t" + pending_phase].push_back(
        pending_ms);
    pending_phase.clear();
  };
  while (std::getline(log, line)) {
    const std::size_t d = line.find("duration: ");
    const std::size_t p = line.find("DETAIL:  parameters: ");
    if (p != std::string::npos) {
      flush(line.substr(p + 21));
      continue;
    }
    flush("");
    if (d == std::string::npos) continue;
    const double ms = std::strtod(line.c_str() + d + 10, nullptr);
    for (const char* phase : {"parse", "bind", "execute"}) {
      const std::size_t at = line.find(std::string("ms  ") + phase + " ");
      if (at == std::string::npos) continue;
      const std::size_t colon = line.find(": ", at);
      if (colon == std::string::npos) break;
      pending_sql = line.substr(colon + 2, 40);
      pending_phase = phase;
      pending_ms = ms;
    }
  }
  flush("");
  if (phases.empty()) return;
  std::printf("\nserver time of each statement on the 1,000,000-run history (its log; median ms of n):\n");
  for (auto& [key, v] : phases) {
    if (v.size() < 10) continue;
    std::sort(v.begin(), v.end());
    std::printf("  %-8.3f n=%-6zu %s\n", v[v.size() / 2], v.size(), key.c_str());
  }
}

}  // namespace
}  // namespace gaugeloop

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  gaugeloop::print_server_times();
  std::filesystem::remove_all(std::filesystem::temp_directory_path() /
                              ("gaugeloop-plant-bench-" + std::to_string(::getpid())));
  return 0;
}
