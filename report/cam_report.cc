// The cam report and the trend plot, drawn with cairo through report/chart_cairo.h.
#include "report/cam_report.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <set>
#include <string_view>
#include <utility>

#include "compensation/inspection.h"
#include "compensation/judgement.h"
#include "core/atomic_file.h"
#include "core/number_text.h"
#include "core/tolerance.h"
#include "report/chart_cairo.h"
#include "report/judged_error.h"
#include "report/run_json.h"
#include "report/shaft.h"

namespace gaugeloop {
namespace {

static_assert(kReportPngPixelsPerPoint == chart::kPngPixelsPerPoint);

using chart::Align;
using chart::Box;
using chart::Frame;

// ---- Layout of the report page (points) ----
// Left column: the three charts over cam angle; right column: polar view and harmonics above,
// the characteristics table below. The header and footer span the page.
constexpr double kMargin = 30.0;
constexpr Box kLiftBox{72.0, 92.0, 398.0, 150.0};
constexpr Box kVelocityBox{72.0, 290.0, 398.0, 95.0};
constexpr Box kAccelerationBox{72.0, 433.0, 398.0, 95.0};
constexpr double kPolarCentreX = 567.0;
constexpr double kPolarCentreY = 176.0;
constexpr double kPolarBaseRadius = 48.0;
constexpr double kPolarRingStep = 10.0;  // points per ring (one scale step of error)
constexpr Box kHarmonicsBox{690.0, 92.0, 122.0, 140.0};
constexpr double kTableLeft = 495.0;
constexpr double kTableTop = 292.0;
constexpr double kTableBottom = 556.0;
constexpr double kRowPt = 9.2;

std::string display_unit(const std::string& unit) {
  if (unit == "um") return "\u00b5m";
  if (unit == "mm/deg^2") return "mm/deg\u00b2";
  return unit;
}

// Fewer than figure_decimals for the rates: the table's columns on the page.
int decimals_for_unit(const std::string& unit) {
  if (unit == "um") return 2;
  if (unit == "deg") return 3;
  if (unit == "mm/deg") return 5;
  if (unit == "mm/deg^2") return 6;
  return 3;
}

std::string limits_text(const Limits& l, int decimals) {
  if (l.lower && l.upper && *l.lower == -*l.upper) return "\u00b1" + format_fixed(*l.upper, decimals);
  if (l.lower && l.upper) return format_fixed(*l.lower, decimals) + " \u2026 " + format_fixed(*l.upper, decimals);
  if (l.upper) return "\u2264 " + format_fixed(*l.upper, decimals);
  if (l.lower) return "\u2265 " + format_fixed(*l.lower, decimals);
  return "\u2013";
}

chart::Rgb verdict_colour(Verdict v) {
  return v == Verdict::kIn ? chart::kIn : v == Verdict::kOut ? chart::kOut : chart::kNotJudged;
}

std::string verdict_text(Verdict v) { return v == Verdict::kIn ? "in" : v == Verdict::kOut ? "OUT" : "not judged"; }

const Characteristic* find_characteristic(const std::vector<Characteristic>& cs, const std::string& key) {
  for (const Characteristic& c : cs) {
    if (c.key == key) return &c;
  }
  return nullptr;
}

// A figure over cam angle as the report charts it: values per nose-centred degree.
struct DegreeCurve {
  std::array<double, 361> value{};  // x = -180..180 at index x + 180
  double at(int x) const { return value[static_cast<std::size_t>(x + 180)]; }
};

DegreeCurve nose_centred(const DegreeTable& t) {
  DegreeCurve c;
  for (int x = -180; x <= 180; ++x) c.value[static_cast<std::size_t>(x + 180)] = t[degree_index(x)];
  return c;
}

// The y range showing the curves and the finite limits, widened to round ticks.
void curve_range(const std::vector<const DegreeCurve*>& curves, const DegreeLimits& limits, double& lo, double& hi) {
  lo = 0.0;
  hi = 0.0;
  for (const DegreeCurve* c : curves) {
    for (double v : c->value) {
      lo = std::min(lo, v);
      hi = std::max(hi, v);
    }
  }
  for (const Limits& l : limits) {
    if (l.lower) lo = std::min(lo, *l.lower);
    if (l.upper) hi = std::max(hi, *l.upper);
  }
  const double pad = (hi - lo) * 0.06;
  lo -= pad;
  hi += pad;
  chart::nice_range(lo, hi, 5);
}

// The allowed region per degree, filled, and its limits as lines.
void draw_band(cairo_t* cr, const Frame& f, const DegreeLimits& limits) {
  chart::clip_to(cr, f);
  for (int x = -179; x <= 180;) {
    const Limits& l = limits[static_cast<std::size_t>(x + 179)];
    int end = x;
    while (end < 180) {
      const Limits& n = limits[static_cast<std::size_t>(end + 1 + 179)];
      if (n.lower != l.lower || n.upper != l.upper) break;
      ++end;
    }
    if (l.any()) {
      const double x0 = f.px(x - 0.5);
      const double x1 = f.px(end + 0.5);
      const double y_top = l.upper ? f.py(*l.upper) : f.box.top;
      const double y_bottom = l.lower ? f.py(*l.lower) : f.box.bottom();
      chart::set_colour(cr, chart::kBand);
      cairo_rectangle(cr, x0, y_top, x1 - x0, y_bottom - y_top);
      cairo_fill(cr);
      chart::set_colour(cr, chart::kLimit);
      cairo_set_line_width(cr, 0.8);
      if (l.upper) {
        cairo_move_to(cr, x0, y_top);
        cairo_line_to(cr, x1, y_top);
      }
      if (l.lower) {
        cairo_move_to(cr, x0, y_bottom);
        cairo_line_to(cr, x1, y_bottom);
      }
      cairo_stroke(cr);
    }
    x = end + 1;
  }
  cairo_restore(cr);
}

void draw_curve(cairo_t* cr, const Frame& f, const DegreeCurve& c, chart::Rgb colour, double width_pt) {
  chart::clip_to(cr, f);
  chart::set_colour(cr, colour);
  cairo_set_line_width(cr, width_pt);
  cairo_set_line_join(cr, CAIRO_LINE_JOIN_ROUND);
  for (int x = -180; x <= 180; ++x) {
    if (x == -180) {
      cairo_move_to(cr, f.px(x), f.py(c.at(x)));
    } else {
      cairo_line_to(cr, f.px(x), f.py(c.at(x)));
    }
  }
  cairo_stroke(cr);
  cairo_restore(cr);
}

// Red ticks along the bottom of the plot at the degrees outside their limits.
bool outside(const DegreeCurve& c, const DegreeLimits& limits, int x) {
  const Limits& l = limits[static_cast<std::size_t>(x + 179)];
  const double v = c.at(x);
  return (l.lower && v < *l.lower) || (l.upper && v > *l.upper);
}

int mark_out_of_tolerance(cairo_t* cr, const Frame& f, const DegreeCurve& c, const DegreeLimits& limits) {
  int out = 0;
  chart::set_colour(cr, chart::kOut);
  for (int x = -179; x <= 180; ++x) {
    if (outside(c, limits, x)) {
      cairo_rectangle(cr, f.px(x - 0.5), f.box.bottom() - 4.0, std::max(0.6, f.px(x + 0.5) - f.px(x - 0.5)), 4.0);
      ++out;
    }
  }
  cairo_fill(cr);
  return out;
}

std::vector<double> cam_angle_ticks() {
  std::vector<double> t;
  for (int x = -180; x <= 180; x += 30) t.push_back(x);
  return t;
}

const char* const kCamAngleTitle = "cam angle, deg (nose at 0; opening side negative, closing side positive)";

// A legend entry at (x, y): a short line or box in `colour`, then the label; returns the x after it.
double legend_entry(cairo_t* cr, double x, double y, chart::Rgb colour, const std::string& label, bool box) {
  chart::set_colour(cr, colour);
  if (box) {
    cairo_rectangle(cr, x, y - 5, 10, 5);
    cairo_fill(cr);
  } else {
    cairo_set_line_width(cr, 1.6);
    cairo_move_to(cr, x, y - 2.5);
    cairo_line_to(cr, x + 10, y - 2.5);
    cairo_stroke(cr);
  }
  chart::set_colour(cr, chart::kInk);
  return x + 13 + chart::text(cr, x + 13, y, label, 6.5) + 8;
}

// A run stored before the best-fit error was kept (judged_error): its raw error is charted.
bool best_fit_missing(const StoredRun& run) { return judged_error(run).basis == JudgedError::Basis::kNominalNoBestFit; }

DegreeTable charted_lift_error_um(const StoredRun& run) { return judged_error(run).error_um; }

struct ReportData {
  const StoredRun* run = nullptr;
  DegreeCurve judged_um, raw_um, velocity_mm_per_deg, acceleration_mm_per_deg2;
  DegreeLimits lift_limits{}, velocity_limits{}, acceleration_limits{};
};

Frame lift_frame(const ReportData& d) {
  Frame f{kLiftBox, -180.0, 180.0, 0.0, 1.0};
  curve_range({&d.judged_um, &d.raw_um}, d.lift_limits, f.y_min, f.y_max);
  return f;
}

// The charts' data; the derivatives' only with `derivatives`.
ReportData report_data(const StoredRun& run, const ErrorDerivatives* derivatives) {
  ReportData d;
  d.run = &run;
  d.judged_um = nose_centred(charted_lift_error_um(run));
  d.raw_um = nose_centred(run.analysis.error_um);
  d.lift_limits = limits_per_degree(run.characteristics, "lift_error");
  if (derivatives != nullptr) {
    // Velocity and acceleration are charted in mm per degree, as the part file's limits, the
    // table beside them and every other view give them.
    d.velocity_mm_per_deg = nose_centred(derivatives->velocity_error_mm_per_deg);
    d.acceleration_mm_per_deg2 = nose_centred(derivatives->acceleration_error_mm_per_deg2);
    d.velocity_limits = limits_per_degree(run.characteristics, "velocity_error");
    d.acceleration_limits = limits_per_degree(run.characteristics, "acceleration_error");
  }
  return d;
}

std::string started_text(const std::string& utc) {
  if (utc.size() < 19) return utc;
  return utc.substr(0, 10) + " " + utc.substr(11, 8) + " UTC";
}

void draw_header(cairo_t* cr, const StoredRun& run, const CamReportWords& w) {
  const RunSummary& s = run.summary;
  chart::set_colour(cr, chart::kInk);
  chart::text(cr, kMargin, 30, w.page_title, 15, Align::kLeft, true);
  chart::text(cr, kMargin + 190, 30, chart::fit_text(cr, s.part, 12, 330) + " \u00b7 " + w.item, 12, Align::kLeft);

  // The verdict, in colour, at the top right.
  const Verdict v = s.verdict;
  const std::string verdict = v == Verdict::kIn    ? "IN TOLERANCE"
                              : v == Verdict::kOut ? "OUT OF TOLERANCE"
                                                   : "NOT JUDGED";
  const double box_w = chart::text_width(cr, verdict, 11, true) + 20;
  const double right = kReportWidthPt - kMargin;
  chart::set_colour(cr, verdict_colour(v));
  cairo_rectangle(cr, right - box_w, 14, box_w, 22);
  cairo_fill(cr);
  cairo_set_source_rgb(cr, 1, 1, 1);
  chart::text(cr, right - box_w / 2, 29, verdict, 11, Align::kCentre, true);

  // Identity: label and value pairs on three lines.
  auto fields = [&](double y, const std::vector<std::pair<std::string, std::string>>& pairs) {
    // Up to six values share a line of the page: none may push the next off it. Each is at
    // most 130 points wide (the note 360), and the line's room is shared so that the narrow
    // ones show whole and the widest are cut to an equal share of what is left.
    const std::size_t n = pairs.size();
    std::vector<double> wanted(n);
    std::vector<std::size_t> narrowest_first(n);
    double room = right - kMargin;
    for (std::size_t i = 0; i < n; ++i) {
      const auto& [label, value] = pairs[i];
      room -= chart::text_width(cr, label + " ", 7.5) + 16;
      const double widest = label == "Note" ? 360.0 : label == "Lobe angle" ? 190.0 : 130.0;
      wanted[i] = std::min(widest, chart::text_width(cr, value.empty() ? "\u2013" : value, 8, true));
      narrowest_first[i] = i;
    }
    std::sort(narrowest_first.begin(), narrowest_first.end(),
              [&wanted](std::size_t a, std::size_t b) { return wanted[a] < wanted[b]; });
    std::vector<double> width(n);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = narrowest_first[k];
      width[i] = std::max(0.0, std::min(wanted[i], room / static_cast<double>(n - k)));
      room -= width[i];
    }
    double x = kMargin;
    for (std::size_t i = 0; i < n; ++i) {
      const auto& [label, value] = pairs[i];
      chart::set_colour(cr, chart::kNotJudged);
      x += chart::text(cr, x, y, label + " ", 7.5);
      chart::set_colour(cr, chart::kInk);
      const std::string shown = chart::fit_text(cr, value.empty() ? "\u2013" : value, 8, width[i], true);
      x += chart::text(cr, x, y, shown, 8, Align::kLeft, true) + 16;
    }
  };
  fields(50, {{"Part", s.part},
              {w.item_label, std::to_string(s.lobe)},
              {"Serial", s.serial},
              {"Operator", s.operator_name},
              {"Machine", s.machine}});
  std::vector<std::pair<std::string, std::string>> second = {{"Run", std::to_string(s.id)},
                                                             {"Started", started_text(s.started_utc)},
                                                             {"Revolutions", std::to_string(s.revolutions)}};
  if (!w.lobe_angle.empty()) second.emplace_back("Lobe angle", w.lobe_angle);
  second.emplace_back("Note", s.note);
  fields(62, second);
  fields(74, w.traceability);
  chart::set_colour(cr, chart::kGrid);
  cairo_set_line_width(cr, 0.8);
  cairo_move_to(cr, kMargin, 79);
  cairo_line_to(cr, right, 79);
  cairo_stroke(cr);
}

void draw_lift_chart(cairo_t* cr, const ReportData& d, const CamReportWords& w) {
  const Frame f = lift_frame(d);
  draw_band(cr, f, d.lift_limits);
  chart::draw_axes(cr, f, cam_angle_ticks(), w.angle_axis, w.error_axis, w.error_chart);
  draw_curve(cr, f, d.raw_um, chart::kFaint, 0.8);
  draw_curve(cr, f, d.judged_um, chart::kCurve, 1.5);
  const int out = mark_out_of_tolerance(cr, f, d.judged_um, d.lift_limits);
  // Legend on the title line, right-aligned: w.lift_legend, the band's entry red when degrees
  // are out.
  double width = 0.0;
  for (const std::string& label : w.lift_legend) width += 21 + chart::text_width(cr, label, 6.5);
  double x = kLiftBox.right() - width + 8;
  const chart::Rgb colours[] = {chart::kCurve, chart::kFaint, out > 0 ? chart::kOut : chart::kBand};
  for (std::size_t i = 0; i < w.lift_legend.size() && i < std::size(colours); ++i) {
    x = legend_entry(cr, x, kLiftBox.top - 5, colours[i], w.lift_legend[i], i == 2);
  }
}

void draw_derivative_chart(cairo_t* cr, const Box& box, const DegreeCurve& c, const DegreeLimits& limits,
                           const std::string& y_title, const std::string& title) {
  Frame f{box, -180.0, 180.0, 0.0, 1.0};
  curve_range({&c}, limits, f.y_min, f.y_max);
  draw_band(cr, f, limits);
  chart::draw_axes(cr, f, cam_angle_ticks(), kCamAngleTitle, y_title, title, 4);
  draw_curve(cr, f, c, chart::kCurve, 1.2);
  mark_out_of_tolerance(cr, f, c, limits);
}

void draw_polar(cairo_t* cr, const ReportData& d, const CamReportWords& w) {
  const double cx = kPolarCentreX;
  const double cy = kPolarCentreY;
  const double r0 = kPolarBaseRadius;
  chart::set_colour(cr, chart::kInk);
  chart::text(cr, kTableLeft, kLiftBox.top - 5, w.polar_title, 8, Align::kLeft, true);
  double biggest = 0.0;
  for (double v : d.judged_um.value) biggest = std::max(biggest, std::abs(v));
  // Two rings either side of the base circle hold the largest error: a ring step of 1, 2 or 5
  // times a power of ten, at least half the largest error.
  const double half = std::max(biggest, 0.1) / 2.0;
  double step_um = std::pow(10.0, std::floor(std::log10(half)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * std::pow(10.0, std::floor(std::log10(half))) >= half * 0.9999) {
      step_um = m * std::pow(10.0, std::floor(std::log10(half)));
      break;
    }
  }
  const double pt_per_um = kPolarRingStep / step_um;
  cairo_set_line_width(cr, 0.5);
  for (int ring = -2; ring <= 2; ++ring) {
    chart::set_colour(cr, ring == 0 ? chart::kInk : chart::kGrid);
    cairo_new_sub_path(cr);
    cairo_arc(cr, cx, cy, r0 + ring * kPolarRingStep, 0, 2 * M_PI);
    cairo_stroke(cr);
  }
  // Nose up; the angle grows clockwise, so the opening side lies left of the nose as in the
  // charts (one convention with the pages and `runs plot`: signed_degree).
  auto point = [&](double deg, double r) {
    const double a = deg * M_PI / 180.0;
    return std::pair<double, double>{cx + r * std::sin(a), cy - r * std::cos(a)};
  };
  chart::set_colour(cr, chart::kGrid);
  for (int deg = 0; deg < 360; deg += 90) {
    auto [x0, y0] = point(deg, r0 - 2.4 * kPolarRingStep);
    auto [x1, y1] = point(deg, r0 + 2.4 * kPolarRingStep);
    cairo_move_to(cr, x0, y0);
    cairo_line_to(cr, x1, y1);
  }
  cairo_stroke(cr);
  chart::set_colour(cr, chart::kInk);
  const double label_r = r0 + 2 * kPolarRingStep + 9;
  chart::text(cr, cx, cy - label_r + 2, w.polar_zero, 6.5, Align::kCentre);
  chart::text(cr, cx + label_r - 6, cy + 2.3, "90", 6.5, Align::kLeft);
  chart::text(cr, cx, cy + label_r + 3, "180", 6.5, Align::kCentre);
  chart::text(cr, cx - label_r + 6, cy + 2.3, "\u221290", 6.5, Align::kRight);
  chart::set_colour(cr, chart::kCurve);
  cairo_set_line_width(cr, 1.2);
  for (int x = -180; x <= 180; ++x) {
    const double r = std::max(0.0, r0 + d.judged_um.at(x) * pt_per_um);
    auto [px, py] = point(x, r);
    if (x == -180) {
      cairo_move_to(cr, px, py);
    } else {
      cairo_line_to(cr, px, py);
    }
  }
  cairo_close_path(cr);
  cairo_stroke(cr);
  chart::set_colour(cr, chart::kInk);
  const int decimals = chart::decimals_for_step(step_um);
  chart::text(
      cr, cx, cy + label_r + 15,
      w.polar_angle + "; rings every " + format_fixed(step_um, decimals) + " \u00b5m about the " + w.polar_reference,
      6.5, Align::kCentre);
}

void draw_harmonics(cairo_t* cr, const StoredRun& run, const CamReportWords& w) {
  const auto& h = run.analysis.harmonic_amplitude_um;
  double top = 0.0;
  for (std::size_t k = 1; k <= 30; ++k) top = std::max(top, h[k]);
  double lo = 0.0;
  double hi = top * 1.05;
  chart::nice_range(lo, hi, 4);
  const Frame f{kHarmonicsBox, 0.0, 31.0, 0.0, hi};
  chart::draw_axes(cr, f, {1, 5, 10, 15, 20, 25, 30}, "harmonic, undulations/turn", "amplitude, \u00b5m",
                   w.harmonics_title, 4);
  chart::set_colour(cr, chart::kCurve);
  for (std::size_t k = 1; k <= 30; ++k) {
    const double x = static_cast<double>(k);
    cairo_rectangle(cr, f.px(x - 0.35), f.py(h[k]), f.px(x + 0.35) - f.px(x - 0.35), f.py(0) - f.py(h[k]));
  }
  cairo_fill(cr);
}

// A characteristic's title as the table's first column holds it: "Acceleration error" always
// shortened to "Accel. error" (alike on every row), "1st harmonic" to "H1" where it would be cut.
std::string table_title(cairo_t* cr, std::string title, double size_pt, double width_pt) {
  const auto shorten = [&title](const std::string& from, const std::string& to) {
    if (const std::size_t at = title.find(from); at != std::string::npos) title.replace(at, from.size(), to);
  };
  shorten("Acceleration error", "Accel. error");
  if (chart::text_width(cr, title, size_pt) > width_pt) shorten("1st harmonic", "H1");
  return chart::fit_text(cr, title, size_pt, width_pt);
}

void draw_table(cairo_t* cr, const StoredRun& run, const CamReportWords& w) {
  const std::vector<Characteristic>& cs = run.characteristics;
  const double right = kReportWidthPt - kMargin;
  // Column positions: title and unit left-aligned, figures right-aligned, limits centred.
  const double unit_x = kTableLeft + 99;
  const double value_r = kTableLeft + 164;
  const double min_r = kTableLeft + 199;
  const double max_r = kTableLeft + 234;
  const double limits_c = kTableLeft + 261;
  const double verdict_x = kTableLeft + 287;
  chart::set_colour(cr, chart::kInk);
  const double title_width = chart::text(cr, kTableLeft, kTableTop - 12, "Characteristics", 8, Align::kLeft, true);
  if (!w.table_note.empty()) {
    chart::set_colour(cr, chart::kNotJudged);
    const double room = right - (kTableLeft + title_width + 6);
    chart::text(cr, kTableLeft + title_width + 6, kTableTop - 12, chart::fit_text(cr, w.table_note, 6.0, room), 6.0);
    chart::set_colour(cr, chart::kInk);
  }
  double y = kTableTop;
  const double size = 6.0;
  chart::set_colour(cr, chart::kNotJudged);
  chart::text(cr, kTableLeft, y, "characteristic", size, Align::kLeft, true);
  chart::text(cr, unit_x, y, "unit", size, Align::kLeft, true);
  chart::text(cr, value_r, y, "value", size, Align::kRight, true);
  chart::text(cr, min_r, y, "min", size, Align::kRight, true);
  chart::text(cr, max_r, y, "max", size, Align::kRight, true);
  chart::text(cr, limits_c, y, "limits", size, Align::kCentre, true);
  chart::text(cr, verdict_x, y, "verdict", size, Align::kLeft, true);
  cairo_set_line_width(cr, 0.5);
  cairo_move_to(cr, kTableLeft, y + 3);
  cairo_line_to(cr, right, y + 3);
  cairo_stroke(cr);
  y += kRowPt + 1;
  if (cs.empty()) {
    chart::set_colour(cr, chart::kNotJudged);
    chart::text(cr, kTableLeft, y + 4, "not judged: no tolerances recorded", 8, Align::kLeft, true);
    chart::text(cr, kTableLeft, y + 16, "(the run was stored without its part's tolerances)", 6.5);
    return;
  }
  const auto rows_fit = static_cast<std::size_t>((kTableBottom - y) / kRowPt) + 1;
  const std::size_t shown = cs.size() <= rows_fit ? cs.size() : rows_fit - 1;
  for (std::size_t i = 0; i < shown; ++i) {
    const Characteristic& c = cs[i];
    const int dec = decimals_for_unit(c.unit);
    if (i % 2 == 1) {
      chart::set_colour(cr, {0.96, 0.96, 0.97});
      cairo_rectangle(cr, kTableLeft, y - kRowPt + 2.5, right - kTableLeft, kRowPt);
      cairo_fill(cr);
    }
    chart::set_colour(cr, chart::kInk);
    chart::text(cr, kTableLeft, y, table_title(cr, w.characteristic_titles[i], size, unit_x - kTableLeft - 3), size);
    chart::text(cr, unit_x, y, display_unit(c.unit), size);
    chart::text(cr, value_r, y, format_fixed(c.value, dec), size, Align::kRight);
    chart::text(cr, min_r, y, format_fixed(c.min, dec), size, Align::kRight);
    chart::text(cr, max_r, y, format_fixed(c.max, dec), size, Align::kRight);
    chart::text(cr, limits_c, y, chart::fit_text(cr, limits_text(c.limits, dec), size, 52), size, Align::kCentre);
    chart::set_colour(cr, verdict_colour(c.verdict));
    chart::text(cr, verdict_x, y, verdict_text(c.verdict), size, Align::kLeft, c.verdict != Verdict::kNotJudged);
    y += kRowPt;
  }
  if (shown < cs.size()) {
    chart::set_colour(cr, chart::kNotJudged);
    chart::text(
        cr, kTableLeft, y,
        "\u2026 " + std::to_string(cs.size() - shown) + " more: gaugeloop runs show " + std::to_string(run.summary.id),
        size);
  }
}

// The noise the derivatives carry, from the gauge noise the revolutions show: the RMS over the
// turn of the per-degree spread across revolutions, averaged over the run's revolutions
// (derivative_noise_rms). Empty when it cannot be said (fewer than 2 revolutions stored).
// In mm per degree, as the charts and the table are.
std::string derivative_noise_text(const StoredRun& run) {
  const LobeAnalysis& a = run.analysis;
  double squares = 0.0;
  for (double s : a.spread_um) squares += s * s;
  const double noise_um = std::sqrt(squares / kDegreesPerRevolution);
  Result<double> velocity = derivative_noise_rms(noise_um, run.summary.revolutions, 1);
  Result<double> acceleration = derivative_noise_rms(noise_um, run.summary.revolutions, 2);
  if (run.summary.revolutions < 2 || !velocity || !acceleration) return "";
  return ", noise " + format_fixed(*velocity, 6) + " mm/deg, " + format_fixed(*acceleration, 7) + " mm/deg\u00b2 RMS";
}

void draw_footer(cairo_t* cr, const CamReportWords& w) {
  const double y = kReportHeightPt - 22;
  chart::set_colour(cr, chart::kGrid);
  cairo_set_line_width(cr, 0.8);
  cairo_move_to(cr, kMargin, y - 12);
  cairo_line_to(cr, kReportWidthPt - kMargin, y - 12);
  cairo_stroke(cr);
  chart::set_colour(cr, chart::kInk);
  chart::text(cr, kMargin, y, w.footer_judged, 6.5);
  chart::text(cr, kMargin, y + 10, w.footer_detail, 6.5);
  chart::text(cr, kReportWidthPt - kMargin, y + 6, "Checked by ____________________   Date ____________", 8,
              Align::kRight);
}

CamReportWords lobe_words(const StoredRun& run) {
  const LobeAnalysis& a = run.analysis;
  const bool best_fit = run.lift_error_reference == LiftErrorReference::kBestFit && !best_fit_missing(run);
  CamReportWords w;
  w.page_title = "Cam inspection report";
  w.item = "lobe " + std::to_string(run.summary.lobe);
  w.item_label = "Lobe";
  w.angle_axis = kCamAngleTitle;
  w.error_axis = "lift error, \u00b5m";
  w.error_chart = best_fit_missing(run) ? "Lift error at nominal timing (no best fit), \u00b5m"
                  : best_fit            ? "Lift error after best-fit phase (judged), \u00b5m"
                                        : "Lift error at nominal timing (judged), \u00b5m";
  w.polar_title = "Polar view of the judged lift error";
  w.polar_zero = "0 (nose)";
  w.polar_angle = "cam deg";
  w.polar_reference = "base circle";
  w.harmonics_title = "Harmonics of the lift error";
  for (const Characteristic& c : run.characteristics) w.characteristic_titles.push_back(characteristic_title(c.key));
  const std::string judged =
      best_fit
          ? "judged: lift error after the best-fit phase (" + format_signed_fixed(a.phase_error_deg, 3) +
                " deg removed), RMS " + format_fixed(a.rms_residual_um, 2) + " \u00b5m, peak to valley " +
                format_fixed(a.peak_to_valley_residual_um, 2) + " \u00b5m"
          : std::string(best_fit_missing(run) ? "charted: lift error at nominal timing (the run kept no best-fit error)"
                                              : "judged: lift error at nominal timing") +
                ", RMS " + format_fixed(a.rms_error_um, 2) + " \u00b5m, peak to valley " +
                format_fixed(a.peak_to_valley_um, 2) + " \u00b5m";
  w.footer_judged = judged + " \u00b7 repeatability " + format_fixed(a.repeatability_um, 2) + " \u00b5m";
  w.footer_detail =
      "velocity, acceleration: harmonics 1\u201330" + derivative_noise_text(run) + " \u00b7 gauge " + run.gauge;
  // A lobe ground at a work speed program says so: its finish and timing are that program's.
  if (!run_setting(run.settings, "speed.base_speed_rpm").empty()) {
    const std::string flank = run_setting(run.settings, "speed.flank_speed_mm_per_min");
    const std::string lobe = run_setting(run.settings, "speed.lobe_speed_mm_per_min");
    auto mm_per_min = [](const std::string& v) {
      char* end = nullptr;
      const double x = std::strtod(v.c_str(), &end);
      return v.empty() || *end != '\0' ? v : format_fixed(x, 0);
    };
    w.footer_detail +=
        " \u00b7 ground at a work speed program (" +
        (!flank.empty() ? "flanks at " + mm_per_min(flank) + " mm/min" : "lobe at " + mm_per_min(lobe) + " mm/min") +
        ")";
  }
  return w;
}

// A pin run stores its radius error in error_um and the error less the least-squares circle
// (what roundness judges) as the residual: the chart shows both as a lobe's shows its raw and
// judged lift error.
CamReportWords pin_words(const StoredRun& run, const RunPart& part) {
  const LobeAnalysis& a = run.analysis;
  CamReportWords w;
  w.page_title = "Pin inspection report";
  w.item = "pin " + std::to_string(run.summary.lobe);
  w.item_label = "Pin";
  w.angle_axis = "pin degree (0 along the crank radius outward)";
  w.error_axis = "radius error, \u00b5m";
  w.error_chart = "Radius error less the least-squares circle (judged), \u00b5m";
  w.polar_title = "Polar view of the judged radius error";
  w.polar_zero = "0 (outward)";
  w.polar_angle = "pin deg";
  w.polar_reference = "least-squares circle";
  w.harmonics_title = "Harmonics of the radius error";
  w.derivative_charts = false;
  for (const Characteristic& c : run.characteristics) {
    w.characteristic_titles.push_back(characteristic_title(c.key, PartKind::kPin));
  }
  w.footer_judged = "judged: radius error less the least-squares circle, RMS " + format_fixed(a.rms_residual_um, 2) +
                    " \u00b5m, peak to valley " + format_fixed(a.peak_to_valley_residual_um, 2) +
                    " \u00b5m \u00b7 repeatability " + format_fixed(a.repeatability_um, 2) + " \u00b5m";
  const std::string mode = part.pin_mode ? (*part.pin_mode == PinMode::kCXY ? "C-X-Y" : "C-X") : "mode not recorded";
  w.footer_detail =
      "crankpin, " + mode + "; raw: the radius error as measured, circle included \u00b7 gauge " + run.gauge;
  return w;
}

std::vector<std::pair<std::string, std::string>> traceability_of(const StoredRun& run, bool pin) {
  const std::string number = run_setting(run.settings, "part.drawing_number");
  const std::string revision = run_setting(run.settings, "part.drawing_revision");
  const std::string drawing = number.empty() ? "" : revision.empty() ? number : number + " rev " + revision;
  const std::string gauge_id = run_setting(run.settings, "gauge.id");
  const std::string calibrated = run_setting(run.settings, "gauge.calibration_date");
  std::string gauge = gauge_id;
  if (!calibrated.empty()) gauge += (gauge.empty() ? "" : ", ") + std::string("calibrated ") + calibrated;
  // The part's temperature at measurement: a warm part's error told from a wrong table.
  const std::string temperature = part_temperature_text(run_part_temperature(run), "\u00b0C");
  std::vector<std::pair<std::string, std::string>> out = {
      {"Drawing", drawing}, {"Gauge", gauge}, {"Part temperature", temperature}, {"Report", report_id(run.summary)}};
  if (!pin) {
    const LobeAnalysis& a = run.analysis;
    const double nominal = *std::max_element(a.design_lift_mm.begin(), a.design_lift_mm.end());
    const double measured = *std::max_element(a.mean_lift_mm.begin(), a.mean_lift_mm.end());
    out.emplace_back("Nose lift", format_fixed(measured, 3) + " mm (drawing " + format_fixed(nominal, 3) + ")");
    const std::string rb = run_setting(run.settings, "part.base_circle_radius_mm");
    char* end = nullptr;
    const double rb_mm = std::strtod(rb.c_str(), &end);
    out.emplace_back("Base circle r", rb.empty() || *end != '\0' ? "" : format_fixed(rb_mm, 3) + " mm");
  }
  return out;
}

}  // namespace

