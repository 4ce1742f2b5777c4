// Statistical process control over stored runs: per characteristic, the mean, the sample
// standard deviation, Cp and Cpk against the characteristic's limits, and how many runs were
// out of tolerance (`runs spc`).
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/tolerance.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Fewer runs than this give Cp and Cpk with a caution: capability studies ask for at least 25
// (the usual preliminary study; a machine capability study asks for 50).
inline constexpr int kCapabilityMinRuns = 25;

// One characteristic over the runs selected.
struct SpcFigure {
  std::string key;   // Characteristic::key, e.g. "lift_error.opening_flank"
  std::string unit;  // as the newest run that has the key stored it
  int n = 0;         // runs that have the key (>= 1)
  double mean = 0.0;
  // Sample standard deviation (divisor n - 1). Empty when n < 2 (or the values are too far
  // apart for a finite s); 0 when every value is the same (then Cp and Cpk are not given: a
  // process without spread has no capability ratio).
  std::optional<double> sd;
  // The limits of the newest run that has the key; limits_changed: some older run of the
  // selection had other limits (its verdicts were given against those).
  Limits limits;
  std::int64_t limits_from_run = 0;  // the run id the limits come from
  bool limits_changed = false;
  // Cp = (USL - LSL) / (6 s), only when both limits exist. Cpk = min(USL - mean, mean - LSL)
  // / (3 s) with both limits; with one limit it is that side's index alone, CPU =
  // (USL - mean) / (3 s) or CPL = (mean - LSL) / (3 s), and cpk_side says which.
  std::optional<double> cp;
  std::optional<double> cpk;
  std::string cpk_side;  // "both", "upper" (CPU), "lower" (CPL); empty without Cpk
  // Why sd, Cp or Cpk is missing, in words ("1 run: no spread"); empty when all are given.
  std::string not_computed;
  // Cpk's approximate 95 % confidence interval (Bissell's normal approximation:
  // Cpk +- 1.96 sqrt(1 / (9 n) + Cpk^2 / (2 (n - 1)))), when Cpk is given.
  std::optional<double> cpk_low95;
  std::optional<double> cpk_high95;
  // Said when Cp or Cpk comes from fewer than kCapabilityMinRuns runs: a first look, not a
  // capability; empty otherwise.
  std::string caution;
  int out_count = 0;     // runs whose verdict for the key was out
  int judged_count = 0;  // runs whose verdict for the key was in or out
  // The part of the newest run that has the key (part_kind_of): its title reads for it.
  PartKind part_kind = PartKind::kLobe;
};

// The SPC figures of `runs` (oldest first, as RunStore::characteristics returns them), one per
// key in the order keys first appear. The figure of each run is Characteristic::value: the
// signed extreme for lift, velocity and acceleration errors, the figure itself otherwise.
// Every number given is finite: a ratio that would not be is left out and said so.
std::vector<SpcFigure> spc_figures(const std::vector<RunCharacteristics>& runs);

// The same from the database's summaries (RunHistory::characteristic_summaries), one figure a
// key in their order. The part kind reads from all the keys.
std::vector<SpcFigure> spc_figures(const CharacteristicSummaries& summaries);

// What the database sums up, summed up here from `runs` (oldest first): what spc_figures(runs)
// reads.
CharacteristicSummaries summarize_characteristics(const std::vector<RunCharacteristics>& runs);

// One figure as `runs spc --json` prints it: key, title (characteristic_title for its
// part_kind), unit, n, mean,
// sd, lsl, usl, limits_from_run, limits_changed, cp, cpk, cpk_side, cpk_low95, cpk_high95, out,
// judged, note, caution; null for what is not given.
nlohmann::json spc_figure_json(const SpcFigure& figure);

// The figures as `runs spc` prints them: one row per characteristic (title, unit, n, mean, s,
// LSL, USL, Cp, Cpk, out/judged; "-" for what is not given, Cpk marked (U) or (L) when one-sided),
// a line saying whose limits these are, then a line for each figure whose limits changed, whose
// ratios are missing or come from fewer than kCapabilityMinRuns runs, saying so. Figures with figure_decimals
// (core/tolerance.h).
std::string spc_table_text(const std::vector<SpcFigure>& figures);

}  // namespace gaugeloop
