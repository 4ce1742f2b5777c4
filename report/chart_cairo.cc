// Drawing helpers for the cairo pages: formats, text, axes.
#include "report/chart_cairo.h"

#include <cairo-pdf.h>
#include <cairo-svg.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <memory>

#include "core/atomic_file.h"
#include "core/number_text.h"
#include "report/xml_text.h"

namespace gaugeloop::chart {
namespace {

cairo_status_t append_bytes(void* closure, const unsigned char* data, unsigned int length) {
  static_cast<std::string*>(closure)->append(reinterpret_cast<const char*>(data), length);
  return CAIRO_STATUS_SUCCESS;
}

struct SurfaceDeleter {
  void operator()(cairo_surface_t* s) const { cairo_surface_destroy(s); }
};
struct ContextDeleter {
  void operator()(cairo_t* cr) const { cairo_destroy(cr); }
};
using SurfacePtr = std::unique_ptr<cairo_surface_t, SurfaceDeleter>;
using ContextPtr = std::unique_ptr<cairo_t, ContextDeleter>;

Error cairo_failed(cairo_status_t status, std::string_view what) {
  return make_error(ErrorCode::kIo,
                    std::string("drawing the ") + std::string(what) + " failed: " + cairo_status_to_string(status));
}

// An SVG page's text, kept as SVG <text> elements rather than drawn by cairo: cairo's SVG surface
// writes every glyph's outline (two thirds of a chart's bytes and most of its drawing time), and
// text as text stays selectable and searchable in a browser. The layout is the same: `text`
// measures with cairo's font either way. The elements go after everything cairo drew, so text
// is on top and not clipped (no chart clips its labels).
struct SvgText {
  std::string elements;
};
const cairo_user_data_key_t kSvgTextKey{};

SvgText* svg_text_of(cairo_t* cr) { return static_cast<SvgText*>(cairo_get_user_data(cr, &kSvgTextKey)); }

// One <text> at user-space (x, y) under the context's current matrix and source colour.
void append_svg_text(cairo_t* cr, SvgText& sink, double x, double y, std::string_view s, double size_pt,
                     const char* anchor, bool bold) {
  cairo_matrix_t m;
  cairo_get_matrix(cr, &m);
  double r = 0.0, g = 0.0, b = 0.0, a = 1.0;
  cairo_pattern_get_rgba(cairo_get_source(cr), &r, &g, &b, &a);  // a chart's text is a solid colour
  const auto channel = [](double v) { return std::to_string(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); };
  std::string& o = sink.elements;
  o += "<text";
  if (m.xx != 1.0 || m.yx != 0.0 || m.xy != 0.0 || m.yy != 1.0 || m.x0 != 0.0 || m.y0 != 0.0) {
    o += " transform=\"matrix(" + format_fixed(m.xx, 6) + " " + format_fixed(m.yx, 6) + " " + format_fixed(m.xy, 6) +
         " " + format_fixed(m.yy, 6) + " " + format_fixed(m.x0, 3) + " " + format_fixed(m.y0, 3) + ")\"";
  }
  o += " x=\"" + format_fixed(x, 2) + "\" y=\"" + format_fixed(y, 2) + "\" font-size=\"" + format_fixed(size_pt, 2) +
       "\"";
  if (bold) o += " font-weight=\"bold\"";
  if (anchor[0] != '\0') o += std::string(" text-anchor=\"") + anchor + "\"";
  o += " fill=\"rgb(" + channel(r) + "," + channel(g) + "," + channel(b) + ")\"";
  if (a < 1.0) o += " fill-opacity=\"" + format_fixed(a, 3) + "\"";
  o += ">";
  o += xml_escaped(s);
  o += "</text>\n";
}

// The page's bytes with the kept text inserted before the closing </svg> tag, in a group that
// names the font once.
void insert_svg_text(std::string& page, const SvgText& sink) {
  if (sink.elements.empty()) return;
  const std::size_t end = page.rfind("</svg>");
  if (end == std::string::npos) return;
  page.insert(
      end, "<g font-family=\"DejaVu Sans, Verdana, sans-serif\" xml:space=\"preserve\">\n" + sink.elements + "</g>\n");
}

}  // namespace

Result<PageFormat> page_format_for(const std::filesystem::path& out) {
  std::string ext = out.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext == ".pdf") return PageFormat::kPdf;
  if (ext == ".svg") return PageFormat::kSvg;
  if (ext == ".png") return PageFormat::kPng;
  return make_error(ErrorCode::kInvalidInput,
                    "cannot tell the format of " + out.string() + ": name the file .pdf, .svg or .png");
}