std::string report_id(const RunSummary& run) {
  std::string id = run.machine + "-" + std::to_string(run.id);
  if (run.uuid.size() >= 8) id += "-" + run.uuid.substr(0, 8);
  return id;
}

Status check_page_file_name(const std::filesystem::path& out) {
  if (Result<chart::PageFormat> format = chart::page_format_for(out); !format) return format.error();
  return {};
}

CamReportWords cam_report_words(const StoredRun& run) {
  const RunPart part = run_part(run);
  CamReportWords w = part.pin() ? pin_words(run, part) : lobe_words(run);
  // Next to each verdict, which error it judges: the rows of the judged curve marked, the mark
  // named beside the table's title.
  bool marked = false;
  for (std::size_t i = 0; i < run.characteristics.size() && i < w.characteristic_titles.size(); ++i) {
    if (!judges_error_curve(run.characteristics[i].key, part.kind)) continue;
    w.characteristic_titles[i] += " *";
    marked = true;
  }
  if (marked) w.table_note = "* of the " + judged_error(run).name;
  w.traceability = traceability_of(run, part.pin());
  if (!part.pin()) {
    const std::optional<NoseAngle> nose = nose_angle(run);
    w.lobe_angle = nose ? "C " + format_fixed(nose->measured_c_deg, 3) + "\u00b0 from the datum (nominal " +
                              format_fixed(nose->nominal_c_deg, 3) + "\u00b0, " +
                              format_signed_fixed(nose->deviation_deg(), 3) + "\u00b0)"
                        : "not known (no frame or phase recorded)";
  }
  // The lift chart's legend; the band's entry only where a band is drawn (a pin's roundness
  // judges the whole curve: no band per degree), counting the degrees out as the chart marks.
  w.lift_legend = {"judged", "raw"};
  const DegreeLimits limits = limits_per_degree(run.characteristics, "lift_error");
  const DegreeCurve judged = nose_centred(charted_lift_error_um(run));
  int out = 0;
  for (int x = -179; x <= 180; ++x) out += outside(judged, limits, x) ? 1 : 0;
  if (out > 0) {
    w.lift_legend.push_back(std::to_string(out) + "\u00b0 out");
  } else if (std::any_of(limits.begin(), limits.end(), [](const Limits& l) { return l.any(); })) {
    w.lift_legend.emplace_back("tolerance");
  }
  return w;
}

