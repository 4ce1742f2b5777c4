// The lobe error of one run as an SVG picture: polar and linear, with the tolerance band.
#include "report/svg_plot.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <numbers>
#include <vector>

#include "core/number_text.h"
#include "core/utf8.h"
#include "report/judged_error.h"
#include "report/xml_text.h"

namespace gaugeloop {
namespace {

// Where an error plot's parts go, px: wide, the panels side by side (1200 x 640: a screen or A4
// landscape), or narrow, stacked (380 x 1060: a phone held upright, drawn at about the phone's
// width so that its text reads at the size it is drawn). The loop plot is always wide.
struct Layout {
  int width, height;
  double margin;               // left and right
  double title_y, subtitle_y;  // baselines
  int title_size, subtitle_size;
  double verdict_y;                                 // the headline's first line
  bool stacked;                                     // narrow: headline under the title, left-aligned
  double polar_cx, polar_cy, polar_r0, polar_span;  // the zero-error circle and the room for +-scale
  double polar_title_y, polar_scale_y;
  double plot_left, plot_right, plot_top, plot_bottom, plot_title_y;  // the linear panel
  int angle_label_step;                                               // degrees between its angle labels
  int axis_title_size;
  double legend_left, legend_y;
};

constexpr Layout kWide{1200, 640, 40,  46,  72,   22,  14,  46,  false, 300, 345, 125,
                       85,   104, 604, 640, 1160, 120, 540, 104, 30,    12,  600, 598};
constexpr Layout kNarrow{380, 1060, 20,  32, 54,  16,  12,  84,  true, 190, 355, 100,
                         55,  168,  556, 62, 360, 612, 860, 596, 60,   11,  20,  930};
constexpr int kWidth = kWide.width;
constexpr int kHeight = kWide.height;

constexpr const char* kErrorColour = "#1f4e9c";
constexpr const char* kSpreadColour = "#9db8e3";
constexpr const char* kRawColour = "#9aa3ad";
constexpr const char* kCorrectionColour = "#d9730d";
constexpr const char* kToleranceColour = "#d7efd9";
constexpr const char* kOutColour = "#c62828";
constexpr const char* kGridColour = "#d0d4da";
constexpr const char* kTextColour = "#1d2329";
constexpr const char* kMutedColour = "#5f6b76";

// Fixed notation with `decimals`, '.' as the separator whatever the C locale.
// A coordinate or a figure on the plot: one decimal unless said.
std::string num(double v, int decimals = 1) { return format_fixed(v, decimals); }

std::string escape(const std::string& text) { return xml_escaped(text); }

// A round grid step: 1, 2 or 5 times a power of ten, so that `span` takes about 4 steps.
double nice_step(double span) {
  const double raw = std::max(span, 1e-6) / 4.0;
  const double decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * decade >= raw) return m * decade;
  }
  return 10.0 * decade;
}

// Cam angle (degrees, 0 at the nose drawn at the top, growing clockwise so that the opening
// side lies left of the nose as in the linear panel) to the page.
double polar_x(const Layout& L, double deg, double r) {
  return L.polar_cx + r * std::sin(deg * std::numbers::pi / 180.0);
}
double polar_y(const Layout& L, double deg, double r) {
  return L.polar_cy - r * std::cos(deg * std::numbers::pi / 180.0);
}

struct Text {
  double x, y;
  std::string text;
  int size = 13;
  const char* anchor = "start";
  const char* colour = kTextColour;
  const char* weight = "normal";
  bool halo = false;  // a white outline, for labels drawn over curves
};

void add_text(std::string& svg, const Text& t) {
  svg += "<text x=\"" + num(t.x) + "\" y=\"" + num(t.y) + "\" font-size=\"" + std::to_string(t.size) +
         "\" text-anchor=\"" + t.anchor + "\" fill=\"" + t.colour + "\" font-weight=\"" + t.weight + "\"" +
         (t.halo ? " stroke=\"#ffffff\" stroke-width=\"3\" paint-order=\"stroke\"" : "") + ">" + escape(t.text) +
         "</text>\n";
}

void add_line(std::string& svg, double x1, double y1, double x2, double y2, const char* colour, double width,
              const char* dash = nullptr) {
  svg += "<line x1=\"" + num(x1) + "\" y1=\"" + num(y1) + "\" x2=\"" + num(x2) + "\" y2=\"" + num(y2) + "\" stroke=\"" +
         colour + "\" stroke-width=\"" + num(width, 2) + "\"";
  if (dash != nullptr) svg += std::string(" stroke-dasharray=\"") + dash + "\"";
  svg += "/>\n";
}

// A closed ring of radius r(deg) around the polar centre, as path data.
template <typename RadiusOf>
std::string polar_ring(const Layout& L, RadiusOf radius_of) {
  std::string d;
  for (int deg = 0; deg < kDegreesPerRevolution; ++deg) {
    const double r = radius_of(deg);
    d += (deg == 0 ? "M" : "L") + num(polar_x(L, deg, r), 2) + "," + num(polar_y(L, deg, r), 2);
  }
  return d + "Z";
}

