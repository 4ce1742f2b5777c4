// The new program's preview page: six charts over one turn of C.
#include "report/program_preview.h"

#include <algorithm>
#include <cmath>

#include "report/cam_report.h"
#include "report/chart_cairo.h"

namespace gaugeloop {
namespace {

using chart::Box;
using chart::Frame;

struct Series {
  const std::vector<double>* values;
  chart::Rgb colour;
  std::string label;
};

std::vector<double> c_ticks() { return {0, 60, 120, 180, 240, 300, 360}; }

// One chart over C 0..360 of one or two series; `limit` draws a dashed bound line.
void draw_chart(cairo_t* cr, const Box& box, const std::string& title, const std::string& y_title,
                const std::vector<Series>& series, std::optional<double> limit = std::nullopt) {
  double lo = 0.0;
  double hi = 0.0;
  bool first = true;
  for (const Series& s : series) {
    for (double v : *s.values) {
      if (!std::isfinite(v)) continue;
      lo = first ? v : std::min(lo, v);
      hi = first ? v : std::max(hi, v);
      first = false;
    }
  }
  if (limit) hi = std::max(hi, *limit * 1.15);
  chart::nice_range(lo, hi, 4);
  Frame f{box, 0.0, 360.0, lo, hi};
  chart::draw_axes(cr, f, c_ticks(), "C, deg", y_title, title, 4);
  cairo_save(cr);
  chart::clip_to(cr, f);
  if (limit) {
    const double dash[] = {4.0, 3.0};
    cairo_set_dash(cr, dash, 2, 0.0);
    chart::set_colour(cr, chart::kLimit);
    cairo_set_line_width(cr, 0.8);
    cairo_move_to(cr, f.px(0.0), f.py(*limit));
    cairo_line_to(cr, f.px(360.0), f.py(*limit));
    cairo_stroke(cr);
    cairo_set_dash(cr, nullptr, 0, 0.0);
  }
  for (const Series& s : series) {
    chart::set_colour(cr, s.colour);
    cairo_set_line_width(cr, 1.0);
    const std::vector<double>& v = *s.values;
    for (std::size_t d = 0; d < v.size(); ++d) {
      const double x = f.px(static_cast<double>(d));
      if (d == 0) {
        cairo_move_to(cr, x, f.py(v[d]));
      } else {
        cairo_line_to(cr, x, f.py(v[d]));
      }
    }
    if (!v.empty()) cairo_line_to(cr, f.px(360.0), f.py(v.front()));  // the turn closes
    cairo_stroke(cr);
  }
  cairo_restore(cr);
  double x = box.left;
  for (const Series& s : series) {
    if (s.label.empty()) continue;
    chart::set_colour(cr, s.colour);
    cairo_rectangle(cr, x, box.bottom() + 22.0, 8.0, 3.0);
    cairo_fill(cr);
    chart::set_colour(cr, chart::kInk);
    x += 12.0 + chart::text(cr, x + 12.0, box.bottom() + 26.0, s.label, 7.0) + 12.0;
  }
}

}  // namespace

Status write_program_preview(const ProgramPreviewPage& p, const std::filesystem::path& out) {
  if (Result<chart::PageFormat> format = chart::page_format_for(out); !format) return format.error();
  const std::size_t n = p.x_mm.size();
  for (const std::vector<double>* v : {&p.dx_mm_per_deg, &p.d2x_mm_per_deg2, &p.c_speed_rpm,
                                       &p.grinding_point_speed_mm_per_min, &p.command_error_um}) {
    if (v->size() != n || n == 0) {
      return make_error(ErrorCode::kInvalidInput, "program preview: every series needs one value per degree");
    }
  }
  return chart::write_page(out, kReportWidthPt, kReportHeightPt, [&](cairo_t* cr) {
    constexpr double kPreviewMarginPt = 36.0;
    chart::set_colour(cr, chart::kInk);
    chart::text(cr, kPreviewMarginPt, 40.0,
                chart::fit_text(cr, p.title, 14.0, kReportWidthPt - 2 * kPreviewMarginPt, true), 14.0,
                chart::Align::kLeft, true);
    chart::text(cr, kPreviewMarginPt, 56.0, chart::fit_text(cr, p.subtitle, 8.0, kReportWidthPt - 2 * kPreviewMarginPt),
                8.0);
    const double col_w = (kReportWidthPt - 2 * kPreviewMarginPt - 2 * 60.0) / 3.0;
    const double row_h = 170.0;
    auto box = [&](int col, int row) {
      return Box{kPreviewMarginPt + 40.0 + col * (col_w + 60.0), 90.0 + row * (row_h + 70.0), col_w - 20.0, row_h};
    };
    std::vector<Series> path{{&p.x_mm, chart::kCurve, p.y_mm.empty() ? std::string() : "X"}};
    if (!p.y_mm.empty()) path.push_back({&p.y_mm, chart::kLimit, "Y"});
    draw_chart(cr, box(0, 0), p.y_mm.empty() ? "Wheel path X" : "Wheel path X and Y", "mm", path);
    draw_chart(cr, box(1, 0), "dX/dC", "mm/deg", {{&p.dx_mm_per_deg, chart::kCurve, ""}});
    draw_chart(cr, box(2, 0), "d2X/dC2", "mm/deg^2", {{&p.d2x_mm_per_deg2, chart::kCurve, ""}});
    draw_chart(cr, box(0, 1), "Work spindle C", "rpm", {{&p.c_speed_rpm, chart::kCurve, ""}});
    draw_chart(cr, box(1, 1), "Grinding-point speed", "mm/min",
               {{&p.grinding_point_speed_mm_per_min, chart::kCurve, ""}});
    std::vector<Series> error{{&p.command_error_um, chart::kCurve, p.y_command_error_um.empty() ? "" : "X table"}};
    if (!p.y_command_error_um.empty()) error.push_back({&p.y_command_error_um, chart::kLimit, "Y table"});
    draw_chart(cr, box(2, 1), "Command position error per degree", "um", error, p.command_error_bound_um);
    chart::set_colour(cr, chart::kNotJudged);
    chart::text(cr, kPreviewMarginPt, kReportHeightPt - 18.0,
                chart::fit_text(cr, p.footer, 7.0, kReportWidthPt - 2 * kPreviewMarginPt), 7.0);
  });
}

}  // namespace gaugeloop