ChartPlacement cam_report_lift_chart(const StoredRun& run) {
  const Frame f = lift_frame(report_data(run, nullptr));
  return {f.box.left, f.box.top, f.box.width, f.box.height, f.x_min, f.x_max, f.y_min, f.y_max};
}

Status write_cam_report(const StoredRun& run, const std::filesystem::path& out) {
  if (Result<chart::PageFormat> format = chart::page_format_for(out); !format) return format.error();
  Result<ErrorDerivatives> derivatives = error_derivatives(charted_lift_error_um(run));
  if (!derivatives) {
    return make_error(derivatives.error().code, "cannot draw the report of run " + std::to_string(run.summary.id) +
                                                    " to " + out.string() + ": " + derivatives.error().message);
  }
  const ReportData d = report_data(run, &*derivatives);
  const CamReportWords w = cam_report_words(run);
  return chart::write_page(out, kReportWidthPt, kReportHeightPt, [&](cairo_t* cr) {
    draw_header(cr, run, w);
    draw_lift_chart(cr, d, w);
    if (w.derivative_charts) {
      draw_derivative_chart(cr, kVelocityBox, d.velocity_mm_per_deg, d.velocity_limits, "velocity error, mm/deg",
                            "Velocity error (d/d\u03b8 of the judged lift error)");
      draw_derivative_chart(cr, kAccelerationBox, d.acceleration_mm_per_deg2, d.acceleration_limits,
                            "accel. error, mm/deg\u00b2", "Acceleration error (d\u00b2/d\u03b8\u00b2)");
    }
    draw_polar(cr, d, w);
    draw_harmonics(cr, run, w);
    draw_table(cr, run, w);
    draw_footer(cr, w);
  });
}