std::string circle_path(const Layout& L, double r) {
  return "M" + num(L.polar_cx - r, 2) + "," + num(L.polar_cy, 2) + "a" + num(r, 2) + "," + num(r, 2) + " 0 1,0 " +
         num(2 * r, 2) + ",0a" + num(r, 2) + "," + num(r, 2) + " 0 1,0 " + num(-2 * r, 2) + ",0Z";
}

// The code points of `text` (a byte that starts no UTF-8 sequence counts as one).
std::size_t code_points(const std::string& text) {
  std::size_t count = 0;
  for (std::size_t i = 0; i < text.size(); ++count) {
    char32_t cp = 0;
    const std::size_t n = utf8_sequence_at(text, i, cp);
    i += n == 0 ? 1 : n;
  }
  return count;
}

// `text` cut to what `max_px` holds at `font_px` with an ellipsis where it was cut. Characters
// (code points) are taken at 0.62 em, wider than DejaVu Sans's average, so nothing cut runs
// over what stands beside it.
std::string fit_text(const std::string& text, double max_px, int font_px) {
  const auto fits = static_cast<std::size_t>(max_px / (0.62 * font_px));
  std::vector<std::size_t> starts;  // byte offset of each code point
  for (std::size_t i = 0; i < text.size();) {
    starts.push_back(i);
    char32_t cp = 0;
    const std::size_t n = utf8_sequence_at(text, i, cp);
    i += n == 0 ? 1 : n;
  }
  if (starts.size() <= fits || fits < 2) return text;
  return text.substr(0, starts[fits - 1]) + "\u2026";
}

// `text` in lines of at most `max_px` at `font_px` (as fit_text measures), broken after the
// " · " between its figures; a figure longer than a line is a line of its own.
std::vector<std::string> wrapped_at_dots(const std::string& text, double max_px, int font_px) {
  const std::string dot = " \u00b7 ";
  const auto fits = static_cast<std::size_t>(max_px / (0.62 * font_px));
  std::vector<std::string> lines;
  std::string line;
  for (std::size_t at = 0; at <= text.size();) {
    std::size_t end = text.find(dot, at);
    if (end == std::string::npos) end = text.size();
    const std::string part = text.substr(at, end - at);
    const std::string joined = line.empty() ? part : line + dot + part;
    if (!line.empty() && code_points(joined) > fits) {
      lines.push_back(line + " \u00b7");
      line = part;
    } else {
      line = joined;
    }
    at = end + dot.size();
  }
  lines.push_back(line);
  return lines;
}

// `text` at (x, y), cut to `max_px` with an ellipsis where it is too long for its room; the
// whole of it is then the text's tooltip.
void add_fitted_text(std::string& svg, Text t, double max_px) {
  const std::string shown = fit_text(t.text, max_px, t.size);
  if (shown == t.text) {
    add_text(svg, t);
    return;
  }
  svg += "<text x=\"" + num(t.x) + "\" y=\"" + num(t.y) + "\" font-size=\"" + std::to_string(t.size) +
         "\" text-anchor=\"" + t.anchor + "\" fill=\"" + t.colour + "\" font-weight=\"" + t.weight + "\"><title>" +
         escape(t.text) + "</title>" + escape(shown) + "</text>\n";
}

// The document, its white page, title and subtitle. A title or subtitle too long for its room
// (a long note or serial) is cut with an ellipsis; the whole of it is the text's tooltip. The
// subtitle's room on a wide page ends short of the headline beside it (about 430 px at 13 px).
std::string start_document(const std::string& title, const std::string& subtitle, const Layout& L) {
  std::string svg;
  svg.reserve(64 * 1024);
  svg += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(L.width) + "\" height=\"" +
         std::to_string(L.height) + "\" viewBox=\"0 0 " + std::to_string(L.width) + " " + std::to_string(L.height) +
         "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  const double room = L.width - 2 * L.margin;
  add_fitted_text(svg, {L.margin, L.title_y, title, L.title_size, "start", kTextColour, "bold"}, room);
  add_fitted_text(svg, {L.margin, L.subtitle_y, subtitle, L.subtitle_size, "start", kMutedColour},
                  L.stacked ? room : room - 460.0);
  return svg;
}

// A panel of lift error (-scale..+scale um, grid every `step`) over the signed cam angle
// -180..180 (signed_degree), the nose in the middle; a grid line every 30 degrees, labelled
// every `label_step`.
struct DegreePanel {
  double left, right, top, bottom;
  double scale, step;
  std::string y_title = "lift error (\u00b5m)";
  std::string x_title = "cam angle (deg, 0 = nose, opening side negative)";
  int label_step = 30;
  int title_size = 12;

  double x_of(double deg) const { return left + (right - left) * (deg + 180.0) / 360.0; }
  double y_of(double um) const { return (top + bottom) / 2.0 - um * (bottom - top) / (2.0 * scale); }

