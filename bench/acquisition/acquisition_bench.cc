// Acquisition benchmarks against the in-process simulator over loopback TCP (and RTU on a pty):
//  - request throughput of the gauge client against a bare libmodbus read loop, same run;
//  - the highest spindle speed at which a 3-revolution run misses no degree, per mode;
//  - CPU time of the poller's thread during a run.
// Results and the command that produced them: docs/PERFORMANCE.md.
#include <benchmark/benchmark.h>
#include <modbus/modbus.h>
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "acquisition/modbus_gauge.h"
#include "acquisition/poller.h"
#include "simulator/gauge_simulator.h"
#include "tests/support/intake_simulator.h"
#include "tests/support/pty_pair.h"

namespace gaugeloop {
namespace {

using SteadyClock = std::chrono::steady_clock;

std::unique_ptr<GaugeSimulator> start_sim(double speed_rpm, const std::string& rtu_device = {}) {
  SimulatorSettings ss;
  ss.speed_rpm = speed_rpm;
  ss.sample_rate_hz = 100000.0;  // a fast amplifier: the bus, not the amplifier, sets the limit
  ss.rtu_device = rtu_device;    // empty: TCP; else RTU at 115200 baud, replies held to line time
  auto sim = testing::start_intake_simulator(ss);
  if (!sim) {
    std::fprintf(stderr, "simulator: %s\n", sim.error().message.c_str());
    std::abort();  // a benchmark on a simulator that did not start measures nothing
  }
  return std::move(*sim);
}

double thread_cpu_s() {
  rusage u{};
  ::getrusage(RUSAGE_THREAD, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
}

// Alternates 500 bare libmodbus reads of the snapshot block with 500 snapshot reads through
// ModbusGauge (block planning, decoding, status translation), on two connections to the
// same simulator, so both see the same machine at the same moment.
void BM_SnapshotReadsVersusBareLibmodbus(benchmark::State& state) {
  auto sim = start_sim(60.0);
  modbus_t* bare = modbus_new_tcp("127.0.0.1", sim->port());
  modbus_connect(bare);
  ModbusSettings ms;
  ms.port = sim->port();
  ModbusGauge gauge(ms);
  (void)gauge.connect();
  std::uint16_t regs[16];
  double bare_s = 0.0;
  double ours_s = 0.0;
  std::int64_t reads = 0;
  for (auto _ : state) {
    const auto t0 = SteadyClock::now();
    for (int i = 0; i < 500; ++i) benchmark::DoNotOptimize(modbus_read_input_registers(bare, 0, 7, regs));
    const auto t1 = SteadyClock::now();
    for (int i = 0; i < 500; ++i) benchmark::DoNotOptimize(gauge.read_snapshot());
    const auto t2 = SteadyClock::now();
    bare_s += std::chrono::duration<double>(t1 - t0).count();
    ours_s += std::chrono::duration<double>(t2 - t1).count();
    reads += 500;
  }
  state.counters["bare_reads_per_s"] = static_cast<double>(reads) / bare_s;
  state.counters["gauge_reads_per_s"] = static_cast<double>(reads) / ours_s;
  state.counters["ratio"] = bare_s / ours_s;  // gaugeloop's rate over the bare loop's
  modbus_close(bare);
  modbus_free(bare);
}
BENCHMARK(BM_SnapshotReadsVersusBareLibmodbus)->Unit(benchmark::kMillisecond)->MinTime(2.0);

// What the platform allows live polling: a bare libmodbus loop reading the snapshot block
// back to back for 4 s, and the time between consecutive replies. Live mode loses a degree
// whenever that time exceeds the gap limit (1 deg: 278 us at 600 rpm, 2.8 ms at 60 rpm).
// No gaugeloop code runs here but the simulator: these stalls are the machine's.
void BM_ReplyGapsBareLibmodbus(benchmark::State& state) {
  auto sim = start_sim(600.0);
  modbus_t* bare = modbus_new_tcp("127.0.0.1", sim->port());
  modbus_connect(bare);
  std::uint16_t regs[16];
  std::vector<double> gaps_us;
  double seconds = 0.0;
  for (auto _ : state) {
    const auto t0 = SteadyClock::now();
    auto last = t0;
    while (last - t0 < std::chrono::seconds(4)) {
      benchmark::DoNotOptimize(modbus_read_input_registers(bare, 0, 7, regs));
      const auto now = SteadyClock::now();
      gaps_us.push_back(std::chrono::duration<double, std::micro>(now - last).count());
      last = now;
    }
    seconds += std::chrono::duration<double>(last - t0).count();
  }
  const auto over = [&](double us) {
    return static_cast<double>(std::count_if(gaps_us.begin(), gaps_us.end(), [us](double g) { return g > us; }));
  };
  state.counters["over_278us_per_s"] = over(278.0) / seconds;
  state.counters["over_1ms_per_s"] = over(1000.0) / seconds;
  state.counters["over_2800us_per_s"] = over(2800.0) / seconds;
  std::sort(gaps_us.begin(), gaps_us.end());
  state.counters["median_us"] = gaps_us[gaps_us.size() / 2];
  state.counters["max_us"] = gaps_us.back();
  modbus_close(bare);
  modbus_free(bare);
}
BENCHMARK(BM_ReplyGapsBareLibmodbus)->Iterations(1)->Unit(benchmark::kSecond);

// One 3-revolution run with no spare revolution: true if every degree of every revolution
// was sampled. Also reports the poller thread's CPU time over the run's wall time.
// `compact`: read the simulator's compact latch ring (2 registers an entry, the degree implied
// by the latch count) instead of its 4-register entries.
bool clean_run(SamplingMode mode, double rpm, double* cpu_fraction, int spares = 0, bool rtu = false,
               bool compact = false, int revolutions = 3) {
  testing::PtyPair pty;  // only used for RTU
  auto sim = start_sim(rpm, rtu ? pty.simulator_end() : std::string());
  ModbusSettings ms;
  ms.port = sim->port();
  if (rtu) {
    ms.transport = ModbusTransport::kRtu;
    ms.device = pty.gauge_end();
    ms.baud = 115200;
  }
  if (compact) ms.map = testing::compact_simulator_map();
  ModbusGauge gauge(ms);
  PollerSettings ps;
  ps.mode = mode;
  ps.spare_revolutions = spares;
  ps.revolutions = revolutions;
  ps.run_timeout = std::chrono::milliseconds(40000);
  Poller poller(gauge, ps);
  const double cpu0 = thread_cpu_s();
  const auto t0 = SteadyClock::now();
  const auto measured = poller.measure();
  const bool ok = measured.ok();
  if (cpu_fraction != nullptr) {
    *cpu_fraction = (thread_cpu_s() - cpu0) / std::chrono::duration<double>(SteadyClock::now() - t0).count();
  }
  if (!ok) std::fprintf(stderr, "  %.0f rpm: %s\n", rpm, measured.error().message.c_str());  // why the ladder stops
  return ok;
}

// The highest speed of the ladder at which two runs in a row complete: with `spares` 0, no
// revolution may miss a degree; with the product's default 3, up to 3 may be replaced.
void max_clean_rpm(benchmark::State& state, SamplingMode mode, int spares = 0, bool rtu = false, bool compact = false,
                   int revolutions = 3) {
  // Up to the simulator's limit of 10000 rpm; RTU from 20 rpm, as its bus is slow.
  const std::vector<double> tcp_ladder = {30,   60,   120,  240,  480,  600,  900,  1200,
                                          1800, 2400, 3000, 4500, 6000, 9000, 10000};
  const std::vector<double> rtu_ladder = {20,  30,  45,  60,  90,  120, 150, 180, 210, 240,
                                          270, 300, 330, 360, 390, 420, 480, 540, 600};
  // Long runs: what the bus sustains once the ring can no longer hide a deficit. From 180 rpm.
  const std::vector<double> long_ladder = {180, 210, 240, 270, 300, 330, 360, 390, 420, 480, 540, 600};
  double best = 0.0;
  for (auto _ : state) {
    best = 0.0;
    for (double rpm : !rtu ? tcp_ladder : revolutions > 3 ? long_ladder : rtu_ladder) {
      if (!clean_run(mode, rpm, nullptr, spares, rtu, compact, revolutions) ||
          !clean_run(mode, rpm, nullptr, spares, rtu, compact, revolutions)) {
        break;
      }
      best = rpm;
    }
  }
  state.counters["max_clean_rpm"] = best;
}

void BM_MaxCleanRpmLatchedTcp(benchmark::State& state) { max_clean_rpm(state, SamplingMode::kLatched); }
void BM_MaxCleanRpmLiveTcp(benchmark::State& state) { max_clean_rpm(state, SamplingMode::kLive); }
void BM_MaxCompleteRpmLiveTcp(benchmark::State& state) { max_clean_rpm(state, SamplingMode::kLive, 3); }
void BM_MaxCleanRpmLatchedRtu(benchmark::State& state) { max_clean_rpm(state, SamplingMode::kLatched, 0, true); }
void BM_MaxCleanRpmLatchedCompactRtu(benchmark::State& state) {
  max_clean_rpm(state, SamplingMode::kLatched, 0, true, true);
}
// 20-revolution runs: a 3-revolution run can outrun the bus while the ring absorbs the lag.
void BM_MaxCleanRpmLatched20RevRtu(benchmark::State& state) {
  max_clean_rpm(state, SamplingMode::kLatched, 0, true, false, 20);
}
void BM_MaxCleanRpmLatchedCompact20RevRtu(benchmark::State& state) {
  max_clean_rpm(state, SamplingMode::kLatched, 0, true, true, 20);
}
void BM_MaxCleanRpmLiveRtu(benchmark::State& state) { max_clean_rpm(state, SamplingMode::kLive, 0, true); }
void BM_MaxCompleteRpmLiveRtu(benchmark::State& state) { max_clean_rpm(state, SamplingMode::kLive, 3, true); }
BENCHMARK(BM_MaxCleanRpmLatchedTcp)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCleanRpmLatchedRtu)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCleanRpmLatchedCompactRtu)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCleanRpmLatched20RevRtu)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCleanRpmLatchedCompact20RevRtu)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCleanRpmLiveRtu)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCompleteRpmLiveRtu)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCleanRpmLiveTcp)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_MaxCompleteRpmLiveTcp)->Iterations(1)->Unit(benchmark::kSecond);

