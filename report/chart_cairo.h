// Drawing helpers the cam report and the trend plot share: one page drawn once with cairo and
// written as PDF, SVG or PNG, text, axes with ticks, and the mapping from data to the page.
// Internal to report/: cairo appears in no other folder's headers.
#pragma once

#include <cairo.h>

#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop::chart {

// The formats a page is written in, chosen by the file's extension.
enum class PageFormat { kPdf, kSvg, kPng };

// .pdf, .svg or .png (any case); kInvalidInput naming the file and the three allowed otherwise.
Result<PageFormat> page_format_for(const std::filesystem::path& out);

// A PNG has this many pixels per point of the page: 2 makes an A4 page 1684 x 1191 pixels,
// small text (7 pt) still 14 pixels high.
inline constexpr double kPngPixelsPerPoint = 2.0;

// Draws one page of width_pt x height_pt (points, origin top left, y down) into the format's
// bytes. `draw` gets a context in points whatever the format. kIo if cairo fails.
Result<std::string> render_page(PageFormat format, double width_pt, double height_pt,
                                const std::function<void(cairo_t*)>& draw);

// Renders the page and writes it to `out` atomically (write_file_atomically): the file holds
// the whole page or is left as it was. The format comes from the extension (page_format_for).
Status write_page(const std::filesystem::path& out, double width_pt, double height_pt,
                  const std::function<void(cairo_t*)>& draw);

struct Rgb {
  double r = 0.0, g = 0.0, b = 0.0;
};
// The colours every chart uses, so that a test can look for them in a PNG.
inline constexpr Rgb kInk{0.10, 0.10, 0.12};
inline constexpr Rgb kGrid{0.86, 0.86, 0.88};
inline constexpr Rgb kCurve{0.05, 0.30, 0.80};  // the judged figure
inline constexpr Rgb kFaint{0.65, 0.70, 0.80};  // the raw lift error behind it
inline constexpr Rgb kBand{0.80, 0.93, 0.80};   // inside the tolerance
inline constexpr Rgb kLimit{0.20, 0.60, 0.25};  // the tolerance limits
inline constexpr Rgb kIn{0.10, 0.55, 0.20};     // verdict in
inline constexpr Rgb kOut{0.80, 0.10, 0.10};    // verdict out
inline constexpr Rgb kNotJudged{0.45, 0.45, 0.48};

void set_colour(cairo_t* cr, Rgb c, double alpha = 1.0);

enum class Align { kLeft, kCentre, kRight };
// Text in DejaVu Sans with its baseline at y; returns its width in points.
double text(cairo_t* cr, double x, double y, std::string_view s, double size_pt, Align align = Align::kLeft,
            bool bold = false);
// `s` cut with "…" so that it is at most max_width_pt wide.
std::string fit_text(cairo_t* cr, std::string_view s, double size_pt, double max_width_pt, bool bold = false);
double text_width(cairo_t* cr, std::string_view s, double size_pt, bool bold = false);

// A rectangle on the page, points.
struct Box {
  double left = 0.0, top = 0.0, width = 0.0, height = 0.0;
  double right() const { return left + width; }
  double bottom() const { return top + height; }
};

// A chart's plot area and the data ranges it shows: x grows to the right, y upwards.
struct Frame {
  Box box;
  double x_min = 0.0, x_max = 1.0;
  double y_min = 0.0, y_max = 1.0;
  double px(double x) const { return box.left + (x - x_min) / (x_max - x_min) * box.width; }
  double py(double y) const { return box.bottom() - (y - y_min) / (y_max - y_min) * box.height; }
};

// Round tick values over [lo, hi], about `target` of them (1, 2 or 5 times a power of ten apart).
std::vector<double> nice_ticks(double lo, double hi, int target);
// [lo, hi] widened to the nearest ticks, never empty (a flat range gets +-1 or +-10 %).
void nice_range(double& lo, double& hi, int target);
// The decimals that print ticks `step` apart without losing them.
int decimals_for_step(double step);

// Frame, grid, y ticks with labels and the y axis title (rotated, left of the ticks), x ticks
// at `x_ticks` with labels and the x axis title below, and the chart title above.
void draw_axes(cairo_t* cr, const Frame& f, const std::vector<double>& x_ticks, const std::string& x_title,
               const std::string& y_title, const std::string& title, int y_target_ticks = 5);

// Clips to the frame's box until cairo_restore.
void clip_to(cairo_t* cr, const Frame& f);

}  // namespace gaugeloop::chart