  // Grid, scale labels, frame and axis titles.
  void draw_axes(std::string& svg) const {
    for (double e = -scale; e <= scale + 1e-9; e += step) {
      const bool zero = std::abs(e) < 1e-9;
      add_line(svg, left, y_of(e), right, y_of(e), zero ? "#8a949e" : kGridColour, zero ? 1.2 : 0.8);
      add_text(svg, {left - 8, y_of(e) + 4, (e > 0 ? "+" : "") + num(e, step < 1 ? 1 : 0), 11, "end", kMutedColour});
    }
    for (int deg = -180; deg <= 180; deg += 30) {
      add_line(svg, x_of(deg), top, x_of(deg), bottom, kGridColour, 0.8);
      if ((deg + 180) % label_step == 0) {
        add_text(svg, {x_of(deg), bottom + 18, std::to_string(deg), 11, "middle", kMutedColour});
      }
    }
    svg += "<rect x=\"" + num(left) + "\" y=\"" + num(top) + "\" width=\"" + num(right - left) + "\" height=\"" +
           num(bottom - top) + "\" fill=\"none\" stroke=\"#8a949e\" stroke-width=\"1\"/>\n";
    add_text(svg, {(left + right) / 2, bottom + 40, x_title, title_size, "middle", kMutedColour});
    const double y0 = (top + bottom) / 2.0;
    svg += "<text x=\"" + num(left - 46) + "\" y=\"" + num(y0) + "\" font-size=\"12\" text-anchor=\"middle\" fill=\"" +
           kMutedColour + "\" transform=\"rotate(-90 " + num(left - 46) + " " + num(y0) + ")\">" + escape(y_title) +
           "</text>\n";
  }

  // Polyline points of a table from -180 to 180 deg (the value at 180 drawn at both ends).
  std::string points(const DegreeTable& t) const {
    std::string pts;
    for (int deg = -180; deg <= 180; ++deg) {
      pts += num(x_of(deg), 2) + "," + num(y_of(t[degree_index(deg)]), 2) + " ";
    }
    return pts;
  }
};

// The limits at degree d: limits_um's, or the symmetric tolerance's.
Limits limits_at(const ErrorPlot& p, std::size_t d) {
  if (p.limits_um) return (*p.limits_um)[d];
  if (p.tolerance_um) return Limits{-*p.tolerance_um, *p.tolerance_um};
  return {};
}

bool has_limits(const ErrorPlot& p) {
  for (std::size_t d = 0; d < p.error_um.size(); ++d) {
    if (limits_at(p, d).any()) return true;
  }
  return false;
}

bool out_of_tolerance(const ErrorPlot& p, std::size_t d) {
  const Limits l = limits_at(p, d);
  const double v = p.error_um[d];
  return (l.lower && v < *l.lower) || (l.upper && v > *l.upper);
}

// The one symmetric band that holds at every degree, as "±12.0 µm"; empty when the limits
// differ by zone (or are one-sided).
std::string uniform_limits_text(const ErrorPlot& p) {
  const Limits first = limits_at(p, 0);
  bool uniform = first.lower && first.upper && std::abs(*first.lower + *first.upper) < 1e-9;
  for (std::size_t d = 1; d < p.error_um.size() && uniform; ++d) {
    const Limits l = limits_at(p, d);
    uniform = l.lower == first.lower && l.upper == first.upper;
  }
  return uniform ? "\u00b1" + num(*first.upper, 1) + " \u00b5m" : std::string();
}

// Runs of whole signed degrees [from, to] (-179..180) with the same limits, in order; only
// those with limits.
struct LimitRun {
  int from = 0;
  int to = 0;
  Limits limits;
};

std::vector<LimitRun> limit_runs(const ErrorPlot& p) {
  std::vector<LimitRun> runs;
  for (int d = -179; d <= 180;) {
    const Limits l = limits_at(p, degree_index(d));
    int end = d;
    while (end < 180) {
      const Limits n = limits_at(p, degree_index(end + 1));
      if (n.lower != l.lower || n.upper != l.upper) break;
      ++end;
    }
    if (l.any()) runs.push_back({d, end, l});
    d = end + 1;
  }
  return runs;
}

// The error plot's scale and what it marks: the axis runs -scale..+scale um with a grid line
// every `step`; `worst` is the degree of the largest |judged error|, `outside` how many degrees
// of it are beyond their limits.
struct ErrorScale {
  double scale = 0.0;
  double step = 0.0;
  std::size_t worst = 0;
  int outside = 0;
};

// The scale: the largest error (with its spread, the raw error and the correction) or the
// limits, whichever is larger.
ErrorScale error_scale(const ErrorPlot& p) {
  ErrorScale s;
  double extent = 0.0;
  for (std::size_t d = 0; d < p.error_um.size(); ++d) {
    const double spread = p.spread_um ? (*p.spread_um)[d] : 0.0;
    extent = std::max(extent, std::abs(p.error_um[d]) + spread);
    if (p.raw_error_um) extent = std::max(extent, std::abs((*p.raw_error_um)[d]));
    if (p.correction_um) extent = std::max(extent, std::abs((*p.correction_um)[d]));
    const Limits l = limits_at(p, d);
    if (l.lower) extent = std::max(extent, std::abs(*l.lower) * 1.15);
    if (l.upper) extent = std::max(extent, std::abs(*l.upper) * 1.15);
    if (std::abs(p.error_um[d]) > std::abs(p.error_um[s.worst])) s.worst = d;
  }
  s.step = nice_step(2.0 * extent);
  s.scale = std::max(s.step, std::ceil(extent / s.step) * s.step);
  for (std::size_t d = 0; d < p.error_um.size(); ++d) s.outside += out_of_tolerance(p, d) ? 1 : 0;
  return s;
}