Result<std::string> render_page(PageFormat format, double width_pt, double height_pt,
                                const std::function<void(cairo_t*)>& draw) {
  std::string bytes;
  SurfacePtr surface;
  switch (format) {
    case PageFormat::kPdf:
      surface.reset(cairo_pdf_surface_create_for_stream(append_bytes, &bytes, width_pt, height_pt));
      break;
    case PageFormat::kSvg:
      surface.reset(cairo_svg_surface_create_for_stream(append_bytes, &bytes, width_pt, height_pt));
      if (cairo_surface_status(surface.get()) == CAIRO_STATUS_SUCCESS) {
        cairo_svg_surface_set_document_unit(surface.get(), CAIRO_SVG_UNIT_PT);
      }
      break;
    case PageFormat::kPng:
      surface.reset(cairo_image_surface_create(CAIRO_FORMAT_RGB24,
                                               static_cast<int>(std::lround(width_pt * kPngPixelsPerPoint)),
                                               static_cast<int>(std::lround(height_pt * kPngPixelsPerPoint))));
      break;
  }
  if (cairo_status_t st = cairo_surface_status(surface.get()); st != CAIRO_STATUS_SUCCESS) {
    return cairo_failed(st, "page");
  }
  SvgText svg_text;
  {
    ContextPtr cr(cairo_create(surface.get()));
    if (format == PageFormat::kSvg) cairo_set_user_data(cr.get(), &kSvgTextKey, &svg_text, nullptr);
    if (format == PageFormat::kPng) cairo_scale(cr.get(), kPngPixelsPerPoint, kPngPixelsPerPoint);
    // The page is white in every format (an image surface starts black).
    cairo_set_source_rgb(cr.get(), 1, 1, 1);
    cairo_paint(cr.get());
    draw(cr.get());
    if (cairo_status_t st = cairo_status(cr.get()); st != CAIRO_STATUS_SUCCESS) return cairo_failed(st, "page");
  }
  if (format == PageFormat::kPng) {
    cairo_surface_flush(surface.get());
    if (cairo_status_t st = cairo_surface_write_to_png_stream(surface.get(), append_bytes, &bytes);
        st != CAIRO_STATUS_SUCCESS) {
      return cairo_failed(st, "PNG");
    }
  } else {
    cairo_surface_finish(surface.get());
  }
  if (cairo_status_t st = cairo_surface_status(surface.get()); st != CAIRO_STATUS_SUCCESS) {
    return cairo_failed(st, "page");
  }
  if (format == PageFormat::kSvg) insert_svg_text(bytes, svg_text);
  return bytes;
}

Status write_page(const std::filesystem::path& out, double width_pt, double height_pt,
                  const std::function<void(cairo_t*)>& draw) {
  Result<PageFormat> format = page_format_for(out);
  if (!format) return format.error();
  Result<std::string> bytes = render_page(*format, width_pt, height_pt, draw);
  if (!bytes) return make_error(bytes.error().code, bytes.error().message + " (writing " + out.string() + ")");
  return write_file_atomically(out, *bytes);
}

void set_colour(cairo_t* cr, Rgb c, double alpha) { cairo_set_source_rgba(cr, c.r, c.g, c.b, alpha); }

namespace {
void select_font(cairo_t* cr, double size_pt, bool bold) {
  cairo_select_font_face(cr, "DejaVu Sans", CAIRO_FONT_SLANT_NORMAL,
                         bold ? CAIRO_FONT_WEIGHT_BOLD : CAIRO_FONT_WEIGHT_NORMAL);
  cairo_set_font_size(cr, size_pt);
}
}  // namespace

double text_width(cairo_t* cr, std::string_view s, double size_pt, bool bold) {
  select_font(cr, size_pt, bold);
  const std::string str(s);
  cairo_text_extents_t ext;
  cairo_text_extents(cr, str.c_str(), &ext);
  return ext.x_advance;
}

double text(cairo_t* cr, double x, double y, std::string_view s, double size_pt, Align align, bool bold) {
  const double w = text_width(cr, s, size_pt, bold);
  if (SvgText* sink = svg_text_of(cr)) {
    append_svg_text(cr, *sink, x, y, s, size_pt,
                    align == Align::kCentre  ? "middle"
                    : align == Align::kRight ? "end"
                                             : "",
                    bold);
    return w;
  }
  if (align == Align::kCentre) x -= w / 2;
  if (align == Align::kRight) x -= w;
  const std::string str(s);
  cairo_move_to(cr, x, y);
  cairo_show_text(cr, str.c_str());
  cairo_new_path(cr);
  return w;
}

