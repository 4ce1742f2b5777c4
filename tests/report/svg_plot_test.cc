// The SVG plots: well-formed XML, what each must show (tolerance band, worst degree, axis
// titles with units), and no number printed as "-0.0", "nan" or "inf".
#include "report/svg_plot.h"

#include <gtest/gtest.h>

#include <array>
#include <cctype>
#include <cmath>
#include <regex>
#include <string>
#include <vector>

namespace gaugeloop {
namespace {

bool name_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == ':'; }

// ` a="1" b="x y"`: each attribute after a blank, its value in double quotes without '<'.
// (By hand: std::regex recurses per character and the path data runs to kilobytes.)
bool attributes_well_formed(const std::string& s) {
  std::size_t i = 0;
  while (i < s.size()) {
    if (s[i] != ' ' && s[i] != '\n') return false;
    while (i < s.size() && (s[i] == ' ' || s[i] == '\n')) ++i;
    if (i == s.size()) return true;
    if (!std::isalpha(static_cast<unsigned char>(s[i]))) return false;
    while (i < s.size() && name_char(s[i])) ++i;
    if (i + 1 >= s.size() || s[i] != '=' || s[i + 1] != '"') return false;
    const std::size_t close = s.find('"', i + 2);
    if (close == std::string::npos || s.find('<', i + 2) < close) return false;
    i = close + 1;
  }
  return true;
}

// Checks the document is well-formed XML as far as these plots go: one XML declaration, tags
// balanced and properly nested with one root `svg`, attribute values quoted, no '<' in text and
// every '&' an entity. Returns "" or what is wrong and where.
std::string xml_problem(const std::string& doc) {
  std::size_t at = 0;
  const std::string decl = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  if (doc.rfind(decl, 0) != 0) return "no XML declaration";
  at = decl.size();
  std::vector<std::string> open;
  int roots = 0;
  const std::regex entity("^&(amp|lt|gt|quot|apos|#[0-9]+|#x[0-9a-fA-F]+);");
  while (at < doc.size()) {
    if (doc[at] == '&') {
      if (!std::regex_search(doc.substr(at, 12), entity)) return "bare & at " + std::to_string(at);
      ++at;
      continue;
    }
    if (doc[at] != '<') {
      if (open.empty() && doc[at] != '\n' && doc[at] != ' ') return "text outside the root at " + std::to_string(at);
      ++at;
      continue;
    }
    // A tag: find its end outside quoted values.
    std::size_t end = at + 1;
    bool quoted = false;
    while (end < doc.size() && (quoted || doc[end] != '>')) {
      if (doc[end] == '"') quoted = !quoted;
      if (!quoted && doc[end] == '<') return "'<' inside a tag at " + std::to_string(end);
      ++end;
    }
    if (end >= doc.size()) return "unterminated tag at " + std::to_string(at);
    const std::string tag = doc.substr(at + 1, end - at - 1);
    at = end + 1;
    if (tag.empty()) return "empty tag";
    if (tag[0] == '/') {
      const std::string name = tag.substr(1);
      if (open.empty() || open.back() != name) {
        return "</" + name + "> closes " + (open.empty() ? std::string("nothing") : "<" + open.back() + ">");
      }
      open.pop_back();
      continue;
    }
    const bool self_closing = tag.back() == '/';
    const std::string body = self_closing ? tag.substr(0, tag.size() - 1) : tag;
    const std::string name = body.substr(0, body.find_first_of(" \n"));
    if (!attributes_well_formed(body.substr(name.size()))) return "malformed tag <" + tag + ">";
    if (open.empty()) {
      ++roots;
      if (name != "svg") return "root <" + name + ">";
    }
    if (!self_closing) open.push_back(name);
  }
  if (!open.empty()) return "<" + open.back() + "> never closed";
  if (roots != 1) return std::to_string(roots) + " roots";
  return "";
}

// Text a number must never print as: a negative zero ("-0", "-0.0", "-0.00") or NaN/infinity.
std::string bad_number(const std::string& doc) {
  static const std::regex negative_zero(R"(-0(\.0+)?(?![0-9.]))");
  static const std::regex not_finite(R"(\b(nan|NaN|inf|Inf|INF)\b)");
  std::smatch m;
  if (std::regex_search(doc, m, negative_zero))
    return "negative zero `" + m.str() + "` at " + std::to_string(m.position());
  if (std::regex_search(doc, m, not_finite)) return "`" + m.str() + "` at " + std::to_string(m.position());
  return "";
}

int count(const std::string& doc, const std::string& what) {
  int n = 0;
  for (std::size_t at = doc.find(what); at != std::string::npos; at = doc.find(what, at + 1)) ++n;
  return n;
}

// An error of `amplitude_um` sin(deg) with a sharper dip of `dip_um` at cam degree 200.
ErrorPlot sample_plot(double amplitude_um, double dip_um) {
  ErrorPlot p;
  p.title = "Run 12 \u00b7 intake_flat lobe 1 \u00b7 <grinder-1> & co";
  p.subtitle = "2026-11-22 02:34 UTC \u00b7 pushed";
  DegreeTable spread{};
  DegreeTable correction{};
  for (std::size_t d = 0; d < 360; ++d) {
    p.error_um[d] = amplitude_um * std::sin(static_cast<double>(d) * 3.14159265358979 / 180.0);
    spread[d] = 0.2;
    correction[d] = 0.9 * p.error_um[d];
  }
  p.error_um[200] = -dip_um;
  p.spread_um = spread;
  p.correction_um = correction;
  p.footer = "db runs.sqlite \u00b7 settings 0123456789abcdef";
  return p;
}

TEST(ErrorPlotSvg, IsWellFormedAndEscapesText) {
  const std::string svg = render_error_plot_svg(sample_plot(3.0, 7.0));
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_NE(svg.find("&lt;grinder-1&gt; &amp; co"), std::string::npos);
  EXPECT_EQ(bad_number(svg), "");
}

// A long note in the subtitle is cut with an ellipsis short of the legend to its right (at
// most 660 px / (0.62 x 14 px) = 76 characters), the whole note its tooltip; a short one stays whole.
TEST(ErrorPlotSvg, ALongSubtitleIsCutBeforeTheTextToItsRight) {
  ErrorPlot p = sample_plot(3.0, 7.0);
  const std::string note =
      "re-ground after the wheel was dressed \u00fcber the nose; " + std::string(200, 'x') + " <end>";
  p.subtitle = "2026-11-22 02:34 UTC \u00b7 pushed \u00b7 " + note;
  const std::string svg = render_error_plot_svg(p);
  EXPECT_EQ(xml_problem(svg), "");
  const std::string shown_start = "y=\"72.0\" font-size=\"14\" text-anchor=\"start\"";
  const std::size_t at = svg.find(shown_start);
  ASSERT_NE(at, std::string::npos);
  const std::size_t title_end = svg.find("</title>", at);
  const std::size_t text_end = svg.find("</text>", at);
  ASSERT_NE(title_end, std::string::npos);
  ASSERT_LT(title_end, text_end);
  const std::string shown = svg.substr(title_end + 8, text_end - title_end - 8);
  std::size_t code_points = 0;
  for (unsigned char c : shown) code_points += (c & 0xC0) != 0x80 ? 1 : 0;
  EXPECT_LE(code_points, 76u) << shown;
  EXPECT_GE(code_points, 60u) << shown;
  EXPECT_EQ(shown.substr(shown.size() - 3), "\u2026") << shown;
  EXPECT_NE(svg.find("x &lt;end&gt;</title>"), std::string::npos) << "the whole note is the tooltip";
  p.subtitle = "2026-11-22 02:34 UTC \u00b7 pushed \u00b7 short note";
  const std::string whole = render_error_plot_svg(p);
  EXPECT_NE(whole.find(">2026-11-22 02:34 UTC \u00b7 pushed \u00b7 short note</text>"), std::string::npos);
}

TEST(ErrorPlotSvg, ShowsTheToleranceBandAndTheWorstDegree) {
  ErrorPlot p = sample_plot(3.0, 7.0);
  p.tolerance_um = 5.0;
  const std::string svg = render_error_plot_svg(p);
  EXPECT_EQ(xml_problem(svg), "");
  // The band: a ring on the polar panel and a strip on the linear one, and its legend.
  EXPECT_EQ(count(svg, "fill=\"#d7efd9\""), 3) << "polar ring, linear strip, legend swatch";
  EXPECT_NE(svg.find("tolerance \u00b15.0 \u00b5m"), std::string::npos);
  // The worst degree: the verdict, the ring around it and its label.
  EXPECT_NE(svg.find("max |error| 7.00 \u00b5m at cam -160\u00b0"), std::string::npos) << "degree 200 is cam -160";
  EXPECT_NE(svg.find("judged: lift error = measured \u2212 design, cam frame"), std::string::npos);
  EXPECT_EQ(count(svg, "r=\"4.5\""), 1);
  EXPECT_NE(svg.find(">-7.00 \u00b5m at -160\u00b0</text>"), std::string::npos);
  // Only degree 200 is outside +-5 um: one mark on each panel, and the verdict says so.
  EXPECT_EQ(count(svg, "r=\"2\" fill=\"#c62828\""), 2);
  EXPECT_NE(svg.find("1 degrees outside \u00b15.0 \u00b5m"), std::string::npos);
  EXPECT_EQ(bad_number(svg), "");

  // Without a tolerance there is no band and nothing is marked outside.
  const std::string plain = render_error_plot_svg(sample_plot(3.0, 7.0));
  EXPECT_EQ(count(plain, "#d7efd9"), 0);
  EXPECT_EQ(count(plain, "#c62828"), 0);
  EXPECT_EQ(count(plain, "r=\"4.5\""), 1) << "the worst degree is marked all the same";

  p.tolerance_um = 10.0;
  EXPECT_NE(render_error_plot_svg(p).find("within \u00b110.0 \u00b5m"), std::string::npos);
}

// One judged quantity per picture: a raw error beyond the band beside a judged curve within it
// is drawn thin and grey and named "not judged"; the headline's maximum, its marks and its count
// are of the judged curve alone, and the headline names it.
TEST(ErrorPlotSvg, TheBandTheMarksAndTheHeadlineAreOfTheJudgedCurve) {
  ErrorPlot p = sample_plot(3.0, 7.0);  // judged: 3 sin(deg), -7 at 200 deg
  p.error_name = "lift error after the best-fit phase";
  DegreeTable raw{};
  for (std::size_t d = 0; d < 360; ++d) raw[d] = 16.0 * std::sin(static_cast<double>(d) * 3.14159265358979 / 180.0);
  p.raw_error_um = raw;
  p.tolerance_um = 10.0;
  const std::string svg = render_error_plot_svg(p);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_NE(svg.find("max |error| 7.00 \u00b5m at cam -160\u00b0 \u00b7 within \u00b110.0 \u00b5m"), std::string::npos)
      << "the raw 16 um is not what the band judges";
  EXPECT_NE(svg.find("judged: lift error after the best-fit phase"), std::string::npos);
  EXPECT_EQ(count(svg, "#c62828"), 0) << "no degree of the judged curve is outside";
  EXPECT_EQ(count(svg, "stroke=\"#9aa3ad\""), 3) << "the raw error on both panels and in the legend";
  EXPECT_NE(svg.find(">raw error, not judged</text>"), std::string::npos);
  EXPECT_NE(svg.find(">judged error</text>"), std::string::npos);
}

// Limits per degree: +-10 everywhere but +-2 over cam 30..60 (a zone's): the band is drawn in
// strips, the degrees of the judged curve beyond +-2 there are marked (3 sin(deg) > 2 from 42
// degrees on: 42..60, 19 degrees, each marked on both panels), and the headline counts them
// against "their limits".
TEST(ErrorPlotSvg, AZonesLimitsAreDrawnAndCountedOverItsArc) {
  ErrorPlot p = sample_plot(3.0, 7.0);
  std::array<Limits, 360> limits{};
  limits.fill(Limits{-10.0, 10.0});
  for (std::size_t d = 30; d <= 60; ++d) limits[d] = Limits{-2.0, 2.0};
  p.limits_um = limits;
  const std::string svg = render_error_plot_svg(p);
  EXPECT_EQ(xml_problem(svg), "");
  int expected = 0;
  for (std::size_t d = 30; d <= 60; ++d) expected += std::abs(p.error_um[d]) > 2.0 ? 1 : 0;
  EXPECT_EQ(expected, 19);
  EXPECT_EQ(count(svg, "r=\"2\" fill=\"#c62828\""), 2 * expected);
  EXPECT_NE(svg.find(std::to_string(expected) + " degrees outside their limits"), std::string::npos);
  // Three runs of equal limits (-179..29, 30..60, 61..180): three strips (degree 180's half
  // degree beyond it drawn at the axis' start, a fourth), three polar sectors and the swatch.
  EXPECT_EQ(count(svg, "fill=\"#d7efd9\""), 8);
  EXPECT_NE(svg.find("tolerance, per zone"), std::string::npos);
  EXPECT_EQ(bad_number(svg), "");
}

// One angle convention on both panels, as the printed report draws it: cam -60 (table index 300)
// is left of the nose on the linear panel's -180..180 axis and, on the polar panel with the nose
// at the top and the angle growing clockwise, up and to the left of the centre.
TEST(ErrorPlotSvg, BothPanelsDrawTheSignedCamAngleTheReportDraws) {
  ErrorPlot p;
  p.title = "spike";
  p.error_um[300] = 9.0;
  p.tolerance_um = 5.0;
  const std::string svg = render_error_plot_svg(p);
  const std::regex mark("<circle cx=\"([0-9.]+)\" cy=\"([0-9.]+)\" r=\"2\" fill=\"#c62828\"/>");
  std::vector<std::pair<double, double>> marks;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), mark); it != std::sregex_iterator(); ++it) {
    marks.emplace_back(std::stod((*it)[1]), std::stod((*it)[2]));
  }
  ASSERT_EQ(marks.size(), 2u) << "one mark on each panel";
  // Polar first (centre 300, 345; zero circle 125 px, +9 um of a 10 um scale outward).
  const double r = std::hypot(marks[0].first - 300.0, marks[0].second - 345.0);
  EXPECT_NEAR(std::atan2(marks[0].first - 300.0, 345.0 - marks[0].second) * 180.0 / 3.14159265358979, -60.0, 0.1)
      << "clockwise from the top: -60 is up and to the left";
  EXPECT_GT(r, 125.0);
  // Linear: the axis 640..1160 px spans -180..180.
  EXPECT_NEAR(marks[1].first, 640.0 + 520.0 * 120.0 / 360.0, 0.05);
  EXPECT_NE(svg.find("at cam -60\u00b0"), std::string::npos);
  for (const char* tick : {">-180</text>", ">-90</text>", ">0</text>", ">180</text>", ">-60\u00b0</text>"}) {
    EXPECT_NE(svg.find(tick), std::string::npos) << tick;
  }
  EXPECT_EQ(svg.find(">270</text>"), std::string::npos) << "no 0..360 axis";
}