// The verdict of the judged error: the largest and where, and the limits kept or not; under it,
// which error that is. Wide: at the top right, one line each; narrow: under the title, each
// part on a line of its own.
void draw_error_verdict(std::string& svg, const ErrorPlot& p, const ErrorScale& s, const Layout& L) {
  const std::string worst = "max |error| " + num(std::abs(p.error_um[s.worst]), 2) + " \u00b5m at " + p.angle_word +
                            " " + std::to_string(signed_degree(s.worst)) + "\u00b0";
  std::string limits_kept;
  if (has_limits(p)) {
    const std::string band = uniform_limits_text(p);
    const std::string limits = band.empty() ? std::string("their limits") : band;
    limits_kept = s.outside == 0 ? "within " + limits : std::to_string(s.outside) + " degrees outside " + limits;
  }
  const char* colour = s.outside > 0 ? kOutColour : kTextColour;
  const std::string judged = "judged: " + p.error_name;
  if (!L.stacked) {
    add_text(svg, {L.width - L.margin, L.verdict_y, worst + (limits_kept.empty() ? "" : " \u00b7 " + limits_kept), 16,
                   "end", colour, "bold"});
    add_text(svg, {L.width - L.margin, L.verdict_y + 26, judged + ", " + p.frame_note, 13, "end", kMutedColour});
    return;
  }
  const double room = L.width - 2 * L.margin;
  double y = L.verdict_y;
  add_fitted_text(svg, {L.margin, y, worst, 14, "start", colour, "bold"}, room);
  if (!limits_kept.empty()) add_fitted_text(svg, {L.margin, y += 18, limits_kept, 14, "start", colour, "bold"}, room);
  add_fitted_text(svg, {L.margin, y += 18, judged, 12, "start", kMutedColour}, room);
  add_fitted_text(svg, {L.margin, y + 16, p.frame_note, 12, "start", kMutedColour}, room);
}

// The band of limits in the polar panel: each run of degrees with the same limits an annular
// sector (a one-sided limit reaches the panel's edge); one band all round, a ring.
void draw_polar_band(std::string& svg, const ErrorPlot& p, double scale, double k, const Layout& L) {
  const std::vector<LimitRun> runs = limit_runs(p);
  const auto radius = [&](const std::optional<double>& limit, double edge_um) {
    return std::max(1.0, L.polar_r0 + limit.value_or(edge_um) * k);
  };
  if (runs.size() == 1 && runs.front().from == -179 && runs.front().to == 180) {
    const Limits& l = runs.front().limits;
    svg += "<path d=\"" + circle_path(L, radius(l.upper, scale)) + circle_path(L, radius(l.lower, -scale)) +
           "\" fill=\"" + kToleranceColour + "\" fill-rule=\"evenodd\" stroke=\"none\"/>\n";
    return;
  }
  for (const LimitRun& r : runs) {
    const double outer = radius(r.limits.upper, scale);
    const double inner = radius(r.limits.lower, -scale);
    std::string pts;
    const double from = r.from - 0.5;
    const double to = r.to + 0.5;
    for (double a = from;; a = std::min(to, a + 1.0)) {
      pts += num(polar_x(L, a, outer), 2) + "," + num(polar_y(L, a, outer), 2) + " ";
      if (a >= to) break;
    }
    for (double a = to;; a = std::max(from, a - 1.0)) {
      pts += num(polar_x(L, a, inner), 2) + "," + num(polar_y(L, a, inner), 2) + " ";
      if (a <= from) break;
    }
    svg += "<polygon points=\"" + pts + "\" fill=\"" + kToleranceColour + "\" stroke=\"none\"/>\n";
  }
}

