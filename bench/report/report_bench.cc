// The trend plot's SVG (what GET /api/trend.svg sends) for a lobe's newest 200 runs, against a
// bare cairo SVG page holding the same 200 values as one line and their dots.
#include <benchmark/benchmark.h>
#include <cairo-svg.h>
#include <cairo.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "report/cam_report.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

// `n` runs of one lobe, a day apart, each with the plotted characteristic: a slow wave with
// one run in twenty out of tolerance, the limits tightened half way.
std::vector<RunCharacteristics> sample_trend(int n) {
  std::vector<RunCharacteristics> out;
  for (int i = 0; i < n; ++i) {
    RunCharacteristics r;
    r.run.id = 100000 + i;
    r.run.part = "cam_1";
    r.run.lobe = 3;
    char started[32];
    std::snprintf(started, sizeof started, "2026-%02d-%02dT06:00:00Z", 1 + (i / 28) % 12, 1 + i % 28);
    r.run.started_utc = started;
    Characteristic c;
    c.key = "lift_error.zone3";
    c.unit = "um";
    c.value = 6.0 * std::sin(0.21 * i) + (i % 20 == 7 ? 9.0 : 0.0);
    c.limits = i < n / 2 ? Limits{-12.0, 12.0} : Limits{-8.0, 8.0};
    c.verdict = std::abs(c.value) > *c.limits.upper ? Verdict::kOut : Verdict::kIn;
    r.characteristics.push_back(c);
    out.push_back(std::move(r));
  }
  return out;
}

void BM_TrendPlotSvg(benchmark::State& state) {
  const std::vector<RunCharacteristics> runs = sample_trend(static_cast<int>(state.range(0)));
  std::size_t bytes = 0;
  for (auto _ : state) {
    Result<std::string> svg = trend_plot_svg(runs, "lift_error.zone3");
    if (!svg) {
      state.SkipWithError(svg.error().message.c_str());
      return;
    }
    bytes = svg->size();
    benchmark::DoNotOptimize(svg->data());
  }
  state.counters["bytes"] = static_cast<double>(bytes);
}

// The same page written to a file atomically (flushed to disk), as `runs trend --plot` does and
// as the HTTP API did before it sent the page from memory.
void BM_TrendPlotSvgFile(benchmark::State& state) {
  const std::vector<RunCharacteristics> runs = sample_trend(static_cast<int>(state.range(0)));
  const std::filesystem::path out = std::filesystem::temp_directory_path() / "gaugeloop-bench-trend.svg";
  for (auto _ : state) {
    if (Status s = write_trend_plot(runs, "lift_error.zone3", out); !s) {
      state.SkipWithError(s.error().message.c_str());
      return;
    }
  }
  std::filesystem::remove(out);
}

cairo_status_t append(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

// Baseline: the same page size and values, bare cairo: one polyline and one filled path of
// dots, no axes, text or limits.
void BM_Baseline_BareCairoSvg(benchmark::State& state) {
  const std::vector<RunCharacteristics> runs = sample_trend(static_cast<int>(state.range(0)));
  std::size_t bytes = 0;
  for (auto _ : state) {
    std::string out;
    cairo_surface_t* surface = cairo_svg_surface_create_for_stream(append, &out, 841.89, 420.0);
    cairo_t* cr = cairo_create(surface);
    const double n = static_cast<double>(runs.size());
    auto px = [&](std::size_t i) { return 72.0 + 740.0 * (static_cast<double>(i) + 0.5) / n; };
    auto py = [&](std::size_t i) { return 222.0 - 12.0 * runs[i].characteristics.front().value; };
    for (std::size_t i = 0; i < runs.size(); ++i) {
      if (i == 0) {
        cairo_move_to(cr, px(i), py(i));
      } else {
        cairo_line_to(cr, px(i), py(i));
      }
    }
    cairo_stroke(cr);
    for (std::size_t i = 0; i < runs.size(); ++i) {
      cairo_new_sub_path(cr);
      cairo_arc(cr, px(i), py(i), 2.6, 0, 2 * M_PI);
    }
    cairo_fill(cr);
    cairo_destroy(cr);
    cairo_surface_finish(surface);
    cairo_surface_destroy(surface);
    bytes = out.size();
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["bytes"] = static_cast<double>(bytes);
}

BENCHMARK(BM_TrendPlotSvg)->Arg(200)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_TrendPlotSvgFile)->Arg(200)->Unit(benchmark::kMillisecond)->Repetitions(5)->ReportAggregatesOnly(true);
BENCHMARK(BM_Baseline_BareCairoSvg)
    ->Arg(200)
    ->Unit(benchmark::kMillisecond)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true);

}  // namespace
}  // namespace gaugeloop

BENCHMARK_MAIN();
