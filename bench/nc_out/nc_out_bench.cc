// Curve-table writer benchmarks: the default table of a sample lobe (every candidate the
// choice tries: linear and spline at fixed steps, adaptive linear, adaptive spline), against a
// yardstick timed in the same loop so the ratio holds on a loaded machine: a bare loop (no
// gaugeloop code) reading a cubic through 5 deg knots at every fine row of C and comparing it
// with the path, the unit of work the adaptive writers repeat.
// Results and the command that produced them: docs/PERFORMANCE.md.
#include <benchmark/benchmark.h>

#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "bench/sample_lobes.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "core/lift_table.h"
#include "nc_out/table_writer.h"

namespace gaugeloop {
namespace {

using bench::or_die;
using bench::thread_cpu_s;

constexpr double kFineStepDeg = 0.01;  // the fine path a run's table is written from

// The wheel path of sample lobe 0 (intake_flat, flat follower, 200 mm wheel) or 1
// (exhaust_roller, 11 mm roller, 45 mm wheel) at the fine step, as a run writes it.
SampledPath lobe_path(int which) {
  const auto [part, design] = bench::sample_lobe(which);
  const PeriodicSpline lift = or_die(PeriodicSpline::fit(design.angle_deg, design.lift_mm), "spline");
  MachinePath m = or_die(compute_machine_path(lift, part, kFineStepDeg), "wheel path");
  SampledPath out;
  out.c_step_deg = kFineStepDeg;
  out.x_mm = std::move(m.x_mm);
  out.dx_dc_mm_per_deg = std::move(m.dx_dc_mm_per_deg);
  out.d2x_dc2_mm_per_deg2 = std::move(m.d2x_dc2_mm_per_deg2);
  return out;
}

// The yardstick: the largest |cubic Hermite through the path's rows every 5 deg - X| over
// every fine row, in a plain loop.
double bare_scan_mm(const SampledPath& path) {
  const std::size_t n = path.x_mm.size();
  const std::size_t step = 500;  // 5 deg of 0.01 deg rows
  const double h = static_cast<double>(step) * path.c_step_deg;
  double worst = 0.0;
  for (std::size_t k = 0; k < n; k += step) {
    const std::size_t k1 = (k + step) % n;
    const double y0 = path.x_mm[k];
    const double y1 = path.x_mm[k1];
    const double m0 = h * path.dx_dc_mm_per_deg[k];
    const double m1 = h * path.dx_dc_mm_per_deg[k1];
    for (std::size_t j = 0; j < step; ++j) {
      const double p = static_cast<double>(j) / static_cast<double>(step);
      const double x = (2 * p * p * p - 3 * p * p + 1) * y0 + (p * p * p - 2 * p * p + p) * m0 +
                       (-2 * p * p * p + 3 * p * p) * y1 + (p * p * p - p * p) * m1;
      worst = std::max(worst, std::abs(x - path.x_mm[k + j]));
    }
  }
  return worst;
}

// Each iteration: the default table, then the yardstick. Counters: thread CPU time per call
// (ms), the ratio, and the blocks of the table chosen.
void BM_DefaultTable(benchmark::State& state) {
  const SampledPath path = lobe_path(static_cast<int>(state.range(0)));
  double table_s = 0.0;
  double scan_s = 0.0;
  std::size_t blocks = 0;
  std::int64_t n = 0;
  for (auto _ : state) {
    const double t0 = thread_cpu_s();
    const CurveTable t = or_die(write_default_table(path, TableChoiceSettings{}, CurveTableFormat{}), "default table");
    const double t1 = thread_cpu_s();
    benchmark::DoNotOptimize(bare_scan_mm(path));
    const double t2 = thread_cpu_s();
    table_s += t1 - t0;
    scan_s += t2 - t1;
    blocks = t.block_count();
    ++n;
  }
  state.counters["table_ms"] = 1e3 * table_s / static_cast<double>(n);
  state.counters["scan_ms"] = 1e3 * scan_s / static_cast<double>(n);
  state.counters["table_per_scan"] = table_s / scan_s;
  state.counters["blocks"] = static_cast<double>(blocks);
}
BENCHMARK(BM_DefaultTable)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond)->MinTime(2.0);

}  // namespace
}  // namespace gaugeloop

BENCHMARK_MAIN();