// The polar panel: the error as a ring around the zero circle, the limits as a band.
void draw_polar_panel(std::string& svg, const ErrorPlot& p, const ErrorScale& s, const Layout& L) {
  const double scale = s.scale;
  const double step = s.step;
  const double k = L.polar_span / scale;  // px per um
  add_text(svg,
           {L.polar_cx, L.polar_title_y, "Polar: error around the zero circle", 14, "middle", kTextColour, "bold"});
  draw_polar_band(svg, p, scale, k, L);
  for (double e = -scale; e <= scale + 1e-9; e += step) {
    const bool zero = std::abs(e) < 1e-9;
    svg += "<path d=\"" + circle_path(L, L.polar_r0 + e * k) + "\" fill=\"none\" stroke=\"" +
           (zero ? std::string("#8a949e") : std::string(kGridColour)) + "\" stroke-width=\"" + (zero ? "1.2" : "0.8") +
           "\"/>\n";
  }
  for (int deg = -150; deg <= 180; deg += 30) {
    const double r_in = L.polar_r0 - scale * k;
    const double r_out = L.polar_r0 + scale * k;
    add_line(svg, polar_x(L, deg, r_in), polar_y(L, deg, r_in), polar_x(L, deg, r_out), polar_y(L, deg, r_out),
             kGridColour, 0.8);
    const double r_label = r_out + 16;
    add_text(svg, {polar_x(L, deg, r_label), polar_y(L, deg, r_label) + 4, std::to_string(deg) + "\u00b0", 11, "middle",
                   kMutedColour});
  }
  // Radial scale labels along the 0 deg spoke, to its right.
  for (double e = -scale; e <= scale + 1e-9; e += step) {
    add_text(svg, {L.polar_cx + 4, L.polar_cy - (L.polar_r0 + e * k) + 4, (e > 0 ? "+" : "") + num(e, step < 1 ? 1 : 0),
                   10, "start", kMutedColour, "normal", true});
  }
  if (p.raw_error_um) {
    const DegreeTable& raw = *p.raw_error_um;
    svg += "<path d=\"" + polar_ring(L, [&](int d) { return L.polar_r0 + raw[static_cast<std::size_t>(d)] * k; }) +
           "\" fill=\"none\" stroke=\"" + kRawColour + "\" stroke-width=\"1\" stroke-linejoin=\"round\"/>\n";
  }
  svg += "<path d=\"" + polar_ring(L, [&](int d) { return L.polar_r0 + p.error_um[static_cast<std::size_t>(d)] * k; }) +
         "\" fill=\"none\" stroke=\"" + kErrorColour + "\" stroke-width=\"1.8\" stroke-linejoin=\"round\"/>\n";
  if (p.correction_um) {
    const DegreeTable& c = *p.correction_um;
    svg += "<path d=\"" + polar_ring(L, [&](int d) { return L.polar_r0 + c[static_cast<std::size_t>(d)] * k; }) +
           "\" fill=\"none\" stroke=\"" + kCorrectionColour + "\" stroke-width=\"1.2\" stroke-dasharray=\"5,3\"/>\n";
  }
  for (std::size_t d = 0; d < p.error_um.size(); ++d) {
    if (!out_of_tolerance(p, d)) continue;
    const double r = L.polar_r0 + p.error_um[d] * k;
    svg += "<circle cx=\"" + num(polar_x(L, static_cast<double>(d), r), 2) + "\" cy=\"" +
           num(polar_y(L, static_cast<double>(d), r), 2) + "\" r=\"2\" fill=\"" + kOutColour + "\"/>\n";
  }
  add_text(svg, {L.polar_cx, L.polar_cy + 4, "0\u00b0 at the top", 11, "middle", kMutedColour});
  add_text(svg, {L.polar_cx, L.polar_cy + 20, "angles clockwise", 11, "middle", kMutedColour});
  add_fitted_text(svg,
                  {L.polar_cx, L.polar_scale_y,
                   "radial scale " + num(step, step < 1 ? 1 : 0) + " \u00b5m per ring, outward = more material",
                   L.stacked ? 10 : 12, "middle", kMutedColour},
                  L.width - 2 * L.margin);
}

// The spread as a band around the error, in the linear panel.
std::string spread_band_points(const ErrorPlot& p, const DegreePanel& panel) {
  std::string band;
  for (int deg = -180; deg <= 180; ++deg) {
    const std::size_t d = degree_index(deg);
    band += num(panel.x_of(deg), 2) + "," + num(panel.y_of(p.error_um[d] + (*p.spread_um)[d]), 2) + " ";
  }
  for (int deg = 180; deg >= -180; --deg) {
    const std::size_t d = degree_index(deg);
    band += num(panel.x_of(deg), 2) + "," + num(panel.y_of(p.error_um[d] - (*p.spread_um)[d]), 2) + " ";
  }
  return band;
}

// The band of limits in the linear panel: a strip per run of degrees with the same limits, each
// degree from half a degree before it to half after (degree 180 at both ends of the axis); a
// one-sided limit reaches the panel's edge.
void draw_linear_band(std::string& svg, const ErrorPlot& p, const DegreePanel& panel) {
  const auto strip = [&](double from_deg, double to_deg, const Limits& l) {
    const double top = panel.y_of(l.upper.value_or(panel.scale));
    const double bottom = panel.y_of(l.lower.value_or(-panel.scale));
    svg += "<rect x=\"" + num(panel.x_of(from_deg), 2) + "\" y=\"" + num(top, 2) + "\" width=\"" +
           num(panel.x_of(to_deg) - panel.x_of(from_deg), 2) + "\" height=\"" + num(std::max(0.0, bottom - top), 2) +
           "\" fill=\"" + kToleranceColour + "\"/>\n";
  };
  for (const LimitRun& r : limit_runs(p)) {
    if (r.from == -179 && r.to == 180) {
      strip(-180.0, 180.0, r.limits);
      continue;
    }
    strip(r.from - 0.5, std::min(180.0, r.to + 0.5), r.limits);
    if (r.to == 180) strip(-180.0, -179.5, r.limits);
  }
}