// Live mode over TCP at each speed on its own, not a ladder: of 5 runs with the product's
// default 3 spare revolutions, how many complete. A stall of the machine costs the revolution
// it falls in; stalls come at a rate per second (BM_ReplyGapsBareLibmodbus), so a short
// revolution is hit less often than a long one, and a faster spindle can fare better than a
// slower one until the polls themselves come more than 1 degree apart.
void BM_LiveTcpCompleteRunsBySpeed(benchmark::State& state) {
  const std::vector<double> speeds = {60, 120, 240, 600, 1200, 2400, 3000, 4500};
  for (auto _ : state) {
    for (double rpm : speeds) {
      int complete = 0;
      for (int i = 0; i < 5; ++i) complete += clean_run(SamplingMode::kLive, rpm, nullptr, 3) ? 1 : 0;
      state.counters["complete_of_5_at_" + std::to_string(static_cast<int>(rpm))] = complete;
    }
  }
}
BENCHMARK(BM_LiveTcpCompleteRunsBySpeed)->Iterations(1)->Unit(benchmark::kSecond);

// CPU of the poller's thread during a 60 rpm run: how much of one core measuring costs.
void poller_cpu(benchmark::State& state, SamplingMode mode) {
  double fraction = 0.0;
  for (auto _ : state) clean_run(mode, 60.0, &fraction);
  state.counters["poller_cpu_percent"] = fraction * 100.0;
}
void BM_PollerCpuLatched60Rpm(benchmark::State& state) { poller_cpu(state, SamplingMode::kLatched); }
void BM_PollerCpuLive60Rpm(benchmark::State& state) { poller_cpu(state, SamplingMode::kLive); }
BENCHMARK(BM_PollerCpuLatched60Rpm)->Iterations(1)->Unit(benchmark::kSecond);
BENCHMARK(BM_PollerCpuLive60Rpm)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace
}  // namespace gaugeloop

BENCHMARK_MAIN();
