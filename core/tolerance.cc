// Names of zones and verdicts, and the verdict of a figure against its limits.
#include "core/tolerance.h"
#include "core/verdict_text.h"

#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace gaugeloop {

std::string_view lobe_zone_name(LobeZone zone) {
  switch (zone) {
    case LobeZone::kBaseCircle:
      return "base_circle";
    case LobeZone::kOpeningRamp:
      return "opening_ramp";
    case LobeZone::kOpeningFlank:
      return "opening_flank";
    case LobeZone::kNose:
      return "nose";
    case LobeZone::kClosingFlank:
      return "closing_flank";
    case LobeZone::kClosingRamp:
      return "closing_ramp";
  }
  return "base_circle";
}

std::string_view lobe_zone_title(LobeZone zone) {
  switch (zone) {
    case LobeZone::kBaseCircle:
      return "base circle";
    case LobeZone::kOpeningRamp:
      return "opening ramp";
    case LobeZone::kOpeningFlank:
      return "opening flank";
    case LobeZone::kNose:
      return "nose";
    case LobeZone::kClosingFlank:
      return "closing flank";
    case LobeZone::kClosingRamp:
      return "closing ramp";
  }
  return "base circle";
}

std::optional<LobeZone> lobe_zone_from_name(std::string_view name) {
  for (LobeZone z : kLobeZones) {
    if (lobe_zone_name(z) == name) return z;
  }
  return std::nullopt;
}

std::string_view lift_error_reference_name(LiftErrorReference reference) {
  return reference == LiftErrorReference::kNominal ? "nominal" : "best_fit";
}

std::string_view verdict_name(Verdict verdict) {
  switch (verdict) {
    case Verdict::kIn:
      return "in";
    case Verdict::kOut:
      return "out";
    case Verdict::kNotJudged:
      return "not_judged";
  }
  return "not_judged";
}

std::optional<Verdict> verdict_from_name(std::string_view name) {
  for (Verdict v : {Verdict::kNotJudged, Verdict::kIn, Verdict::kOut}) {
    if (verdict_name(v) == name) return v;
  }
  return std::nullopt;
}

Verdict combined_verdict(const std::vector<Verdict>& verdicts) {
  Verdict out = Verdict::kNotJudged;
  for (Verdict v : verdicts) {
    if (v == Verdict::kOut) return Verdict::kOut;
    if (v == Verdict::kIn) out = Verdict::kIn;
  }
  return out;
}

Verdict judge(double min, double max, const Limits& limits) {
  if (!limits.any()) return Verdict::kNotJudged;
  // Written so that a NaN figure is out, never in.
  if (limits.lower && !(min >= *limits.lower)) return Verdict::kOut;
  if (limits.upper && !(max <= *limits.upper)) return Verdict::kOut;
  return Verdict::kIn;
}

std::string verdict_summary(Verdict verdict, const std::vector<Characteristic>& characteristics) {
  int judged = 0;
  std::string out_keys;
  for (const Characteristic& c : characteristics) {
    if (c.verdict == Verdict::kNotJudged) continue;
    ++judged;
    if (c.verdict == Verdict::kOut) out_keys += (out_keys.empty() ? "" : ", ") + c.key;
  }
  if (judged == 0) return "not judged (no limits given)";
  std::string text(verdict_name(verdict));
  if (!out_keys.empty()) text += ": " + out_keys;
  return text + " (" + std::to_string(judged) + " of " + std::to_string(characteristics.size()) +
         " characteristics judged)";
}

int figure_decimals(std::string_view unit) {
  if (unit == "um") return 2;
  if (unit == "deg") return 4;
  if (unit == "mm/deg") return 6;
  if (unit == "mm/deg^2") return 7;
  return 4;
}

Characteristic single_characteristic(std::string key, std::string unit, double value, const Limits& limits) {
  Characteristic c;
  c.key = std::move(key);
  c.unit = std::move(unit);
  c.value = c.min = c.max = value;
  c.limits = limits;
  c.verdict = judge(value, value, limits);
  return c;
}