// The linear panel: the judged error (the raw error beside it), spread and correction per
// degree, the limits as a band, the degrees outside it marked, and the worst degree ringed and
// labelled.
void draw_linear_panel(std::string& svg, const ErrorPlot& p, const ErrorScale& s, const Layout& L) {
  const DegreePanel panel{L.plot_left, L.plot_right, L.plot_top,    L.plot_bottom,      s.scale,
                          s.step,      p.axis_label, p.angle_title, L.angle_label_step, L.axis_title_size};
  const auto x_of = [&](double deg) { return panel.x_of(deg); };
  const auto y_of = [&](double um) { return panel.y_of(um); };
  add_text(svg, {(L.plot_left + L.plot_right) / 2, L.plot_title_y, "Linear: error per degree", 14, "middle",
                 kTextColour, "bold"});
  draw_linear_band(svg, p, panel);
  panel.draw_axes(svg);
  if (p.spread_um) {
    svg += "<polygon points=\"" + spread_band_points(p, panel) + "\" fill=\"" + kSpreadColour +
           "\" fill-opacity=\"0.6\" stroke=\"none\"/>\n";
  }
  if (p.raw_error_um) {
    svg += "<polyline points=\"" + panel.points(*p.raw_error_um) + "\" fill=\"none\" stroke=\"" + kRawColour +
           "\" stroke-width=\"1\" stroke-linejoin=\"round\"/>\n";
  }
  svg += "<polyline points=\"" + panel.points(p.error_um) + "\" fill=\"none\" stroke=\"" + kErrorColour +
         "\" stroke-width=\"1.8\" stroke-linejoin=\"round\"/>\n";
  if (p.correction_um) {
    svg += "<polyline points=\"" + panel.points(*p.correction_um) + "\" fill=\"none\" stroke=\"" + kCorrectionColour +
           "\" stroke-width=\"1.2\" stroke-dasharray=\"5,3\"/>\n";
  }
  for (std::size_t d = 0; d < p.error_um.size(); ++d) {
    if (!out_of_tolerance(p, d)) continue;
    svg += "<circle cx=\"" + num(x_of(signed_degree(d)), 2) + "\" cy=\"" + num(y_of(p.error_um[d]), 2) +
           "\" r=\"2\" fill=\"" + kOutColour + "\"/>\n";
  }
  // The worst degree, marked and labelled on the side with room.
  const std::size_t worst = s.worst;
  const int worst_deg = signed_degree(worst);
  const double wx = x_of(worst_deg);
  const double wy = y_of(p.error_um[worst]);
  svg += "<circle cx=\"" + num(wx, 2) + "\" cy=\"" + num(wy, 2) + "\" r=\"4.5\" fill=\"none\" stroke=\"" + kTextColour +
         "\" stroke-width=\"1.4\"/>\n";
  const bool label_left = worst_deg > 70;
  const double ly = p.error_um[worst] >= 0 ? wy - 10 : wy + 20;
  add_text(svg, {wx + (label_left ? -8 : 8), ly,
                 num(p.error_um[worst], 2) + " \u00b5m at " + std::to_string(worst_deg) + "\u00b0", 12,
                 label_left ? "end" : "start", kTextColour, "bold"});
}

// The legend under the linear panel: a swatch and a label for each thing drawn, the judged
// error first; an entry that does not fit on its row starts the next.
void draw_error_legend(std::string& svg, const ErrorPlot& p, const Layout& L) {
  const double left = L.legend_left;
  double lx = left;
  double ly = L.legend_y;
  const auto legend = [&](const auto& swatch, const std::string& label) {
    const double width = 30 + 6.5 * static_cast<double>(code_points(label));
    if (lx > left && lx + width > L.width - L.margin) {
      lx = left;
      ly += 16;
    }
    svg += swatch();
    add_text(svg, {lx + 30, ly + 4, label, 12, "start", kTextColour});
    lx += width + 18;
  };
  const auto line = [&](const char* colour, const char* width, const char* dash) {
    return [&lx, &ly, colour, width, dash] {
      return "<line x1=\"" + num(lx) + "\" y1=\"" + num(ly) + "\" x2=\"" + num(lx + 24) + "\" y2=\"" + num(ly) +
             "\" stroke=\"" + colour + "\" stroke-width=\"" + width + "\"" +
             (dash != nullptr ? std::string(" stroke-dasharray=\"") + dash + "\"" : std::string()) + "/>\n";
    };
  };
  const auto box = [&](const char* colour, const char* stroke) {
    return [&lx, &ly, colour, stroke] {
      return "<rect x=\"" + num(lx) + "\" y=\"" + num(ly - 6) + "\" width=\"24\" height=\"12\" fill=\"" + colour +
             "\"" + (stroke != nullptr ? std::string(" stroke=\"") + stroke + "\"" : std::string()) + "/>\n";
    };
  };
  legend(line(kErrorColour, "2", nullptr), p.raw_error_um ? std::string("judged error") : std::string("error"));
  if (p.raw_error_um) legend(line(kRawColour, "1", nullptr), "raw error, not judged");
  if (p.spread_um) legend(box(kSpreadColour, nullptr), "\u00b1 spread (1 s.d.)");
  if (p.correction_um) legend(line(kCorrectionColour, "1.5", "5,3"), "correction");
  if (has_limits(p))
    legend(box(kToleranceColour, "#9fcfa4"),
           uniform_limits_text(p).empty() ? std::string("tolerance, per zone") : "tolerance " + uniform_limits_text(p));
}

}  // namespace

std::string render_error_plot_svg(const ErrorPlot& p, PlotShape shape) {
  const Layout& L = shape == PlotShape::kNarrow ? kNarrow : kWide;
  const ErrorScale s = error_scale(p);
  std::string svg = start_document(p.title, p.subtitle, L);
  draw_error_verdict(svg, p, s, L);
  draw_polar_panel(svg, p, s, L);
  draw_linear_panel(svg, p, s, L);
  draw_error_legend(svg, p, L);
  // The footer: one line on a wide page; on a narrow one a line per figure where they would not
  // fit, from the bottom up.
  std::vector<std::string> lines{p.footer};
  if (L.stacked) lines = wrapped_at_dots(p.footer, L.width - 2 * L.margin, 11);
  double y = L.height - 10.0 - 15.0 * static_cast<double>(lines.size() - 1);
  for (const std::string& line : lines) {
    add_text(svg, {L.margin, y, line, 11, "start", kMutedColour});
    y += 15.0;
  }
  svg += "</svg>\n";
  return svg;
}

