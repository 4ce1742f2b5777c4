// Compensation benchmarks: one lobe from a measured run to the next wheel path (analysis,
// correction decision, 0.1 deg corrected path), end to end, against yardsticks timed in the
// same loop so the ratios hold on a loaded machine:
//  - the design's own 0.1 deg wheel path, the least work any correction must redo;
//  - one 360-point Eigen FFT, the unit the analysis and the smoothing are built from.
// Results and the command that produced them: docs/PERFORMANCE.md.
#include <benchmark/benchmark.h>

#include <time.h>

#include <cmath>
#include <complex>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include <unsupported/Eigen/FFT>

#include "bench/sample_lobes.h"
#include "compensation/analysis.h"
#include "compensation/correction.h"
#include "compensation/flat_probe.h"
#include "compensation/periodic_spline.h"
#include "compensation/wheel_path.h"
#include "core/lift_table.h"

namespace gaugeloop {
namespace {

using bench::or_die;
using bench::thread_cpu_s;

// The sample lobes: 0 intake_flat (flat follower, 200 mm wheel), 1 exhaust_roller (11 mm
// roller, 45 mm wheel, concave flanks).
struct Lobe {
  LiftTable design;
  Part part;
  PeriodicSpline lift;
  DesignReading reading;
  MeasuredRun run;
};

Lobe load_lobe(int which) {
  auto [part, design] = bench::sample_lobe(which);
  PeriodicSpline lift = or_die(PeriodicSpline::fit(design.angle_deg, design.lift_mm), "spline");
  DesignReading reading = or_die(DesignReading::of_lobe(lift, part), "design reading");
  // A ground lobe as the gauge sees it: the design, a 12 um smooth form error, a 0.05 deg lag,
  // 0.3 um RMS of noise per sample, 3 revolutions.
  std::mt19937 rng(1);
  std::normal_distribution<double> noise(0.0, 0.3e-3);
  MeasuredRun run;
  for (int r = 0; r < 3; ++r) {
    RevolutionSamples rev;
    rev.revolution = r;
    for (int c = 0; c < 360; ++c) {
      const double t = c * std::numbers::pi / 180.0;
      rev.lift_mm[static_cast<size_t>(c)] =
          reading.at(c - 0.05) + 0.008 * std::cos(2 * t + 0.3) + 0.004 * std::sin(3 * t + 1.1) + 0.25 + noise(rng);
    }
    run.revolutions.push_back(rev);
  }
  return {std::move(design), part, std::move(lift), std::move(reading), std::move(run)};
}

// One lobe, measured run to next wheel path, as measure_job would run it with the model.
// The model (DesignReading::of_lobe) is made once per part, before measuring, and reused by
// every run of that part: it is not in this figure but timed apart (BM_DesignReading).
WheelPath end_to_end(const Lobe& lobe) {
  const LobeAnalysis a = or_die(analyse_lobe(lobe.run, lobe.reading, lobe.part, AnalysisSettings{}), "analysis");
  const CompensationDecision d =
      or_die(decide_correction(a, lobe.reading, DegreeTable{}, CompensationSettings{}), "decision");
  return or_die(corrected_wheel_path(lobe.design, lobe.reading, d.correction_um, lobe.part, 0.1), "corrected path");
}

// The same with tables only (analyse_lobe on the design table, next_correction), the calls
// app/measure_job.cc makes today.
WheelPath end_to_end_tables_only(const Lobe& lobe) {
  const LobeAnalysis a =
      or_die(analyse_lobe(lobe.run, lobe.reading.table(), lobe.part, AnalysisSettings{}), "analysis");
  const DegreeTable c = or_die(next_correction(a, DegreeTable{}, CompensationSettings{}), "correction");
  return or_die(corrected_wheel_path(lobe.design, c, lobe.part, 0.1), "corrected path");
}

std::vector<std::complex<double>> fft360(const std::vector<double>& in) {
  Eigen::FFT<double> fft;
  std::vector<std::complex<double>> out;
  fft.fwd(out, in);
  return out;
}

// Each iteration: the end-to-end step, then the design path, then 100 FFTs (one is too
// short for the clock), so every figure sees the same machine state. Counters are thread
// CPU time per call, in microseconds, and their ratios.
void run_against_yardsticks(benchmark::State& state, WheelPath (*step)(const Lobe&)) {
  const Lobe lobe = load_lobe(static_cast<int>(state.range(0)));
  const std::vector<double> fft_input(lobe.reading.table().begin(), lobe.reading.table().end());
  double step_s = 0.0;
  double path_s = 0.0;
  double fft_s = 0.0;
  std::int64_t n = 0;
  for (auto _ : state) {
    const double t0 = thread_cpu_s();
    benchmark::DoNotOptimize(step(lobe));
    const double t1 = thread_cpu_s();
    benchmark::DoNotOptimize(or_die(compute_wheel_path(lobe.lift, lobe.part, 0.1), "design path"));
    const double t2 = thread_cpu_s();
    for (int i = 0; i < 100; ++i) benchmark::DoNotOptimize(fft360(fft_input));
    const double t3 = thread_cpu_s();
    step_s += t1 - t0;
    path_s += t2 - t1;
    fft_s += (t3 - t2) / 100.0;
    ++n;
  }
  state.SetLabel(lobe.part.name);
  state.counters["step_us"] = 1e6 * step_s / static_cast<double>(n);
  state.counters["design_path_us"] = 1e6 * path_s / static_cast<double>(n);
  state.counters["fft360_us"] = 1e6 * fft_s / static_cast<double>(n);
  state.counters["step_per_design_path"] = step_s / path_s;
  state.counters["step_per_fft360"] = step_s / fft_s;
}

void BM_EndToEnd(benchmark::State& state) { run_against_yardsticks(state, end_to_end); }
BENCHMARK(BM_EndToEnd)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)->MinTime(2.0);

void BM_EndToEndTablesOnly(benchmark::State& state) { run_against_yardsticks(state, end_to_end_tables_only); }
BENCHMARK(BM_EndToEndTablesOnly)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond)->MinTime(2.0);

