// SPC figures over stored characteristics.
#include "report/spc.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/number_text.h"

namespace gaugeloop {
namespace {

bool same_limits(const Limits& a, const Limits& b) { return a.lower == b.lower && a.upper == b.upper; }

// The values of one key, and the newest characteristic that carried it.
struct Gathered {
  std::vector<double> values;
  const Characteristic* newest = nullptr;
  std::int64_t newest_run = 0;
  bool limits_changed = false;
  int out_count = 0;
  int judged_count = 0;
  PartKind part_kind = PartKind::kLobe;
};

void add_capability(SpcFigure& f) {
  if (f.n < 2) {
    f.not_computed = "1 run: no spread, so no s, Cp or Cpk";
    return;
  }
  const double s = *f.sd;
  if (s == 0.0) {
    f.not_computed = "no spread (s = 0): no Cp or Cpk";
    return;
  }
  const std::optional<double>& lsl = f.limits.lower;
  const std::optional<double>& usl = f.limits.upper;
  if (!lsl && !usl) {
    f.not_computed = "no limits: no Cp or Cpk";
    return;
  }
  std::optional<double> cp, cpk;
  if (lsl && usl) {
    cp = (*usl - *lsl) / (6.0 * s);
    cpk = std::min(*usl - f.mean, f.mean - *lsl) / (3.0 * s);
    f.cpk_side = "both";
  } else if (usl) {
    cpk = (*usl - f.mean) / (3.0 * s);
    f.cpk_side = "upper";
  } else {
    cpk = (f.mean - *lsl) / (3.0 * s);
    f.cpk_side = "lower";
  }
  // A spread tiny against the limits can overflow a double; such a ratio is left out.
  if (cp && std::isfinite(*cp)) f.cp = cp;
  if (std::isfinite(*cpk)) {
    f.cpk = cpk;
  } else {
    f.cpk_side.clear();
  }
  if (f.cpk) {
    const double n = f.n;
    const double half = 1.96 * std::sqrt(1.0 / (9.0 * n) + *f.cpk * *f.cpk / (2.0 * (n - 1.0)));
    f.cpk_low95 = *f.cpk - half;
    f.cpk_high95 = *f.cpk + half;
    if (f.n < kCapabilityMinRuns) {
      f.caution = std::to_string(f.n) + " run" + (f.n == 1 ? "" : "s") + ": Cp and Cpk from fewer than " +
                  std::to_string(kCapabilityMinRuns) +
                  " runs are a first look, not a capability (Cpk's 95 % interval " + format_fixed(*f.cpk_low95, 2) +
                  " .. " + format_fixed(*f.cpk_high95, 2) + ")";
    }
  }
  if ((cp && !f.cp) || !f.cpk) {
    f.not_computed = "spread too small against the limits for a finite Cp or Cpk";
  } else if (!f.cp) {
    f.not_computed = "one limit only: Cpk is the " + std::string(usl ? "upper (CPU)" : "lower (CPL)") + " index, no Cp";
  }
}

std::string or_dash(const std::optional<double>& v, int decimals, bool with_sign) {
  if (!v) return "-";
  return with_sign ? format_signed_fixed(*v, decimals) : format_fixed(*v, decimals);
}

}  // namespace

std::vector<SpcFigure> spc_figures(const std::vector<RunCharacteristics>& runs) {
  std::vector<std::string> order;
  std::map<std::string, Gathered> by_key;
  for (const RunCharacteristics& run : runs) {
    for (const Characteristic& c : run.characteristics) {
      auto [it, inserted] = by_key.try_emplace(c.key);
      Gathered& g = it->second;
      if (inserted) order.push_back(c.key);
      if (g.newest != nullptr && !same_limits(g.newest->limits, c.limits)) g.limits_changed = true;
      g.values.push_back(c.value);
      g.newest = &c;
      g.newest_run = run.run.id;
      g.part_kind = part_kind_of(run.characteristics);
      if (c.verdict != Verdict::kNotJudged) ++g.judged_count;
      if (c.verdict == Verdict::kOut) ++g.out_count;
    }
  }
  std::vector<SpcFigure> out;
  out.reserve(order.size());
  for (const std::string& key : order) {
    const Gathered& g = by_key.at(key);
    SpcFigure f;
    f.key = key;
    f.unit = g.newest->unit;
    f.n = static_cast<int>(g.values.size());
    f.limits = g.newest->limits;
    f.limits_from_run = g.newest_run;
    f.limits_changed = g.limits_changed;
    f.out_count = g.out_count;
    f.judged_count = g.judged_count;
    f.part_kind = g.part_kind;
    // A running mean: the sum of many values near the largest double would overflow.
    f.mean = 0.0;
    for (std::size_t i = 0; i < g.values.size(); ++i) f.mean += (g.values[i] - f.mean) / static_cast<double>(i + 1);
    if (f.n >= 2) {
      // Equal values give exactly 0 here (the mean of equal values can differ from them in the
      // last bit, so the deviations are not summed for them).
      const bool all_equal =
          std::all_of(g.values.begin(), g.values.end(), [&](double v) { return v == g.values.front(); });
      if (all_equal) {
        f.mean = g.values.front();
        f.sd = 0.0;
      } else {
        double squares = 0.0;
        for (double v : g.values) squares += (v - f.mean) * (v - f.mean);
        f.sd = std::sqrt(squares / (f.n - 1));
      }
    }
    if (f.sd && !std::isfinite(*f.sd)) {
      f.sd.reset();
      f.not_computed = "values too far apart for a finite s: no s, Cp or Cpk";
    } else {
      add_capability(f);
    }
    out.push_back(std::move(f));
  }
  return out;
}

std::string spc_table_text(const std::vector<SpcFigure>& figures) {
  std::size_t title_width = std::string("characteristic").size();
  for (const SpcFigure& f : figures)
    title_width = std::max(title_width, characteristic_title(f.key, f.part_kind).size());
  const int w = static_cast<int>(title_width);
  std::string out;
  char line[512];
  std::snprintf(line, sizeof line, "%-*s  %-8s  %4s  %12s  %12s  %12s  %12s  %6s  %9s  %s\n", w, "characteristic",
                "unit", "n", "mean", "s", "LSL", "USL", "Cp", "Cpk", "out/judged");
  out += line;
  for (const SpcFigure& f : figures) {
    const int d = figure_decimals(f.unit);
    std::string cpk = or_dash(f.cpk, 2, false);
    if (f.cpk_side == "upper") cpk += " (U)";
    if (f.cpk_side == "lower") cpk += " (L)";
    std::snprintf(line, sizeof line, "%-*s  %-8s  %4d  %12s  %12s  %12s  %12s  %6s  %9s  %d/%d\n", w,
                  characteristic_title(f.key, f.part_kind).c_str(), f.unit.c_str(), f.n,
                  format_signed_fixed(f.mean, d).c_str(), or_dash(f.sd, d, false).c_str(),
                  or_dash(f.limits.lower, d, true).c_str(), or_dash(f.limits.upper, d, true).c_str(),
                  or_dash(f.cp, 2, false).c_str(), cpk.c_str(), f.out_count, f.judged_count);
    out += line;
  }
  if (!figures.empty()) out += "LSL, USL: the limits of the newest run that has the characteristic\n";
  for (const SpcFigure& f : figures) {
    if (f.limits_changed) {
      out += characteristic_title(f.key, f.part_kind) +
             ": the limits changed over these runs; shown are those of run " + std::to_string(f.limits_from_run) +
             " (the newest), each run was judged against its own\n";
    }
    if (!f.not_computed.empty()) out += characteristic_title(f.key, f.part_kind) + ": " + f.not_computed + "\n";
    if (!f.caution.empty()) out += characteristic_title(f.key, f.part_kind) + ": " + f.caution + "\n";
  }
  return out;
}

nlohmann::json spc_figure_json(const SpcFigure& f) {
  auto number = [](const std::optional<double>& v) { return v ? nlohmann::json(*v) : nlohmann::json(); };
  return {{"key", f.key},
          {"title", characteristic_title(f.key, f.part_kind)},
          {"unit", f.unit},
          {"n", f.n},
          {"mean", f.mean},
          {"sd", number(f.sd)},
          {"lsl", number(f.limits.lower)},
          {"usl", number(f.limits.upper)},
          {"limits_from_run", f.limits_from_run},
          {"limits_changed", f.limits_changed},
          {"cp", number(f.cp)},
          {"cpk", number(f.cpk)},
          {"cpk_side", f.cpk_side.empty() ? nlohmann::json() : nlohmann::json(f.cpk_side)},
          {"cpk_low95", number(f.cpk_low95)},
          {"cpk_high95", number(f.cpk_high95)},
          {"caution", f.caution},
          {"out", f.out_count},
          {"judged", f.judged_count},
          {"note", f.not_computed}};
}

}  // namespace gaugeloop
