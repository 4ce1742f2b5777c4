// The gear report, drawn with cairo (report/chart_cairo.h).
#include "report/gear_report.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/number_text.h"
#include "report/cam_report.h"
#include "report/chart_cairo.h"
#include "report/gear_characteristics.h"

namespace gaugeloop {
namespace {

using chart::Align;
using chart::Box;
using chart::Frame;

constexpr double kPageWidthPt = 842.0;  // A4 landscape
constexpr double kPageHeightPt = 595.0;
constexpr double kMarginPt = 36.0;
constexpr chart::Rgb kLeftFlank{0.05, 0.30, 0.80};
constexpr chart::Rgb kRightFlank{0.85, 0.45, 0.05};  // orange: red is the verdict out

std::string um_text(double v) { return format_fixed(v, 2) + " um"; }

// The traces of each gap, left flank first.
std::map<int, std::vector<const GearTraceRecord*>> by_gap(const GearRunRecord& r) {
  std::map<int, std::vector<const GearTraceRecord*>> out;
  for (const GearTraceRecord& t : r.traces) out[t.gap].push_back(&t);
  for (auto& [gap, traces] : out) {
    std::sort(traces.begin(), traces.end(),
              [](const GearTraceRecord* a, const GearTraceRecord* b) { return a->flank < b->flank; });
  }
  return out;
}

void draw_header(cairo_t* cr, const StoredGearRun& g) {
  const GearRunRecord& r = g.record;
  chart::set_colour(cr, chart::kInk);
  chart::text(cr, kMarginPt, kMarginPt + 4,
              "Gear run " + std::to_string(g.id) + ": " + r.part + " on " + r.machine +
                  (r.profiles.empty() ? " - lead (helix) report" : " - lead (helix) and profile report"),
              15.0, Align::kLeft, true);
  std::string who = "Measured " + r.started_utc + " by " + r.source;
  if (!r.serial.empty()) who += "; serial " + r.serial;
  if (!r.operator_name.empty()) who += "; operator " + r.operator_name;
  chart::text(cr, kMarginPt, kMarginPt + 22, chart::fit_text(cr, who, 9.0, kPageWidthPt - 2 * kMarginPt), 9.0);
  std::string stroke = "Ground from " + r.nc_file + ", stroke version " +
                       (r.ground_with_version ? std::to_string(*r.ground_with_version) : std::string("not known"));
  if (g.pushed_version) stroke += "; stroke version " + std::to_string(*g.pushed_version) + " pushed from this gear";
  chart::text(cr, kMarginPt, kMarginPt + 35, chart::fit_text(cr, stroke, 9.0, kPageWidthPt - 2 * kMarginPt), 9.0);
  // The verdict, in its colour, and what it was judged against.
  const chart::Rgb colour = r.verdict == Verdict::kIn    ? chart::kIn
                            : r.verdict == Verdict::kOut ? chart::kOut
                                                         : chart::kNotJudged;
  chart::set_colour(cr, colour);
  const std::string word = r.verdict == Verdict::kIn ? "IN" : r.verdict == Verdict::kOut ? "OUT" : "NOT JUDGED";
  const double w = chart::text(cr, kMarginPt, kMarginPt + 56, word, 14.0, Align::kLeft, true);
  chart::set_colour(cr, chart::kInk);
  std::string against = "F_beta " + um_text(r.total_max_um) + " at worst (ISO 1328-1 class " +
                        std::to_string(r.tolerance_class) + "), " + um_text(r.total_mean_um) + " mean; ";
  against += r.required_class ? "class " + std::to_string(*r.required_class) + " asked: F_beta within " +
                                    um_text(r.total_tolerance_um.value_or(0.0))
                              : std::string("the part names no tolerance class");
  chart::text(cr, kMarginPt + w + 10, kMarginPt + 56, against, 10.0);
  // The profile's line: what it was, or that it was not measured.
  std::string profile = "profile: not measured (the traces are leads only)";
  if (!r.profiles.empty()) {
    const GearProfileFigures p = gear_profile_figures(r);
    profile = "profile: F_alpha " + um_text(p.total_max_um) + " at worst (class " + std::to_string(p.tolerance_class) +
              "), " + um_text(p.total_mean_um) + " mean";
    if (r.profile_tolerance_um) profile += "; F_alpha within " + um_text(*r.profile_tolerance_um) + " asked";
  }
  chart::text(cr, kMarginPt + w + 10, kMarginPt + 70, profile, 9.0);
}

// One gap's lead chart: Z up, the deviation across, left and right flank, the evaluation range.
void draw_gap(cairo_t* cr, const Box& box, int gap, const std::vector<const GearTraceRecord*>& traces, double span_um) {
  double z_lo = 0.0, z_hi = 0.0;
  bool first = true;
  for (const GearTraceRecord* t : traces) {
    for (double z : t->z_mm) {
      z_lo = first ? z : std::min(z_lo, z);
      z_hi = first ? z : std::max(z_hi, z);
      first = false;
    }
  }
  if (z_hi <= z_lo) z_hi = z_lo + 1.0;
  Frame f{box, -span_um, span_um, z_lo, z_hi};
  const std::vector<double> x_ticks = chart::nice_ticks(-span_um, span_um, 4);
  chart::draw_axes(cr, f, x_ticks, "deviation, um", "Z, mm", "gap " + std::to_string(gap), 4);
  cairo_save(cr);
  chart::clip_to(cr, f);
  // The evaluation range of ISO 1328-1.
  chart::set_colour(cr, chart::kLimit);
  cairo_set_line_width(cr, 0.6);
  const double dash[] = {3.0, 2.0};
  cairo_set_dash(cr, dash, 2, 0.0);
  for (double z : {traces.front()->from_mm, traces.front()->to_mm}) {
    cairo_move_to(cr, box.left, f.py(z));
    cairo_line_to(cr, box.right(), f.py(z));
  }
  cairo_stroke(cr);
  cairo_set_dash(cr, nullptr, 0, 0.0);
  for (const GearTraceRecord* t : traces) {
    chart::set_colour(cr, t->flank == "left" ? kLeftFlank : kRightFlank);
    cairo_set_line_width(cr, 1.1);
    for (std::size_t i = 0; i < t->z_mm.size(); ++i) {
      const double x = f.px(t->deviation_um[i]);
      const double y = f.py(t->z_mm[i]);
      if (i == 0) {
        cairo_move_to(cr, x, y);
      } else {
        cairo_line_to(cr, x, y);
      }
    }
    cairo_stroke(cr);
  }
  cairo_restore(cr);
}

// A table of traces (leads or profiles: `head` names their figures), each judged against
// `tolerance_um` (none: not judged); returns where the next line would go. Rows that do not fit
// on the page are left out: the export has every trace.
template <typename Trace>
double draw_table(cairo_t* cr, double top, const std::vector<Trace>& traces, const std::vector<std::string>& head,
                  std::optional<double> tolerance_um) {
  const std::vector<double> x = {kMarginPt,       kMarginPt + 40,  kMarginPt + 150, kMarginPt + 240,
                                 kMarginPt + 330, kMarginPt + 405, kMarginPt + 455};
  chart::set_colour(cr, chart::kInk);
  for (std::size_t c = 0; c < head.size(); ++c) chart::text(cr, x[c], top, head[c], 8.0, Align::kLeft, true);
  double y = top + 11;
  for (const Trace& t : traces) {
    if (y > kPageHeightPt - kMarginPt + 10) break;
    const std::string judged = !tolerance_um ? "not judged" : t.total_um <= *tolerance_um ? "in" : "out";
    chart::set_colour(cr, chart::kInk);
    const std::vector<std::string> row = {std::to_string(t.gap),       t.flank,
                                          format_fixed(t.total_um, 2), format_fixed(t.form_um, 2),
                                          format_fixed(t.slope_um, 2), std::to_string(t.tolerance_class)};
    for (std::size_t c = 0; c < row.size(); ++c) chart::text(cr, x[c], y, row[c], 8.0);
    chart::set_colour(cr, judged == "in" ? chart::kIn : judged == "out" ? chart::kOut : chart::kNotJudged);
    chart::text(cr, x[6], y, judged, 8.0);
    y += 10;
  }
  return y;
}

}  // namespace

Status write_gear_report(const StoredGearRun& run, const std::filesystem::path& out) {
  if (Status s = check_page_file_name(out); !s) return s;
  if (run.record.traces.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      "gear run " + std::to_string(run.id) + " has no lead trace to report; load it with its traces");
  }
  const auto gaps = by_gap(run.record);
  double span = 1.0;
  for (const GearTraceRecord& t : run.record.traces) {
    for (double d : t.deviation_um) span = std::max(span, std::abs(d));
  }
  double lo = -span, hi = span;
  chart::nice_range(lo, hi, 4);
  span = std::max(-lo, hi);
  return chart::write_page(out, kPageWidthPt, kPageHeightPt, [&](cairo_t* cr) {
    draw_header(cr, run);
    // Up to 6 gaps a row of charts; more are in the table and the export.
    const int n = std::min<int>(6, static_cast<int>(gaps.size()));
    const double gutter = 30.0;
    const double width = (kPageWidthPt - 2 * kMarginPt - 30 - (n - 1) * gutter) / n;
    int k = 0;
    for (const auto& [gap, traces] : gaps) {
      if (k == n) break;
      const Box box{kMarginPt + 30 + k * (width + gutter), kMarginPt + 90, width, 200};
      draw_gap(cr, box, gap, traces, span);
      ++k;
    }
    chart::set_colour(cr, kLeftFlank);
    chart::text(cr, kMarginPt, kMarginPt + 330, "left flank", 8.0, Align::kLeft, true);
    chart::set_colour(cr, kRightFlank);
    chart::text(cr, kMarginPt + 60, kMarginPt + 330, "right flank", 8.0, Align::kLeft, true);
    chart::set_colour(cr, chart::kLimit);
    chart::text(cr, kMarginPt + 125, kMarginPt + 330, "- - evaluation range (ISO 1328-1)", 8.0);
    const GearRunRecord& r = run.record;
    const double after = draw_table(cr, kMarginPt + 350, r.traces,
                                    {"gap", "flank", "F_beta um", "f_f_beta um", "f_H_beta um", "class", "verdict"},
                                    r.total_tolerance_um);
    if (!r.profiles.empty() && after + 16 < kPageHeightPt - kMarginPt) {
      draw_table(cr, after + 8, r.profiles,
                 {"gap", "flank", "F_alpha um", "f_f_alpha um", "f_H_alpha um", "class", "verdict"},
                 r.profile_tolerance_um);
    }
  });
}

}  // namespace gaugeloop