std::string fit_text(cairo_t* cr, std::string_view s, double size_pt, double max_width_pt, bool bold) {
  std::string t(s);
  if (text_width(cr, t, size_pt, bold) <= max_width_pt) return t;
  while (!t.empty()) {
    t.pop_back();
    // Never leave half a UTF-8 character.
    while (!t.empty() && (static_cast<unsigned char>(t.back()) & 0xC0) == 0x80) t.pop_back();
    if (!t.empty() && (static_cast<unsigned char>(t.back()) & 0x80) != 0) t.pop_back();
    if (text_width(cr, t + "\u2026", size_pt, bold) <= max_width_pt) return t + "\u2026";
  }
  return "\u2026";
}

namespace {
double nice_step(double span, int target) {
  const double raw = span / std::max(1, target);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double f = raw / mag;
  const double nice = f < 1.5 ? 1.0 : f < 3.5 ? 2.0 : f < 7.5 ? 5.0 : 10.0;
  return nice * mag;
}
}  // namespace

void nice_range(double& lo, double& hi, int target) {
  if (!(hi > lo)) {
    const double pad = lo == 0.0 ? 1.0 : std::abs(lo) * 0.1;
    lo -= pad;
    hi += pad;
  }
  const double step = nice_step(hi - lo, target);
  lo = std::floor(lo / step + 1e-9) * step;
  hi = std::ceil(hi / step - 1e-9) * step;
}

std::vector<double> nice_ticks(double lo, double hi, int target) {
  std::vector<double> ticks;
  if (!(hi > lo)) return ticks;
  const double step = nice_step(hi - lo, target);
  for (double v = std::ceil(lo / step - 1e-9) * step; v <= hi + step * 1e-9; v += step) {
    ticks.push_back(std::abs(v) < step * 1e-9 ? 0.0 : v);
  }
  return ticks;
}

int decimals_for_step(double step) {
  if (!(step > 0)) return 0;
  int d = 0;
  while (d < 8 && std::abs(step * std::pow(10.0, d) - std::round(step * std::pow(10.0, d))) > 1e-6) ++d;
  return d;
}

void clip_to(cairo_t* cr, const Frame& f) {
  cairo_save(cr);
  cairo_rectangle(cr, f.box.left, f.box.top, f.box.width, f.box.height);
  cairo_clip(cr);
}

void draw_axes(cairo_t* cr, const Frame& f, const std::vector<double>& x_ticks, const std::string& x_title,
               const std::string& y_title, const std::string& title, int y_target_ticks) {
  const Box& b = f.box;
  const std::vector<double> y_ticks = nice_ticks(f.y_min, f.y_max, y_target_ticks);
  const int y_decimals = y_ticks.size() >= 2 ? decimals_for_step(y_ticks[1] - y_ticks[0]) : 0;
  cairo_set_line_width(cr, 0.4);
  set_colour(cr, kGrid);
  for (double y : y_ticks) {
    cairo_move_to(cr, b.left, f.py(y));
    cairo_line_to(cr, b.right(), f.py(y));
  }
  for (double x : x_ticks) {
    cairo_move_to(cr, f.px(x), b.top);
    cairo_line_to(cr, f.px(x), b.bottom());
  }
  cairo_stroke(cr);
  set_colour(cr, kInk);
  double widest = 0.0;
  for (double y : y_ticks) {
    widest = std::max(widest, text(cr, b.left - 3, f.py(y) + 2.3, format_fixed(y, y_decimals), 6.5, Align::kRight));
  }
  const int x_decimals = x_ticks.size() >= 2 ? decimals_for_step(x_ticks[1] - x_ticks[0]) : 0;
  for (double x : x_ticks) text(cr, f.px(x), b.bottom() + 8.5, format_fixed(x, x_decimals), 6.5, Align::kCentre);
  if (!x_title.empty()) text(cr, b.left + b.width / 2, b.bottom() + 18, x_title, 7, Align::kCentre);
  if (!y_title.empty()) {
    cairo_save(cr);
    cairo_translate(cr, b.left - widest - 7, b.top + b.height / 2);
    cairo_rotate(cr, -M_PI / 2);
    text(cr, 0, 0, y_title, 7, Align::kCentre);
    cairo_restore(cr);
  }
  if (!title.empty()) text(cr, b.left, b.top - 5, title, 8, Align::kLeft, true);
  cairo_set_line_width(cr, 0.6);
  cairo_rectangle(cr, b.left, b.top, b.width, b.height);
  cairo_stroke(cr);
}

}  // namespace gaugeloop::chart
