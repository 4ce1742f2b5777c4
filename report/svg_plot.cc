// The lobe error of one run as an SVG picture: polar and linear, with the tolerance band.
#include "report/svg_plot.h"
#include "core/number_text.h"
#include "core/utf8.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdio>
#include <numbers>
#include <vector>

namespace gaugeloop {
namespace {

constexpr int kWidth = 1200;
constexpr int kHeight = 640;

// Polar panel: the zero-error circle and the radial room for +-scale.
constexpr double kPolarCx = 300.0;
constexpr double kPolarCy = 345.0;
constexpr double kPolarR0 = 125.0;
constexpr double kPolarSpan = 85.0;

// Linear panel.
constexpr double kPlotLeft = 640.0;
constexpr double kPlotRight = 1160.0;
constexpr double kPlotTop = 120.0;
constexpr double kPlotBottom = 540.0;

constexpr const char* kErrorColour = "#1f4e9c";
constexpr const char* kSpreadColour = "#9db8e3";
constexpr const char* kCorrectionColour = "#d9730d";
constexpr const char* kToleranceColour = "#d7efd9";
constexpr const char* kOutColour = "#c62828";
constexpr const char* kGridColour = "#d0d4da";
constexpr const char* kTextColour = "#1d2329";
constexpr const char* kMutedColour = "#5f6b76";

// Fixed notation with `decimals`, '.' as the separator whatever the C locale.
// A coordinate or a figure on the plot: one decimal unless said.
std::string num(double v, int decimals = 1) { return format_fixed(v, decimals); }

std::string escape(const std::string& text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

// A round grid step: 1, 2 or 5 times a power of ten, so that `span` takes about 4 steps.
double nice_step(double span) {
  const double raw = std::max(span, 1e-6) / 4.0;
  const double decade = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * decade >= raw) return m * decade;
  }
  return 10.0 * decade;
}

// Cam angle (degrees, counter-clockwise, 0 at the nose drawn at the top) to the page.
double polar_x(double deg, double r) { return kPolarCx - r * std::sin(deg * std::numbers::pi / 180.0); }
double polar_y(double deg, double r) { return kPolarCy - r * std::cos(deg * std::numbers::pi / 180.0); }

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
std::string polar_ring(RadiusOf radius_of) {
  std::string d;
  for (int deg = 0; deg < kDegreesPerRevolution; ++deg) {
    const double r = radius_of(deg);
    d += (deg == 0 ? "M" : "L") + num(polar_x(deg, r), 2) + "," + num(polar_y(deg, r), 2);
  }
  return d + "Z";
}

std::string circle_path(double r) {
  return "M" + num(kPolarCx - r, 2) + "," + num(kPolarCy, 2) + "a" + num(r, 2) + "," + num(r, 2) + " 0 1,0 " +
         num(2 * r, 2) + ",0a" + num(r, 2) + "," + num(r, 2) + " 0 1,0 " + num(-2 * r, 2) + ",0Z";
}

// Room for the subtitle: from the left margin to short of the right-aligned line beside it
// (the legend of the lift error, about 430 px at 13 px).
constexpr double kSubtitleWidthPx = 660.0;

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

// The document, its white page, title and subtitle. A subtitle too long for its room (a long
// note or serial) is cut with an ellipsis; the whole of it is the text's tooltip.
std::string start_document(const std::string& title, const std::string& subtitle) {
  std::string svg;
  svg.reserve(64 * 1024);
  svg += "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  svg += "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"" + std::to_string(kWidth) + "\" height=\"" +
         std::to_string(kHeight) + "\" viewBox=\"0 0 " + std::to_string(kWidth) + " " + std::to_string(kHeight) +
         "\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n";
  svg += "<rect width=\"100%\" height=\"100%\" fill=\"#ffffff\"/>\n";
  add_text(svg, {40, 46, title, 22, "start", kTextColour, "bold"});
  const std::string shown = fit_text(subtitle, kSubtitleWidthPx, 14);
  if (shown == subtitle) {
    add_text(svg, {40, 72, subtitle, 14, "start", kMutedColour});
  } else {
    svg += "<text x=\"40\" y=\"72\" font-size=\"14\" text-anchor=\"start\" fill=\"" + std::string(kMutedColour) +
           "\"><title>" + escape(subtitle) + "</title>" + escape(shown) + "</text>\n";
  }
  return svg;
}

// A panel of lift error (-scale..+scale um, grid every `step`) over cam degrees 0..360.
struct DegreePanel {
  double left, right, top, bottom;
  double scale, step;

