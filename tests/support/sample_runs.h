// Stored runs made up for query tests (runs commands, HTTP API): known figures, a sine error.
#pragma once

#include <cmath>
#include <string>

#include "core/part.h"
#include "core/run.h"
#include "core/tolerance.h"
#include "storage/run_store.h"

namespace gaugeloop::testing {

// Raw reading at machine degree c of revolution rev: distinct per degree and revolution.
inline double raw_mm(int rev, int c) { return 1.0 + 0.001 * c + 0.0001 * rev; }

// A run of 3 revolutions whose lift error is max_um * sin(cam degree), correction 0.9 times
// that, repeatability 0.2 um, phase 0.25 deg, runout 1.5 um, c_offset 10 deg.
inline RunRecord sample_run(const std::string& part, int lobe, const std::string& machine, const std::string& started,
                            double max_um) {
  RunRecord r;
  r.started_utc = started;
  r.finished_utc = started;
  r.machine = machine;
  r.part = part;
  r.lobe = lobe;
  r.gauge = "tcp:127.0.0.1:1502";
  for (int i = 0; i < 3; ++i) {
    RevolutionSamples rev;
    rev.revolution = 10 + i;
    for (int c = 0; c < 360; ++c) rev.lift_mm[static_cast<std::size_t>(c)] = raw_mm(i, c);
    r.measured.revolutions.push_back(rev);
  }
  for (std::size_t d = 0; d < 360; ++d) {
    r.analysis.design_lift_mm[d] = 0.5;
    r.analysis.error_um[d] = max_um * std::sin(static_cast<double>(d) * 0.0174533);
    r.analysis.mean_lift_mm[d] = 0.5 + r.analysis.error_um[d] / 1000.0;
    r.analysis.spread_um[d] = 0.2;
    r.correction_um[d] = 0.9 * r.analysis.error_um[d];
  }
  r.analysis.max_abs_error_um = max_um;
  r.analysis.rms_error_um = max_um / std::sqrt(2.0);
  r.analysis.peak_to_valley_um = 2 * max_um;
  r.analysis.repeatability_um = 0.2;
  r.analysis.phase_error_deg = 0.25;
  r.analysis.base_circle_runout_um = 1.5;
  r.settings = "compensation.gain = 1\nanalysis.window = 150..210\n";
  Part g;
  g.c_offset_deg = 10.0;
  r.geometry = g;
  return r;
}

// A crankpin run as the measure job stores it: sample_run's tables read as pin degrees, the
// settings saying pin and `mode` ("c-x" or "c-x-y"), no cam frame, and the pin's four
// characteristics (roundness 3.5 um, diameter error +0.15 um, stroke error -0.01 um, index
// error 0.002 deg).
inline RunRecord sample_pin_run(const std::string& part, const std::string& mode, const std::string& started,
                                double max_um) {
  RunRecord r = sample_run(part, 1, "grinder-1", started, max_um);
  for (std::size_t d = 0; d < 360; ++d) r.analysis.design_lift_mm[d] = 0.0;
  r.analysis.phase_error_deg = 0.002;
  r.analysis.base_circle_runout_um = 0.0;
  r.settings = "part.kind = pin\npin.mode = " + mode + "\npin.throw_mm = 45.000000\n";
  r.geometry.reset();
  r.characteristics = {single_characteristic("roundness", "um", 3.5, Limits{std::nullopt, 4.0}),
                       single_characteristic("diameter_error", "um", 0.15, Limits{-8.0, 8.0}),
                       single_characteristic("stroke_error", "um", -0.01, Limits{-25.0, 25.0}),
                       single_characteristic("index_error", "deg", 0.002, Limits{-0.03, 0.03})};
  return r;
}

// The guard's refusal of a correction for intake lobe 1 on g1, a day before sample_run's runs.
inline EventRecord sample_refusal_event() {
  EventRecord e;
  e.at_utc = "2020-11-21T07:00:00Z";
  e.kind = EventKind::kRefusal;
  e.code = "refused";
  e.machine = "g1";
  e.part = "intake";
  e.lobe = 1;
  e.message = "correction 120.0 um at cam degree 95 exceeds the 100 um guard";
  return e;
}

}  // namespace gaugeloop::testing