// The narrow layout for a phone: 380 px wide, every text inside it at 0.62 em a character
// (wider than DejaVu Sans's average) whichever way it is anchored; the
// headline's parts each on a line, the footer's figures all there, broken at their dots.
TEST(ErrorPlotSvg, TheNarrowLayoutKeepsEveryTextInsideAPhonesWidth) {
  ErrorPlot p = sample_plot(3.0, 7.0);
  p.tolerance_um = 5.0;
  p.title = "Run 1234 \u00b7 intake_flat lobe 1 \u00b7 grinder-with-a-long-name-7";
  p.error_name = "lift error after the best-fit phase";
  p.footer =
      "judged: max 7.00 \u00b5m \u00b7 RMS 2.21 \u00b5m \u00b7 peak to valley 10.00 \u00b5m \u00b7 raw max 16.73 "
      "\u00b5m "
      "\u00b7 phase +0.125\u00b0 \u00b7 repeatability 0.31 \u00b5m \u00b7 3 revolutions";
  const std::string svg = render_error_plot_svg(p, PlotShape::kNarrow);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(bad_number(svg), "");
  EXPECT_NE(svg.find("width=\"380\" height=\"1060\""), std::string::npos);
  const std::regex text(
      "<text x=\"([-0-9.]+)\" y=\"[-0-9.]+\" font-size=\"([0-9]+)\" "
      "text-anchor=\"([a-z]+)\"[^>]*>(?:<title>[^<]*</title>)?([^<]*)</text>");
  int texts = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), text); it != std::sregex_iterator(); ++it, ++texts) {
    const double x = std::stod((*it)[1]);
    const int size = std::stoi((*it)[2]);
    EXPECT_GE(size, 10) << (*it)[4];
    EXPECT_GE(x, 0.0) << (*it)[4];
    EXPECT_LE(x, 380.0) << (*it)[4];
    if (it->str().find("transform=") != std::string::npos) {  // the turned axis title: a glyph's em to its left
      EXPECT_GE(x - size, 0.0) << (*it)[4];
      continue;
    }
    std::size_t chars = 0;
    for (unsigned char c : std::string((*it)[4])) chars += (c & 0xC0) != 0x80 ? 1 : 0;
    const double w = 0.62 * size * static_cast<double>(chars);
    const double left = (*it)[3] == "start" ? x : (*it)[3] == "middle" ? x - w / 2 : x - w;
    EXPECT_GE(left, -1e-9) << (*it)[4];
    EXPECT_LE(left + w, 380.0 + 1e-9) << (*it)[4];
  }
  EXPECT_GT(texts, 40);
  EXPECT_NE(svg.find(">max |error| 7.00 \u00b5m at cam -160\u00b0</text>"), std::string::npos);
  EXPECT_NE(svg.find(">1 degrees outside \u00b15.0 \u00b5m</text>"), std::string::npos);
  EXPECT_NE(svg.find(">judged: lift error after the best-fit phase</text>"), std::string::npos);
  for (const char* figure : {"judged: max 7.00 \u00b5m", "raw max 16.73 \u00b5m", "3 revolutions"}) {
    EXPECT_NE(svg.find(figure), std::string::npos) << figure;
  }
  EXPECT_EQ(svg.find(">-150</text>"), std::string::npos) << "the narrow axis is labelled every 60 degrees";
  EXPECT_NE(svg.find(">-120</text>"), std::string::npos);
}