  double x_of(double deg) const { return left + (right - left) * deg / 360.0; }
  double y_of(double um) const { return (top + bottom) / 2.0 - um * (bottom - top) / (2.0 * scale); }

  // Grid, scale labels, frame and axis titles.
  void draw_axes(std::string& svg) const {
    for (double e = -scale; e <= scale + 1e-9; e += step) {
      const bool zero = std::abs(e) < 1e-9;
      add_line(svg, left, y_of(e), right, y_of(e), zero ? "#8a949e" : kGridColour, zero ? 1.2 : 0.8);
      add_text(svg, {left - 8, y_of(e) + 4, (e > 0 ? "+" : "") + num(e, step < 1 ? 1 : 0), 11, "end", kMutedColour});
    }
    for (int deg = 0; deg <= 360; deg += 30) {
      add_line(svg, x_of(deg), top, x_of(deg), bottom, kGridColour, 0.8);
      add_text(svg, {x_of(deg), bottom + 18, std::to_string(deg), 11, "middle", kMutedColour});
    }
    svg += "<rect x=\"" + num(left) + "\" y=\"" + num(top) + "\" width=\"" + num(right - left) + "\" height=\"" +
           num(bottom - top) + "\" fill=\"none\" stroke=\"#8a949e\" stroke-width=\"1\"/>\n";
    add_text(svg, {(left + right) / 2, bottom + 40, "cam angle (deg, 0 = nose)", 12, "middle", kMutedColour});
    const double y0 = (top + bottom) / 2.0;
    svg += "<text x=\"" + num(left - 46) + "\" y=\"" + num(y0) + "\" font-size=\"12\" text-anchor=\"middle\" fill=\"" +
           kMutedColour + "\" transform=\"rotate(-90 " + num(left - 46) + " " + num(y0) +
           ")\">lift error (\u00b5m)</text>\n";
  }

