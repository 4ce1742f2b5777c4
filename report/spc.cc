// SPC figures over stored characteristics.
#include "report/spc.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "core/number_text.h"
#include "storage/characteristic_summaries.h"

namespace gaugeloop {
namespace {

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

CharacteristicSummaries summarize_characteristics(const std::vector<RunCharacteristics>& runs) {
  CharacteristicSummer summer;
  for (const RunCharacteristics& run : runs) {
    for (const Characteristic& c : run.characteristics) summer.add(run.run.id, c);
  }
  if (runs.empty()) return summer.finish(0, "", "");
  return summer.finish(static_cast<int>(runs.size()), runs.front().run.started_utc, runs.back().run.started_utc);
}

std::vector<SpcFigure> spc_figures(const CharacteristicSummaries& summaries) {
  std::vector<Characteristic> keys;  // the part kind reads from the keys
  for (const CharacteristicSummary& k : summaries.by_key) {
    keys.emplace_back();
    keys.back().key = k.key;
  }
  const PartKind part_kind = part_kind_of(keys);
  std::vector<SpcFigure> out;
  out.reserve(summaries.by_key.size());
  for (const CharacteristicSummary& k : summaries.by_key) {
    SpcFigure f;
    f.key = k.key;
    f.unit = k.unit;
    f.n = k.n;
    f.mean = k.mean;
    f.limits = k.limits;
    f.limits_from_run = k.limits_from_run;
    f.limits_changed = k.limits_changed;
    f.out_count = k.out_count;
    f.judged_count = k.judged_count;
    f.part_kind = part_kind;
    // Equal values give exactly 0 (their mean can differ from them in the last bit).
    if (f.n >= 2) f.sd = k.all_equal ? 0.0 : std::sqrt(k.squares / (f.n - 1));
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

std::vector<SpcFigure> spc_figures(const std::vector<RunCharacteristics>& runs) {
  return spc_figures(summarize_characteristics(runs));
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