namespace {

// A gear's "lead." and "profile." keys (characteristic_title); nullopt for another key.
std::optional<std::string> gear_title(std::string_view key) {
  struct Figure {
    std::string_view kind;  // "lead" or "profile"
    std::string_view name;  // the figure's part of the key
    std::string_view title;
  };
  static constexpr Figure kFigures[] = {
      {"lead", "F_beta", "Total helix deviation F_beta"},
      {"lead", "f_f_beta", "Helix form deviation f_f_beta"},
      {"lead", "f_H_beta", "Helix slope deviation f_H_beta"},
      {"profile", "F_alpha", "Total profile deviation F_alpha"},
      {"profile", "f_f_alpha", "Profile form deviation f_f_alpha"},
      {"profile", "f_H_alpha", "Profile slope deviation f_H_alpha"},
  };
  const size_t first_dot = key.find('.');
  if (first_dot == std::string_view::npos) return std::nullopt;
  const std::string_view kind = key.substr(0, first_dot);
  std::vector<std::string_view> parts;
  for (std::string_view rest = key.substr(first_dot + 1);;) {
    const size_t dot = rest.find('.');
    parts.push_back(rest.substr(0, dot));
    if (dot == std::string_view::npos) break;
    rest = rest.substr(dot + 1);
  }
  const Figure* figure = nullptr;
  for (const Figure& f : kFigures) {
    if (f.kind == kind && f.name == parts[0]) figure = &f;
  }
  if (figure == nullptr) return std::nullopt;
  const std::string title(figure->title);
  const bool total = parts[0] == "F_beta" || parts[0] == "F_alpha";
  if (parts.size() == 1 && total) return title + ", worst flank";
  if (parts.size() == 2 && parts[1] == "mean") return title + ", mean of the flanks";
  if (parts.size() == 2 && parts[1] == "mean_abs") return title + ", mean size over the flanks";
  const bool gap =
      parts.size() == 3 && !parts[1].empty() && parts[1].find_first_not_of("0123456789") == std::string_view::npos;
  if (gap && (parts[2] == "left" || parts[2] == "right")) {
    return title + ", gap " + std::string(parts[1]) + ", " + std::string(parts[2]) + " flank";
  }
  return std::nullopt;
}

}  // namespace

std::string characteristic_title(std::string_view key, PartKind kind) {
  if (std::optional<std::string> gear = gear_title(key)) return *gear;
  std::string_view base = key;
  std::string_view zone;
  if (const size_t dot = key.find('.'); dot != std::string_view::npos) {
    base = key.substr(0, dot);
    zone = key.substr(dot + 1);
  }
  std::string title;
  if (base == "lift_error") {
    title = "Lift error";
  } else if (base == "velocity_error") {
    title = "Velocity error";
  } else if (base == "acceleration_error") {
    title = "Acceleration error";
  } else if (key == "phase") {
    return "Phase (timing) error";
  } else if (key == "base_circle_runout") {
    return "Base circle runout (dial)";
  } else if (key == "base_circle_runout_h1") {
    return "Base circle eccentricity (1st harmonic)";
  } else if (key == "roundness") {
    return kind == PartKind::kPin ? "Pin roundness" : "Base circle roundness";
  } else if (key == "diameter_error") {
    return "Pin diameter error";
  } else if (key == "stroke_error") {
    return "Pin stroke (throw) error";
  } else if (key == "index_error") {
    return "Pin index error";
  } else if (base == "harmonic" && !zone.empty() && zone.find_first_not_of("0123456789") == std::string_view::npos) {
    return "Lift error, harmonic " + std::string(zone);
  } else {
    return std::string(key);
  }
  if (zone.empty()) return title + ", whole turn";
  const std::optional<LobeZone> z = lobe_zone_from_name(zone);
  if (!z) return std::string(key);
  return title + ", " + std::string(lobe_zone_title(*z));
}

PartKind part_kind_of(const std::vector<Characteristic>& characteristics) {
  for (const Characteristic& c : characteristics) {
    if (c.key == "diameter_error" || c.key == "stroke_error" || c.key == "index_error") return PartKind::kPin;
    if (c.key.rfind("lead.", 0) == 0 || c.key.rfind("profile.", 0) == 0) return PartKind::kGear;
  }
  return PartKind::kLobe;
}

}  // namespace gaugeloop