// The parts alone, to see where the time goes.
void BM_AnalyseLobe(benchmark::State& state) {
  const Lobe lobe = load_lobe(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(analyse_lobe(lobe.run, lobe.reading, lobe.part, AnalysisSettings{}));
  state.SetLabel(lobe.part.name);
}
BENCHMARK(BM_AnalyseLobe)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_DecideCorrection(benchmark::State& state) {
  const Lobe lobe = load_lobe(static_cast<int>(state.range(0)));
  const LobeAnalysis a = or_die(analyse_lobe(lobe.run, lobe.reading, lobe.part, AnalysisSettings{}), "analysis");
  for (auto _ : state) {
    benchmark::DoNotOptimize(decide_correction(a, lobe.reading, DegreeTable{}, CompensationSettings{}));
  }
  state.SetLabel(lobe.part.name);
}
BENCHMARK(BM_DecideCorrection)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_CorrectedWheelPath(benchmark::State& state) {
  const Lobe lobe = load_lobe(static_cast<int>(state.range(0)));
  const LobeAnalysis a = or_die(analyse_lobe(lobe.run, lobe.reading, lobe.part, AnalysisSettings{}), "analysis");
  const CompensationDecision d =
      or_die(decide_correction(a, lobe.reading, DegreeTable{}, CompensationSettings{}), "decision");
  for (auto _ : state) {
    benchmark::DoNotOptimize(corrected_wheel_path(lobe.design, lobe.reading, d.correction_um, lobe.part, 0.1));
  }
  state.SetLabel(lobe.part.name);
}
BENCHMARK(BM_CorrectedWheelPath)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// The same without the model: corrected_lift finds the contacts again (the table-only call).
void BM_CorrectedWheelPathTablesOnly(benchmark::State& state) {
  const Lobe lobe = load_lobe(static_cast<int>(state.range(0)));
  const LobeAnalysis a = or_die(analyse_lobe(lobe.run, lobe.reading, lobe.part, AnalysisSettings{}), "analysis");
  const CompensationDecision d =
      or_die(decide_correction(a, lobe.reading, DegreeTable{}, CompensationSettings{}), "decision");
  for (auto _ : state) benchmark::DoNotOptimize(corrected_wheel_path(lobe.design, d.correction_um, lobe.part, 0.1));
  state.SetLabel(lobe.part.name);
}
BENCHMARK(BM_CorrectedWheelPathTablesOnly)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

void BM_DesignWheelPath(benchmark::State& state) {
  const Lobe lobe = load_lobe(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(compute_wheel_path(lobe.lift, lobe.part, 0.1));
  state.SetLabel(lobe.part.name);
}
BENCHMARK(BM_DesignWheelPath)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

// Once per part, before measuring: the design reading model, with the contacts
// corrected_lift reuses. Not part of BM_EndToEnd.
void BM_DesignReading(benchmark::State& state) {
  const Lobe lobe = load_lobe(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(DesignReading::of_lobe(lobe.lift, lobe.part));
  state.SetLabel(lobe.part.name);
}
BENCHMARK(BM_DesignReading)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace gaugeloop

BENCHMARK_MAIN();