TEST(ErrorPlotSvg, LabelsTheAxesWithUnits) {
  const std::string svg = render_error_plot_svg(sample_plot(3.0, 7.0));
  EXPECT_NE(svg.find(">lift error (\u00b5m)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">cam angle (deg, 0 = nose, opening side negative)</text>"), std::string::npos);
  EXPECT_NE(svg.find("\u00b5m per ring"), std::string::npos) << "the polar panel's radial scale";
}

// A perfect lobe (all zero) and errors that round to zero on the page: no "-0.0" anywhere, no
// NaN from a zero scale.
TEST(ErrorPlotSvg, AZeroOrTinyErrorPrintsNoNegativeZeroOrNan) {
  ErrorPlot zero;
  zero.title = "zero";
  zero.tolerance_um = 1.0;
  std::string svg = render_error_plot_svg(zero);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(bad_number(svg), "");

  ErrorPlot tiny = sample_plot(-0.0004, 0.0001);
  svg = render_error_plot_svg(tiny);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(bad_number(svg), "");

  ErrorPlot nothing;
  nothing.title = "no tolerance, no spread";
  svg = render_error_plot_svg(nothing);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(bad_number(svg), "");
}

LoopPlot sample_loop(int parts, double first_max_um) {
  LoopPlot p;
  p.title = "Grinding loop \u00b7 intake_flat lobe 1";
  p.subtitle = "simulated";
  for (int i = 0; i < parts; ++i) {
    LoopPlotPart part;
    part.label = "part " + std::to_string(i) + " \u00b7 v" + std::to_string(i);
    const double max_um = first_max_um / std::pow(3.0, i);
    for (std::size_t d = 0; d < 360; ++d) {
      part.error_um[d] = max_um * std::cos(static_cast<double>(d) * 3.14159265358979 / 90.0);
    }
    part.measured_max_um = max_um;
    part.true_max_um = 0.9 * max_um;
    part.floor_max_um = 0.4;
    p.parts.push_back(part);
  }
  p.footer = "footer";
  return p;
}

TEST(LoopPlotSvg, IsWellFormedWithAProfilePerPartAndTheConvergence) {
  const std::string svg = render_loop_plot_svg(sample_loop(4, 27.0));
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(bad_number(svg), "");
  EXPECT_NE(svg.find("max |error| 27.00 \u2192 1.00 \u00b5m \u00b7 floor 0.40 \u00b5m"), std::string::npos);
  EXPECT_NE(svg.find(">lift error (\u00b5m)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">cam angle (deg, 0 = nose, opening side negative)</text>"), std::string::npos);
  EXPECT_EQ(count(svg, "r=\"3.5\""), 4) << "one measured point per part";
  for (int i = 0; i < 4; ++i) {
    EXPECT_NE(svg.find(">part " + std::to_string(i) + " \u00b7 v" + std::to_string(i) + "</text>"), std::string::npos);
  }
}

TEST(LoopPlotSvg, OnePartOrAllZeroPrintsNoNegativeZeroOrNan) {
  std::string svg = render_loop_plot_svg(sample_loop(1, 5.0));
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(bad_number(svg), "");
  LoopPlot zero = sample_loop(2, 0.0);
  for (LoopPlotPart& part : zero.parts) part.floor_max_um = 0.0;
  svg = render_loop_plot_svg(zero);
  EXPECT_EQ(xml_problem(svg), "");
  EXPECT_EQ(bad_number(svg), "");
}

// The checkers themselves catch what they are for.
TEST(SvgCheckers, CatchBrokenXmlAndBadNumbers) {
  const std::string head = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  EXPECT_EQ(xml_problem(head + "<svg><g></g></svg>\n"), "");
  EXPECT_NE(xml_problem(head + "<svg><g></svg>\n"), "");
  EXPECT_NE(xml_problem(head + "<svg><text>a & b</text></svg>\n"), "");
  EXPECT_NE(xml_problem(head + "<svg><line x1=1/></svg>\n"), "");
  EXPECT_NE(xml_problem(head + "<svg/><svg/>\n"), "");
  EXPECT_EQ(bad_number("x=\"-0.05\" y=\"10.0\" z=\"-0.1\""), "");
  EXPECT_NE(bad_number("y=\"-0.0\""), "");
  EXPECT_NE(bad_number(">-0 \u00b5m<"), "");
  EXPECT_NE(bad_number("x=\"nan\""), "");
  EXPECT_NE(bad_number(">-inf<"), "");
}

}  // namespace
}  // namespace gaugeloop