namespace {

// From the first part (light orange) to the last (dark blue): the eye follows the loop.
std::string ramp_colour(std::size_t i, std::size_t n) {
  const double t = n > 1 ? static_cast<double>(i) / static_cast<double>(n - 1) : 1.0;
  const auto mixc = [t](int a, int b) { return static_cast<int>(std::lround(a + (b - a) * t)); };
  char buf[8];
  std::snprintf(buf, sizeof buf, "#%02x%02x%02x", mixc(0xf0, 0x1f), mixc(0xa2, 0x4e), mixc(0x4c, 0x9c));
  return buf;
}

}  // namespace

std::string render_loop_plot_svg(const LoopPlot& p) {
  constexpr double kLeft = 80.0;
  constexpr double kRight = 760.0;
  constexpr double kTop = 120.0;
  constexpr double kBottom = 540.0;
  constexpr double kConvLeft = 860.0;
  constexpr double kConvRight = 1160.0;
  const std::size_t n = p.parts.size();

  double extent = 0.0;
  double largest_max = 0.0;
  for (const LoopPlotPart& part : p.parts) {
    for (double v : part.error_um) extent = std::max(extent, std::abs(v));
    largest_max = std::max({largest_max, part.measured_max_um, part.true_max_um, part.floor_max_um});
  }
  const double step = nice_step(2.0 * extent);
  const double scale = std::max(step, std::ceil(extent / step) * step);

  std::string svg = start_document(p.title, p.subtitle, kWide);

  // ---- Error profiles ----
  const DegreePanel panel{kLeft, kRight, kTop, kBottom, scale, step};
  add_text(svg, {(kLeft + kRight) / 2, 104, "Measured lift error of every part, per cam degree", 14, "middle",
                 kTextColour, "bold"});
  panel.draw_axes(svg);
  for (std::size_t i = 0; i < n; ++i) {
    svg += "<polyline points=\"" + panel.points(p.parts[i].error_um) + "\" fill=\"none\" stroke=\"" +
           ramp_colour(i, n) + "\" stroke-width=\"" + (i + 1 == n ? "2.2" : "1.4") + "\" stroke-linejoin=\"round\"/>\n";
  }

  // ---- Convergence ----
  const double top = nice_step(largest_max) * std::ceil(largest_max / nice_step(largest_max));
  const double cy = (kBottom - kTop) / std::max(top, 1e-9);
  const auto cx_of = [&](std::size_t i) {
    return n > 1 ? kConvLeft + (kConvRight - kConvLeft) * static_cast<double>(i) / static_cast<double>(n - 1)
                 : (kConvLeft + kConvRight) / 2;
  };
  const auto cy_of = [&](double um) { return kBottom - um * cy; };
  add_text(svg,
           {(kConvLeft + kConvRight) / 2, 104, "Largest lift error per part (um)", 14, "middle", kTextColour, "bold"});
  const double cstep = nice_step(top);
  for (double e = 0.0; e <= top + 1e-9; e += cstep) {
    add_line(svg, kConvLeft, cy_of(e), kConvRight, cy_of(e), kGridColour, 0.8);
    add_text(svg, {kConvLeft - 8, cy_of(e) + 4, num(e, cstep < 1 ? 1 : 0), 11, "end", kMutedColour});
  }
  svg += "<rect x=\"" + num(kConvLeft) + "\" y=\"" + num(kTop) + "\" width=\"" + num(kConvRight - kConvLeft) +
         "\" height=\"" + num(kBottom - kTop) + "\" fill=\"none\" stroke=\"#8a949e\" stroke-width=\"1\"/>\n";
  const auto series = [&](double LoopPlotPart::*field, const char* colour, const char* dash, bool dots) {
    std::string pts;
    for (std::size_t i = 0; i < n; ++i) pts += num(cx_of(i), 2) + "," + num(cy_of(p.parts[i].*field), 2) + " ";
    svg += "<polyline points=\"" + pts + "\" fill=\"none\" stroke=\"" + colour + "\" stroke-width=\"1.6\"" +
           (dash != nullptr ? std::string(" stroke-dasharray=\"") + dash + "\"" : std::string()) + "/>\n";
    if (!dots) return;
    for (std::size_t i = 0; i < n; ++i) {
      svg += "<circle cx=\"" + num(cx_of(i), 2) + "\" cy=\"" + num(cy_of(p.parts[i].*field), 2) +
             "\" r=\"3.5\" fill=\"" + ramp_colour(i, n) + "\" stroke=\"" + colour + "\"/>\n";
    }
  };
  series(&LoopPlotPart::floor_max_um, kMutedColour, "5,3", false);
  series(&LoopPlotPart::true_max_um, kCorrectionColour, "2,2", false);
  series(&LoopPlotPart::measured_max_um, kErrorColour, nullptr, true);
  for (std::size_t i = 0; i < n; ++i) {
    add_text(svg, {cx_of(i), kBottom + 18, std::to_string(i), 11, "middle", kMutedColour});
  }
  add_text(svg, {(kConvLeft + kConvRight) / 2, kBottom + 40, "part (0: ground before compensation)", 12, "middle",
                 kMutedColour});
  const double last_measured = p.parts.back().measured_max_um;
  add_text(svg, {kWidth - 40.0, 46,
                 "max |error| " + num(p.parts.front().measured_max_um, 2) + " \u2192 " + num(last_measured, 2) +
                     " \u00b5m \u00b7 floor " + num(p.parts.back().floor_max_um, 2) + " \u00b5m",
                 16, "end", kTextColour, "bold"});
  add_text(svg, {kWidth - 40.0, 72, "lift error = measured \u2212 design, cam frame, 0\u00b0 at the nose", 13, "end",
                 kMutedColour});

  // ---- Legend and footer ----
  double lx = kConvLeft - 40;
  const double ly = 606;
  const auto legend = [&](const char* colour, const char* dash, const std::string& label) {
    svg += "<line x1=\"" + num(lx) + "\" y1=\"" + num(ly) + "\" x2=\"" + num(lx + 24) + "\" y2=\"" + num(ly) +
           "\" stroke=\"" + colour + "\" stroke-width=\"2\"" +
           (dash != nullptr ? std::string(" stroke-dasharray=\"") + dash + "\"" : std::string()) + "/>\n";
    add_text(svg, {lx + 30, ly + 4, label, 12, "start", kTextColour});
    lx += 30 + 6.5 * static_cast<double>(label.size()) + 14;
  };
  legend(kErrorColour, nullptr, "measured");
  legend(kCorrectionColour, "2,2", "true");
  legend(kMutedColour, "5,3", "floor");
  double px = kLeft;
  for (std::size_t i = 0; i < n; ++i) {
    if (px > kRight - 60) break;  // more parts than room: the ramp tells the order
    svg += "<line x1=\"" + num(px) + "\" y1=\"" + num(ly) + "\" x2=\"" + num(px + 18) + "\" y2=\"" + num(ly) +
           "\" stroke=\"" + ramp_colour(i, n) + "\" stroke-width=\"3\"/>\n";
    add_text(svg, {px + 22, ly + 4, p.parts[i].label, 11, "start", kTextColour});
    px += 22 + 6.0 * static_cast<double>(p.parts[i].label.size()) + 14;
  }
  add_text(svg, {40, kHeight - 10.0, p.footer, 11, "start", kMutedColour});
  svg += "</svg>\n";
  return svg;
}