  // Polyline points of a table; the last point repeats the first at 360 deg (periodic).
  std::string points(const DegreeTable& t) const {
    std::string pts;
    for (int deg = 0; deg <= kDegreesPerRevolution; ++deg) {
      const double v = t[static_cast<std::size_t>(deg % kDegreesPerRevolution)];
      pts += num(x_of(deg), 2) + "," + num(y_of(v), 2) + " ";
    }
    return pts;
  }
};

// The error plot's scale and what it marks: the axis runs -scale..+scale um with a grid line
// every `step`; `worst` is the degree of the largest |error|, `outside` how many degrees are
// beyond the tolerance.
struct ErrorScale {
  double scale = 0.0;
  double step = 0.0;
  std::size_t worst = 0;
  int outside = 0;
};

bool out_of_tolerance(const ErrorPlot& p, std::size_t d) {
  return p.tolerance_um && std::abs(p.error_um[d]) > *p.tolerance_um;
}

// The scale: the largest error (with its spread) or the tolerance, whichever is larger.
ErrorScale error_scale(const ErrorPlot& p) {
  ErrorScale s;
  double extent = 0.0;
  for (std::size_t d = 0; d < p.error_um.size(); ++d) {
    const double spread = p.spread_um ? (*p.spread_um)[d] : 0.0;
    extent = std::max(extent, std::abs(p.error_um[d]) + spread);
    if (p.correction_um) extent = std::max(extent, std::abs((*p.correction_um)[d]));
    if (std::abs(p.error_um[d]) > std::abs(p.error_um[s.worst])) s.worst = d;
  }
  if (p.tolerance_um) extent = std::max(extent, *p.tolerance_um * 1.15);
  s.step = nice_step(2.0 * extent);
  s.scale = std::max(s.step, std::ceil(extent / s.step) * s.step);
  for (std::size_t d = 0; d < p.error_um.size(); ++d) s.outside += out_of_tolerance(p, d) ? 1 : 0;
  return s;
}

// The verdict at the top right: the largest error and where, and the tolerance kept or not.
void draw_error_verdict(std::string& svg, const ErrorPlot& p, const ErrorScale& s) {
  std::string verdict =
      "max |error| " + num(std::abs(p.error_um[s.worst]), 2) + " \u00b5m at cam " + std::to_string(s.worst) + "\u00b0";
  if (p.tolerance_um) {
    verdict += s.outside == 0 ? " \u00b7 within \u00b1" + num(*p.tolerance_um, 1) + " \u00b5m"
                              : " \u00b7 " + std::to_string(s.outside) + " degrees outside \u00b1" +
                                    num(*p.tolerance_um, 1) + " \u00b5m";
  }
  add_text(svg, {kWidth - 40.0, 46, verdict, 16, "end", s.outside > 0 ? kOutColour : kTextColour, "bold"});
  add_text(svg, {kWidth - 40.0, 72, "lift error = measured \u2212 design, cam frame, 0\u00b0 at the nose", 13, "end",
                 kMutedColour});
}

// The polar panel: the error as a ring around the zero circle, the tolerance as a band.
void draw_polar_panel(std::string& svg, const ErrorPlot& p, const ErrorScale& s) {
  const double scale = s.scale;
  const double step = s.step;
  const double k = kPolarSpan / scale;  // px per um
  add_text(svg, {kPolarCx, 104, "Polar: error around the zero circle", 14, "middle", kTextColour, "bold"});
  if (p.tolerance_um) {
    const double t = *p.tolerance_um * k;
    svg += "<path d=\"" + circle_path(kPolarR0 + t) + circle_path(kPolarR0 - t) + "\" fill=\"" + kToleranceColour +
           "\" fill-rule=\"evenodd\" stroke=\"none\"/>\n";
  }
  for (double e = -scale; e <= scale + 1e-9; e += step) {
    const bool zero = std::abs(e) < 1e-9;
    svg += "<path d=\"" + circle_path(kPolarR0 + e * k) + "\" fill=\"none\" stroke=\"" +
           (zero ? std::string("#8a949e") : std::string(kGridColour)) + "\" stroke-width=\"" + (zero ? "1.2" : "0.8") +
           "\"/>\n";
  }
  for (int deg = 0; deg < 360; deg += 30) {
    const double r_in = kPolarR0 - scale * k;
    const double r_out = kPolarR0 + scale * k;
    add_line(svg, polar_x(deg, r_in), polar_y(deg, r_in), polar_x(deg, r_out), polar_y(deg, r_out), kGridColour, 0.8);
    const double r_label = r_out + 16;
    add_text(svg, {polar_x(deg, r_label), polar_y(deg, r_label) + 4, std::to_string(deg) + "\u00b0", 11, "middle",
                   kMutedColour});
  }
  // Radial scale labels along the 0 deg spoke, to its right.
  for (double e = -scale; e <= scale + 1e-9; e += step) {
    add_text(svg, {kPolarCx + 4, kPolarCy - (kPolarR0 + e * k) + 4, (e > 0 ? "+" : "") + num(e, step < 1 ? 1 : 0), 10,
                   "start", kMutedColour, "normal", true});
  }
  svg += "<path d=\"" + polar_ring([&](int d) { return kPolarR0 + p.error_um[static_cast<std::size_t>(d)] * k; }) +
         "\" fill=\"none\" stroke=\"" + kErrorColour + "\" stroke-width=\"1.8\" stroke-linejoin=\"round\"/>\n";
  if (p.correction_um) {
    const DegreeTable& c = *p.correction_um;
    svg += "<path d=\"" + polar_ring([&](int d) { return kPolarR0 + c[static_cast<std::size_t>(d)] * k; }) +
           "\" fill=\"none\" stroke=\"" + kCorrectionColour + "\" stroke-width=\"1.2\" stroke-dasharray=\"5,3\"/>\n";
  }
  for (std::size_t d = 0; d < p.error_um.size(); ++d) {
    if (!out_of_tolerance(p, d)) continue;
    const double r = kPolarR0 + p.error_um[d] * k;
    svg += "<circle cx=\"" + num(polar_x(static_cast<double>(d), r), 2) + "\" cy=\"" +
           num(polar_y(static_cast<double>(d), r), 2) + "\" r=\"2\" fill=\"" + kOutColour + "\"/>\n";
  }
  add_text(svg, {kPolarCx, kPolarCy + 4, "nose at 0\u00b0, top", 11, "middle", kMutedColour});
  add_text(svg, {kPolarCx, kPolarCy + 20, "angles counter-clockwise", 11, "middle", kMutedColour});
  add_text(svg,
           {kPolarCx, 604, "radial scale " + num(step, step < 1 ? 1 : 0) + " \u00b5m per ring, outward = more material",
            12, "middle", kMutedColour});
}

// The spread as a band around the error, in the linear panel.
std::string spread_band_points(const ErrorPlot& p, const DegreePanel& panel) {
  std::string band;
  for (int deg = 0; deg <= kDegreesPerRevolution; ++deg) {
    const auto d = static_cast<std::size_t>(deg % kDegreesPerRevolution);
    band += num(panel.x_of(deg), 2) + "," + num(panel.y_of(p.error_um[d] + (*p.spread_um)[d]), 2) + " ";
  }
  for (int deg = kDegreesPerRevolution; deg >= 0; --deg) {
    const auto d = static_cast<std::size_t>(deg % kDegreesPerRevolution);
    band += num(panel.x_of(deg), 2) + "," + num(panel.y_of(p.error_um[d] - (*p.spread_um)[d]), 2) + " ";
  }
  return band;
}

// The linear panel: error, spread and correction per cam degree, the tolerance as a strip,
// the degrees outside it marked, and the worst degree ringed and labelled.
void draw_linear_panel(std::string& svg, const ErrorPlot& p, const ErrorScale& s) {
  const DegreePanel panel{kPlotLeft, kPlotRight, kPlotTop, kPlotBottom, s.scale, s.step};
  const auto x_of = [&](double deg) { return panel.x_of(deg); };
  const auto y_of = [&](double um) { return panel.y_of(um); };
  add_text(svg, {(kPlotLeft + kPlotRight) / 2, 104, "Linear: error per cam degree", 14, "middle", kTextColour, "bold"});
  if (p.tolerance_um) {
    svg += "<rect x=\"" + num(kPlotLeft) + "\" y=\"" + num(y_of(*p.tolerance_um)) + "\" width=\"" +
           num(kPlotRight - kPlotLeft) + "\" height=\"" + num(y_of(-*p.tolerance_um) - y_of(*p.tolerance_um)) +
           "\" fill=\"" + kToleranceColour + "\"/>\n";
  }
  panel.draw_axes(svg);
  if (p.spread_um) {
    svg += "<polygon points=\"" + spread_band_points(p, panel) + "\" fill=\"" + kSpreadColour +
           "\" fill-opacity=\"0.6\" stroke=\"none\"/>\n";
  }
  svg += "<polyline points=\"" + panel.points(p.error_um) + "\" fill=\"none\" stroke=\"" + kErrorColour +
         "\" stroke-width=\"1.8\" stroke-linejoin=\"round\"/>\n";
  if (p.correction_um) {
    svg += "<polyline points=\"" + panel.points(*p.correction_um) + "\" fill=\"none\" stroke=\"" + kCorrectionColour +
           "\" stroke-width=\"1.2\" stroke-dasharray=\"5,3\"/>\n";
  }
  for (std::size_t d = 0; d < p.error_um.size(); ++d) {
    if (!out_of_tolerance(p, d)) continue;
    svg += "<circle cx=\"" + num(x_of(static_cast<double>(d)), 2) + "\" cy=\"" + num(y_of(p.error_um[d]), 2) +
           "\" r=\"2\" fill=\"" + kOutColour + "\"/>\n";
  }
  // The worst degree, marked and labelled on the side with room.
  const std::size_t worst = s.worst;
  const double wx = x_of(static_cast<double>(worst));
  const double wy = y_of(p.error_um[worst]);
  svg += "<circle cx=\"" + num(wx, 2) + "\" cy=\"" + num(wy, 2) + "\" r=\"4.5\" fill=\"none\" stroke=\"" + kTextColour +
         "\" stroke-width=\"1.4\"/>\n";
  const bool label_left = worst > 250;
  const double ly = p.error_um[worst] >= 0 ? wy - 10 : wy + 20;
  add_text(svg, {wx + (label_left ? -8 : 8), ly,
                 num(p.error_um[worst], 2) + " \u00b5m at " + std::to_string(worst) + "\u00b0", 12,
                 label_left ? "end" : "start", kTextColour, "bold"});
}

// The legend under the linear panel: a swatch and a label for each thing drawn.
void draw_error_legend(std::string& svg, const ErrorPlot& p) {
  double lx = kPlotLeft - 40;
  const double ly = 606;
  const auto legend = [&](const std::string& swatch, const std::string& label) {
    svg += swatch;
    add_text(svg, {lx + 30, ly + 4, label, 12, "start", kTextColour});
    lx += 30 + 6.5 * static_cast<double>(label.size()) + 18;
  };
  legend("<line x1=\"" + num(lx) + "\" y1=\"" + num(ly) + "\" x2=\"" + num(lx + 24) + "\" y2=\"" + num(ly) +
             "\" stroke=\"" + kErrorColour + "\" stroke-width=\"2\"/>\n",
         "error");
  if (p.spread_um) {
    legend("<rect x=\"" + num(lx) + "\" y=\"" + num(ly - 6) + "\" width=\"24\" height=\"12\" fill=\"" + kSpreadColour +
               "\"/>\n",
           "\u00b1 spread (1 s.d.)");
  }
  if (p.correction_um) {
    legend("<line x1=\"" + num(lx) + "\" y1=\"" + num(ly) + "\" x2=\"" + num(lx + 24) + "\" y2=\"" + num(ly) +
               "\" stroke=\"" + kCorrectionColour + "\" stroke-width=\"1.5\" stroke-dasharray=\"5,3\"/>\n",
           "correction");
  }
  if (p.tolerance_um) {
    legend("<rect x=\"" + num(lx) + "\" y=\"" + num(ly - 6) + "\" width=\"24\" height=\"12\" fill=\"" +
               kToleranceColour + "\" stroke=\"#9fcfa4\"/>\n",
           "tolerance \u00b1" + num(*p.tolerance_um, 1) + " \u00b5m");
  }
}

}  // namespace

std::string render_error_plot_svg(const ErrorPlot& p) {
  const ErrorScale s = error_scale(p);
  std::string svg = start_document(p.title, p.subtitle);
  draw_error_verdict(svg, p, s);
  draw_polar_panel(svg, p, s);
  draw_linear_panel(svg, p, s);
  draw_error_legend(svg, p);
  add_text(svg, {40, kHeight - 10.0, p.footer, 11, "start", kMutedColour});
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

  std::string svg = start_document(p.title, p.subtitle);

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
  p.error_um = run.analysis.error_um;
  p.spread_um = run.analysis.spread_um;
  p.correction_um = run.correction_um;
  return p;
}

}  // namespace gaugeloop