// ---- The trend plot ----

Result<std::vector<RunCharacteristics>> trend_plot_runs(const RunHistory& history, const RunQuery& q,
                                                        const std::string& key) {
  Result<std::vector<RunCharacteristics>> runs = history.characteristics(q, key);
  if (!runs) return runs.error();
  const bool any =
      std::any_of(runs->begin(), runs->end(), [](const RunCharacteristics& r) { return !r.characteristics.empty(); });
  if (any || runs->empty()) return runs;
  // The newest run alone, all of its characteristics: enough to name the keys to ask for, and
  // a few rows, not every characteristic of the window.
  RunQuery newest = q;
  newest.limit = 1;
  return history.characteristics(newest);
}

namespace {

// The trend plot's page in `format`'s bytes.
Result<std::string> render_trend_plot(const std::vector<RunCharacteristics>& runs, const std::string& key,
                                      chart::PageFormat format) {
  if (runs.empty()) return make_error(ErrorCode::kNotFound, "no runs to plot: no run matches the filters");
  struct Point {
    const RunSummary* run;
    const Characteristic* c;
  };
  std::vector<Point> points;
  for (const RunCharacteristics& r : runs) {
    if (const Characteristic* c = find_characteristic(r.characteristics, key)) points.push_back({&r.run, c});
  }
  if (points.empty()) {
    std::set<std::string> keys;  // of the newest run
    for (const Characteristic& c : runs.back().characteristics) keys.insert(c.key);
    std::string present;
    for (const std::string& k : keys) present += (present.empty() ? "" : ", ") + k;
    return make_error(ErrorCode::kNotFound,
                      "no run of " + runs.front().run.part + " lobe " + std::to_string(runs.front().run.lobe) +
                          " has the characteristic " + key + "; " +
                          (present.empty() ? "the newest run has none (stored before tolerances were recorded)"
                                           : "the newest run has: " + present));
  }
  const std::string unit = points.front().c->unit;
  const int dec = decimals_for_unit(unit);
  const auto n = static_cast<double>(points.size());
  Frame f{{72.0, 62.0, kTrendWidthPt - 72.0 - 30.0, 320.0}, -0.5, n - 0.5, 0.0, 0.0};
  double lo = points.front().c->value;
  double hi = lo;
  int out_count = 0;
  for (const Point& p : points) {
    lo = std::min(lo, p.c->value);
    hi = std::max(hi, p.c->value);
    if (p.c->limits.lower) lo = std::min(lo, *p.c->limits.lower);
    if (p.c->limits.upper) hi = std::max(hi, *p.c->limits.upper);
    if (p.c->verdict == Verdict::kOut) ++out_count;
  }
  const double pad = (hi - lo) * 0.08;
  lo -= pad;
  hi += pad;
  chart::nice_range(lo, hi, 6);
  f.y_min = lo;
  f.y_max = hi;
  const RunSummary& first = *points.front().run;

  return chart::render_page(format, kTrendWidthPt, kTrendHeightPt, [&](cairo_t* cr) {
    chart::set_colour(cr, chart::kInk);
    chart::text(cr, 30, 28, characteristic_title(key) + ", " + display_unit(unit), 14, Align::kLeft, true);
    chart::text(cr, 30, 43,
                first.part + " lobe " + std::to_string(first.lobe) + " \u00b7 " + std::to_string(points.size()) +
                    " runs, oldest first \u00b7 " + std::to_string(out_count) + " out of tolerance",
                9);
    chart::draw_axes(cr, f, {}, "", characteristic_title(key) + ", " + display_unit(unit), "", 6);
    // Limits per run, as steps: a run judged against other limits shows where they changed.
    chart::clip_to(cr, f);
    cairo_set_line_width(cr, 1.0);
    const double dash[] = {5.0, 3.0};
    cairo_set_dash(cr, dash, 2, 0);
    chart::set_colour(cr, chart::kOut);
    // One dashed line per stretch of runs with the same limit, so that the dashes run on.
    for (const bool upper : {false, true}) {
      const auto limit_of = [&](std::size_t i) {
        return upper ? points[i].c->limits.upper : points[i].c->limits.lower;
      };
      for (std::size_t i = 0; i < points.size();) {
        std::size_t end = i + 1;
        while (end < points.size() && limit_of(end) == limit_of(i)) ++end;
        if (const std::optional<double> l = limit_of(i)) {
          cairo_move_to(cr, f.px(static_cast<double>(i) - 0.5), f.py(*l));
          cairo_line_to(cr, f.px(static_cast<double>(end) - 0.5), f.py(*l));
        }
        i = end;
      }
    }
    cairo_stroke(cr);
    cairo_set_dash(cr, nullptr, 0, 0);
    chart::set_colour(cr, chart::kCurve);
    cairo_set_line_width(cr, 1.0);
    for (std::size_t i = 0; i < points.size(); ++i) {
      const auto x = static_cast<double>(i);
      if (i == 0) {
        cairo_move_to(cr, f.px(x), f.py(points[i].c->value));
      } else {
        cairo_line_to(cr, f.px(x), f.py(points[i].c->value));
      }
    }
    cairo_stroke(cr);
    // The dots one stroke per verdict, out of tolerance last so that they stay on top: each a
    // segment of no length with a round cap as wide as the dot (a circle in PDF, PNG and SVG
    // alike), four numbers a dot in an SVG where an arc takes 26, and one path per verdict
    // rather than one per run.
    cairo_set_line_cap(cr, CAIRO_LINE_CAP_ROUND);
    for (const Verdict v : {Verdict::kNotJudged, Verdict::kIn, Verdict::kOut}) {
      for (std::size_t i = 0; i < points.size(); ++i) {
        if (points[i].c->verdict != v) continue;
        const double x = f.px(static_cast<double>(i));
        const double y = f.py(points[i].c->value);
        cairo_move_to(cr, x, y);
        cairo_line_to(cr, x, y);
      }
      cairo_set_line_width(cr, v == Verdict::kOut ? 8.0 : 5.2);
      chart::set_colour(cr, v == Verdict::kOut ? chart::kOut : v == Verdict::kIn ? chart::kCurve : chart::kNotJudged);
      cairo_stroke(cr);
    }
    cairo_restore(cr);
    // Run ids and dates under the axis, thinned so that labels stay apart.
    const double per_run = f.box.width / n;
    const auto every = static_cast<std::size_t>(std::max(1.0, std::ceil(46.0 / per_run)));
    chart::set_colour(cr, chart::kInk);
    for (std::size_t i = 0; i < points.size(); i += every) {
      const double x = f.px(static_cast<double>(i));
      chart::text(cr, x, f.box.bottom() + 9, "run " + std::to_string(points[i].run->id), 6.5, Align::kCentre);
      chart::text(cr, x, f.box.bottom() + 17.5, points[i].run->started_utc.substr(0, 10), 6.5, Align::kCentre);
    }
    // The run labels, the dates and this line in the ticks' size: an SVG carries the outline of
    // every glyph once per size, most of its bytes and of the time it takes to write.
    chart::text(cr, f.box.left + f.box.width / 2, f.box.bottom() + 31, "runs in the order measured (started, UTC)", 6.5,
                Align::kCentre);
    // Legend.
    double lx = f.box.left;
    const double ly = kTrendHeightPt - 22;
    lx = legend_entry(cr, lx, ly, chart::kCurve, "value (in tolerance)", false);
    lx = legend_entry(cr, lx, ly, chart::kOut, "out of tolerance", true);
    lx = legend_entry(cr, lx, ly, chart::kNotJudged, "not judged", true);
    chart::set_colour(cr, chart::kOut);
    cairo_set_line_width(cr, 1.0);
    cairo_set_dash(cr, dash, 2, 0);
    cairo_move_to(cr, lx, ly - 2.5);
    cairo_line_to(cr, lx + 14, ly - 2.5);
    cairo_stroke(cr);
    cairo_set_dash(cr, nullptr, 0, 0);
    chart::set_colour(cr, chart::kInk);
    const Limits& last = points.back().c->limits;
    chart::text(cr, lx + 18, ly, "limits (newest: " + limits_text(last, dec) + " " + display_unit(unit) + ")", 6.5);
  });
}

}  // namespace

Status write_trend_plot(const std::vector<RunCharacteristics>& runs, const std::string& key,
                        const std::filesystem::path& out) {
  Result<chart::PageFormat> format = chart::page_format_for(out);
  if (!format) return format.error();
  Result<std::string> page = render_trend_plot(runs, key, *format);
  if (!page && page.error().code == ErrorCode::kIo) {
    return make_error(ErrorCode::kIo, page.error().message + " (writing " + out.string() + ")");
  }
  if (!page) return page.error();
  return write_file_atomically(out, *page);
}

Result<std::string> trend_plot_svg(const std::vector<RunCharacteristics>& runs, const std::string& key) {
  return render_trend_plot(runs, key, chart::PageFormat::kSvg);
}

}  // namespace gaugeloop