ErrorPlot run_error_plot(const StoredRun& run) {
  const RunSummary& s = run.summary;
  ErrorPlot p;
  p.title =
      "Run " + std::to_string(s.id) + " \u00b7 " + s.part + " lobe " + std::to_string(s.lobe) + " \u00b7 " + s.machine;
  // "2026-11-22T02:34:44Z" -> "2026-11-22 02:34 UTC"
  const std::string& t = s.started_utc;
  p.subtitle = t.substr(0, std::min<std::size_t>(10, t.size())) + (t.size() >= 16 ? " " + t.substr(11, 5) : "") +
               " UTC \u00b7 " + s.status + (s.serial.empty() ? "" : " \u00b7 serial " + s.serial) +
               (s.note.empty() ? "" : " \u00b7 " + s.note);
  const JudgedError judged = judged_error(run);
  // The figures of the judged curve first, those of the raw error after them, named.
  p.footer = "judged: max " + num(judged.max_abs_um, 2) + " \u00b5m \u00b7 RMS " + num(judged.rms_um, 2) +
             " \u00b5m \u00b7 peak to valley " + num(judged.peak_to_valley_um, 2) + " \u00b5m";
  if (judged.raw_error_um) p.footer += " \u00b7 raw max " + num(s.max_abs_error_um, 2) + " \u00b5m";
  if (s.phase_error_deg && judged.basis != JudgedError::Basis::kLeastSquaresCircle) {
    p.footer += " \u00b7 phase " + format_signed_fixed(*s.phase_error_deg, 3) + "\u00b0";
  }
  p.footer += " \u00b7 repeatability " + num(s.repeatability_um, 2) + " \u00b5m \u00b7 " +
              std::to_string(s.revolutions) + " revolutions";
  p.error_um = judged.error_um;
  p.error_name = judged.name;
  p.raw_error_um = judged.raw_error_um;
  p.spread_um = run.analysis.spread_um;
  p.correction_um = run.correction_um;
  if (judged.basis == JudgedError::Basis::kLeastSquaresCircle) {
    p.axis_label = "radius error (\u00b5m)";
    p.angle_title = "pin angle (deg, 0 = along the crank radius outward)";
    p.angle_word = "pin";
    p.frame_note = "0\u00b0 along the crank radius outward";
    return p;
  }
  const auto limits = limits_per_cam_degree(run.characteristics, "lift_error");
  if (std::any_of(limits.begin(), limits.end(), [](const Limits& l) { return l.any(); })) p.limits_um = limits;
  return p;
}

}  // namespace gaugeloop
