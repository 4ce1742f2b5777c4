// The cam report and the trend plot drawn with cairo: each format's file as a reader takes it,
// the tolerance band and the error curve where the lift error chart must show them (pixels of
// the PNG read back), refusals, and no file left after a failure.
#include "report/cam_report.h"
#include "report/gear_report.h"

#include <cairo.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "core/tolerance.h"
#include "tests/support/angles.h"
#include "tests/support/cli.h"
#include "tests/support/temp_dir.h"
#include "tests/support/text.h"

namespace gaugeloop {
namespace {

using testing::kPi;

namespace fs = std::filesystem;
using testing::slurp;

// A nose-centred cam angle (-180..180) as the cam frame index.
std::size_t index_of(int x_deg) { return static_cast<std::size_t>((x_deg % 360 + 360) % 360); }

// The judged (best-fit) lift error of the test lobe at nose-centred angle x: a third harmonic
// of 8 um and a 20 um bump on the nose (|x| < 20), which the nose zone's +-10 um refuses.
double judged_um(int x) {
  double e = 8.0 * std::sin(2 * kPi * 3 * x / 360.0);
  if (std::abs(x) < 20) e += 20.0 * std::pow(std::cos(kPi * x / 40.0), 2);
  return e;
}

Characteristic zone_characteristic(const std::string& key, int from, int to, double limit, Verdict v) {
  Characteristic c;
  c.key = key;
  c.unit = key.rfind("lift", 0) == 0 ? "um" : key.rfind("velocity", 0) == 0 ? "mm/deg" : "mm/deg^2";
  c.limits.lower = -limit;
  c.limits.upper = limit;
  c.verdict = v;
  c.from_deg = from;
  c.to_deg = to;
  return c;
}

// A run whose lift error is out of tolerance on the nose: whole-turn limits +-15 um, the nose
// (-20..20 deg) +-10 um; the raw error has an extra first harmonic.
StoredRun out_of_tolerance_run() {
  StoredRun r;
  r.summary.id = 42;
  r.summary.part = "intake-flat";
  r.summary.lobe = 3;
  r.summary.machine = "grinder-1";
  r.summary.serial = "SN-0042";
  r.summary.operator_name = "anna";
  r.summary.started_utc = "2026-11-22T02:34:44Z";
  r.summary.note = "after wheel dressing";
  r.summary.revolutions = 8;
  r.summary.verdict = Verdict::kOut;
  r.gauge = "tcp:127.0.0.1:1502";
  r.lift_error_reference = LiftErrorReference::kBestFit;
  for (int x = -179; x <= 180; ++x) {
    const std::size_t d = index_of(x);
    r.analysis.residual_error_um[d] = judged_um(x);
    r.analysis.error_um[d] = judged_um(x) + 5.0 * std::sin(2 * kPi * x / 360.0);
    r.analysis.design_lift_mm[d] = std::abs(x) < 90 ? 8.0 * std::pow(std::cos(kPi * x / 180.0), 2) : 0.0;
  }
  for (std::size_t k = 1; k <= 30; ++k) r.analysis.harmonic_amplitude_um[k] = 10.0 / static_cast<double>(k);
  r.analysis.harmonic_amplitude_um[3] = 8.0;
  r.analysis.phase_error_deg = 0.125;

  Characteristic whole;
  whole.key = "lift_error";
  whole.unit = "um";
  whole.value = 26.1;
  whole.min = -8.0;
  whole.max = 26.1;
  whole.limits.lower = -15.0;
  whole.limits.upper = 15.0;
  whole.verdict = Verdict::kOut;
  r.characteristics.push_back(whole);
  Characteristic nose = zone_characteristic("lift_error.nose", -20, 20, 10.0, Verdict::kOut);
  nose.value = nose.max = 26.1;
  r.characteristics.push_back(nose);
  r.characteristics.push_back(zone_characteristic("velocity_error.nose", -20, 20, 0.005, Verdict::kIn));
  Characteristic phase;
  phase.key = "phase";
  phase.unit = "deg";
  phase.value = phase.min = phase.max = 0.125;
  phase.limits.lower = -0.5;
  phase.limits.upper = 0.5;
  phase.verdict = Verdict::kIn;
  r.characteristics.push_back(phase);
  return r;
}

std::uint32_t big_endian_u32(const std::string& s, std::size_t at) {
  std::uint32_t v = 0;
  for (std::size_t i = 0; i < 4; ++i) v = (v << 8) | static_cast<unsigned char>(s[at + i]);
  return v;
}

std::size_t count_of(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::size_t files_in(const fs::path& dir) {
  std::size_t n = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir)) ++n;
  return n;
}

// A PNG read back with cairo, its pixels sampled at points of the page.
class Png {
 public:
  explicit Png(const fs::path& file)
      : surface_(cairo_image_surface_create_from_png(file.c_str()), cairo_surface_destroy) {}
  bool ok() const { return cairo_surface_status(surface_.get()) == CAIRO_STATUS_SUCCESS; }
  int width() const { return cairo_image_surface_get_width(surface_.get()); }
  int height() const { return cairo_image_surface_get_height(surface_.get()); }

  struct Rgb {
    int r, g, b;
  };
  Rgb at_px(int x, int y) const {
    cairo_surface_flush(surface_.get());
    const unsigned char* data = cairo_image_surface_get_data(surface_.get());
    const int stride = cairo_image_surface_get_stride(surface_.get());
    std::uint32_t p = 0;
    std::memcpy(&p, data + static_cast<std::ptrdiff_t>(y) * stride + x * 4, 4);
    return {static_cast<int>((p >> 16) & 0xFF), static_cast<int>((p >> 8) & 0xFF), static_cast<int>(p & 0xFF)};
  }
  Rgb at_pt(double x_pt, double y_pt) const {
    return at_px(static_cast<int>(std::lround(x_pt * kReportPngPixelsPerPoint)),
                 static_cast<int>(std::lround(y_pt * kReportPngPixelsPerPoint)));
  }
  // Whether a pixel within `radius_px` of the point is within `tol` of the colour.
  bool near_pt(double x_pt, double y_pt, Rgb want, int radius_px, int tol) const {
    const int cx = static_cast<int>(std::lround(x_pt * kReportPngPixelsPerPoint));
    const int cy = static_cast<int>(std::lround(y_pt * kReportPngPixelsPerPoint));
    for (int y = cy - radius_px; y <= cy + radius_px; ++y) {
      for (int x = cx - radius_px; x <= cx + radius_px; ++x) {
        if (x < 0 || y < 0 || x >= width() || y >= height()) continue;
        if (close(at_px(x, y), want, tol)) return true;
      }
    }
    return false;
  }
  static bool close(Rgb a, Rgb b, int tol) {
    return std::abs(a.r - b.r) <= tol && std::abs(a.g - b.g) <= tol && std::abs(a.b - b.b) <= tol;
  }

 private:
  std::unique_ptr<cairo_surface_t, decltype(&cairo_surface_destroy)> surface_;
};

// The colours report/chart_cairo.h draws with, in 8 bits.
constexpr Png::Rgb kBandColour{204, 237, 204};  // kBand 0.80 0.93 0.80
constexpr Png::Rgb kCurveColour{13, 77, 204};   // kCurve 0.05 0.30 0.80
constexpr Png::Rgb kWhite{255, 255, 255};

// With GAUGELOOP_PICTURE_DIR set, the pictures the tests draw are copied there to be looked at.
void keep_picture(const fs::path& file) {
  const char* dir = std::getenv("GAUGELOOP_PICTURE_DIR");
  if (dir == nullptr || *dir == '\0') return;
  std::error_code ec;
  fs::copy_file(file, fs::path(dir) / file.filename(), fs::copy_options::overwrite_existing, ec);
}

std::string describe(Png::Rgb c) {
  return "rgb(" + std::to_string(c.r) + "," + std::to_string(c.g) + "," + std::to_string(c.b) + ")";
}

TEST(CamReport, PdfIsOnePage) {
  testing::TempDir dir;
  const fs::path out = dir / "run42.pdf";
  Status s = write_cam_report(out_of_tolerance_run(), out);
  ASSERT_TRUE(s.ok()) << s.error().message;
  const std::string pdf = slurp(out);
  ASSERT_EQ(pdf.rfind("%PDF-", 0), 0u);
  EXPECT_EQ(count_of(pdf, "/Type /Page") - count_of(pdf, "/Type /Pages"), 1u);
  EXPECT_NE(pdf.find("/Count 1"), std::string::npos);
  EXPECT_NE(pdf.find("%%EOF"), std::string::npos);
  EXPECT_EQ(files_in(dir.path()), 1u) << "no temporary file is left";
}

TEST(CamReport, SvgIsAnSvgDocumentOnA4Landscape) {
  testing::TempDir dir;
  const fs::path out = dir / "run42.SVG";
  Status s = write_cam_report(out_of_tolerance_run(), out);
  ASSERT_TRUE(s.ok()) << s.error().message;
  const std::string svg = slurp(out);
  ASSERT_EQ(svg.rfind("<?xml", 0), 0u);
  EXPECT_NE(svg.find("<svg"), std::string::npos);
  EXPECT_NE(svg.find("width=\"841.89pt\""), std::string::npos) << svg.substr(0, 400);
  EXPECT_NE(svg.find("</svg>"), std::string::npos);
}

TEST(CamReport, PngHasTwoPixelsPerPointOfA4Landscape) {
  testing::TempDir dir;
  const fs::path out = dir / "run42.png";
  Status s = write_cam_report(out_of_tolerance_run(), out);
  ASSERT_TRUE(s.ok()) << s.error().message;
  const std::string png = slurp(out);
  ASSERT_GT(png.size(), 24u);
  ASSERT_EQ(png.substr(1, 3), "PNG");
  ASSERT_EQ(png.substr(12, 4), "IHDR");
  EXPECT_EQ(big_endian_u32(png, 16), static_cast<std::uint32_t>(std::lround(kReportWidthPt * 2)));
  EXPECT_EQ(big_endian_u32(png, 20), static_cast<std::uint32_t>(std::lround(kReportHeightPt * 2)));
}

// The lift chart shows each zone's band and the judged error where the placement says: inside
// the whole-turn band (+-15 um) at -75 deg, inside the nose band (+-10 um) but not beyond it at
// 5 deg, and the curve at the judged value on the nose, out of tolerance.
TEST(CamReport, LiftChartShowsTheZoneBandsAndTheErrorCurve) {
  testing::TempDir dir;
  const StoredRun run = out_of_tolerance_run();
  const fs::path out = dir / "run42.png";
  Status s = write_cam_report(run, out);
  ASSERT_TRUE(s.ok()) << s.error().message;
  keep_picture(out);
  Png png(out);
  ASSERT_TRUE(png.ok());
  const ChartPlacement c = cam_report_lift_chart(run);
  ASSERT_EQ(c.x_min, -180.0);
  ASSERT_EQ(c.x_max, 180.0);
  ASSERT_GE(c.y_max, judged_um(0)) << "the chart holds the nose bump";

  // Band: at -75 deg the curve is near +5.7 um, so -12 um shows the whole-turn band only.
  Png::Rgb p = png.at_pt(c.x_pt(-75), c.y_pt(-12));
  EXPECT_TRUE(Png::close(p, kBandColour, 6)) << describe(p);
  // Beyond the whole-turn band: page white.
  p = png.at_pt(c.x_pt(-75), c.y_pt(18));
  EXPECT_TRUE(Png::close(p, kWhite, 6)) << describe(p);
  // The nose has its own narrower band: -5 um is inside, -12 um outside it.
  p = png.at_pt(c.x_pt(5), c.y_pt(-5));
  EXPECT_TRUE(Png::close(p, kBandColour, 6)) << describe(p);
  p = png.at_pt(c.x_pt(5), c.y_pt(-12));
  EXPECT_TRUE(Png::close(p, kWhite, 6)) << describe(p);

  // The judged curve passes through its values, out of tolerance on the nose and elsewhere.
  for (int x : {-150, -100, -45, 5, 10, 60, 120}) {
    EXPECT_TRUE(png.near_pt(c.x_pt(x), c.y_pt(judged_um(x)), kCurveColour, 3, 40))
        << "no curve at " << x << " deg, " << judged_um(x) << " um";
  }
  // ...and nowhere near the mirror of its nose bump.
  EXPECT_FALSE(png.near_pt(c.x_pt(5), c.y_pt(-judged_um(5)), kCurveColour, 3, 40));
}

// Identity at its longest (64 characters each) is cut to fit, never pushed off the page.
TEST(CamReport, LongIdentityStaysOnThePage) {
  StoredRun run = out_of_tolerance_run();
  run.summary.part = std::string(64, 'P');
  run.summary.serial = std::string(64, 'S');
  run.summary.operator_name = std::string(64, 'O');
  run.summary.machine = std::string(64, 'M');
  run.summary.note = std::string(200, 'N');
  run.settings = "part.drawing_number = " + std::string(40, 'D') + "\npart.drawing_revision = " + std::string(40, 'R') +
                 "\ngauge.id = " + std::string(40, 'G') + "\ngauge.calibration_date = 2026-10-01\n" +
                 "part.temperature_c = -39.9\npart.temperature_source = operator\n";
  run.summary.machine += std::string(1, 'X');
  testing::TempDir dir;
  const fs::path out = dir / "long.png";
  ASSERT_TRUE(write_cam_report(run, out).ok());
  keep_picture(out);
  Png png(out);
  ASSERT_TRUE(png.ok());
  // The right margin (the last 20 points) stays white over the identity lines.
  for (int y = static_cast<int>(40 * kReportPngPixelsPerPoint); y < static_cast<int>(77 * kReportPngPixelsPerPoint);
       ++y) {
    for (int x = png.width() - static_cast<int>(20 * kReportPngPixelsPerPoint); x < png.width(); ++x) {
      ASSERT_TRUE(Png::close(png.at_px(x, y), kWhite, 6)) << "ink at " << x << "," << y;
    }
  }
}

TEST(CamReport, RunWithoutCharacteristicsHasNoBand) {
  testing::TempDir dir;
  StoredRun run = out_of_tolerance_run();
  run.characteristics.clear();
  run.summary.verdict = Verdict::kNotJudged;
  const fs::path out = dir / "old.png";
  Status s = write_cam_report(run, out);
  ASSERT_TRUE(s.ok()) << s.error().message;
  keep_picture(out);
  Png png(out);
  ASSERT_TRUE(png.ok());
  const ChartPlacement c = cam_report_lift_chart(run);
  Png::Rgb p = png.at_pt(c.x_pt(-75), c.y_pt(-12));
  EXPECT_TRUE(Png::close(p, kWhite, 6)) << describe(p);
  EXPECT_TRUE(png.near_pt(c.x_pt(5), c.y_pt(judged_um(5)), kCurveColour, 3, 40));
}

TEST(CamReport, NominalReferenceChartsTheRawError) {
  StoredRun run = out_of_tolerance_run();
  run.lift_error_reference = LiftErrorReference::kNominal;
  testing::TempDir dir;
  const fs::path out = dir / "nominal.png";
  ASSERT_TRUE(write_cam_report(run, out).ok());
  Png png(out);
  const ChartPlacement c = cam_report_lift_chart(run);
  // At -90 deg the raw error is the judged one minus 5 um: the bold curve is there.
  const double raw = run.analysis.error_um[index_of(-90)];
  EXPECT_TRUE(png.near_pt(c.x_pt(-90), c.y_pt(raw), kCurveColour, 3, 40)) << raw;
}

// A run stored before the best-fit error was kept has a best-fit table of zeros: the report
// charts the raw error rather than a flat line.
TEST(CamReport, RunWithoutBestFitErrorChartsTheRawError) {
  StoredRun run = out_of_tolerance_run();
  run.analysis.residual_error_um.fill(0.0);
  testing::TempDir dir;
  const fs::path out = dir / "old.png";
  ASSERT_TRUE(write_cam_report(run, out).ok());
  Png png(out);
  const ChartPlacement c = cam_report_lift_chart(run);
  for (int x : {-100, 5, 100}) {
    const double raw = run.analysis.error_um[index_of(x)];
    EXPECT_TRUE(png.near_pt(c.x_pt(x), c.y_pt(raw), kCurveColour, 3, 40)) << x << " deg, " << raw << " um";
  }
}

// A crankpin run as the measure job stores it: radius error in pin degrees, the error less
// the least-squares circle as the residual, the pin's characteristics, settings saying pin.
StoredRun pin_run() {
  StoredRun r;
  r.summary.id = 7;
  r.summary.part = "crankpin_cx";
  r.summary.lobe = 1;
  r.summary.revolutions = 3;
  r.summary.verdict = Verdict::kIn;
  r.gauge = "tcp:127.0.0.1:1502";
  r.settings = "part.kind = pin\npin.mode = c-x\npin.throw_mm = 45.000000\n";
  for (int x = -179; x <= 180; ++x) {
    const std::size_t d = index_of(x);
    r.analysis.residual_error_um[d] = 1.5 * std::sin(2 * kPi * 2 * x / 360.0);
    r.analysis.error_um[d] = r.analysis.residual_error_um[d] + 4.0 + 2.0 * std::cos(2 * kPi * x / 360.0);
  }
  r.analysis.peak_to_valley_residual_um = 3.0;
  r.characteristics = {single_characteristic("roundness", "um", 3.0, Limits{std::nullopt, 4.0}),
                       single_characteristic("diameter_error", "um", 8.0, Limits{-8.0, 8.0}),
                       single_characteristic("stroke_error", "um", 2.0, Limits{-25.0, 25.0}),
                       single_characteristic("index_error", "deg", 0.0, Limits{-0.03, 0.03})};
  return r;
}

std::string all_words(const CamReportWords& w) {
  std::string out = w.page_title + "|" + w.item + "|" + w.item_label + "|" + w.angle_axis + "|" + w.error_axis + "|" +
                    w.error_chart + "|" + w.polar_title + "|" + w.polar_zero + "|" + w.polar_angle + "|" +
                    w.polar_reference + "|" + w.harmonics_title + "|" + w.footer_judged + "|" + w.footer_detail;
  for (const std::string& t : w.characteristic_titles) out += "|" + t;
  return out;
}

TEST(CamReport, APinRunSpeaksOfThePinAndLeavesOutTheLobesFigures) {
  const CamReportWords w = cam_report_words(pin_run());
  EXPECT_EQ(w.page_title, "Pin inspection report");
  EXPECT_EQ(w.item, "pin 1");
  EXPECT_EQ(w.item_label, "Pin");
  EXPECT_NE(w.error_axis.find("radius error"), std::string::npos) << w.error_axis;
  EXPECT_EQ(w.error_chart.rfind("Radius error", 0), 0u) << w.error_chart;
  EXPECT_EQ(w.angle_axis.rfind("pin degree", 0), 0u) << w.angle_axis;
  EXPECT_FALSE(w.derivative_charts);
  EXPECT_EQ(w.characteristic_titles, (std::vector<std::string>{"Pin roundness *", "Pin diameter error",
                                                               "Pin stroke (throw) error", "Pin index error"}));
  EXPECT_EQ(w.table_note, "* of the radius error less the least-squares circle");
  EXPECT_NE(w.footer_detail.find("C-X"), std::string::npos) << w.footer_detail;
  EXPECT_EQ(w.lift_legend, (std::vector<std::string>{"judged", "raw"}))
      << "roundness judges the whole curve: no band drawn, none named";
  const std::string words = all_words(w);
  for (const char* lobe_word :
       {"lift", "Lift", "cam", "nose", "phase", "runout", "base circle", "Base circle", "velocity", "acceleration"}) {
    EXPECT_EQ(words.find(lobe_word), std::string::npos) << "'" << lobe_word << "' in " << words;
  }

  testing::TempDir dir;
  const fs::path out = dir / "pin7.pdf";
  Status s = write_cam_report(pin_run(), out);
  ASSERT_TRUE(s.ok()) << s.error().message;
  const std::string pdf = slurp(out);
  EXPECT_EQ(pdf.rfind("%PDF-", 0), 0u);
  EXPECT_EQ(count_of(pdf, "/Type /Page") - count_of(pdf, "/Type /Pages"), 1u);
  const fs::path png = dir / "pin7.png";
  ASSERT_TRUE(write_cam_report(pin_run(), png).ok());
  keep_picture(png);
}

TEST(CamReport, ALobeRunKeepsTheCamWords) {
  StoredRun r = out_of_tolerance_run();
  r.settings = "compensation.gain = 1\n";
  r.characteristics.push_back(single_characteristic("roundness", "um", 1.0, Limits{std::nullopt, 4.0}));
  const CamReportWords w = cam_report_words(r);
  EXPECT_EQ(w.page_title, "Cam inspection report");
  EXPECT_EQ(w.item, "lobe 3");
  EXPECT_EQ(w.angle_axis, "cam angle, deg (nose at 0; opening side negative, closing side positive)");
  EXPECT_EQ(w.error_chart, "Lift error after best-fit phase (judged), \u00b5m");
  EXPECT_EQ(w.polar_title, "Polar view of the judged lift error");
  EXPECT_EQ(w.polar_zero, "0 (nose)");
  EXPECT_TRUE(w.derivative_charts);
  EXPECT_EQ(w.characteristic_titles.back(), "Base circle roundness") << "a figure of its own: not marked";
  ASSERT_FALSE(r.characteristics.empty());
  for (std::size_t i = 0; i < r.characteristics.size(); ++i) {
    const bool of_curve = r.characteristics[i].key.rfind("lift_error", 0) == 0 ||
                          r.characteristics[i].key.rfind("velocity_error", 0) == 0 ||
                          r.characteristics[i].key.rfind("acceleration_error", 0) == 0;
    const std::string& t = w.characteristic_titles[i];
    EXPECT_EQ(t.size() > 2 && t.substr(t.size() - 2) == " *", of_curve) << t;
  }
  EXPECT_EQ(w.table_note, "* of the lift error after the best-fit phase");
  ASSERT_EQ(w.lift_legend.size(), 3u);
  EXPECT_TRUE(w.lift_legend.back().ends_with("\u00b0 out")) << w.lift_legend.back() << ": a band, degrees out of it";
  EXPECT_EQ(w.footer_judged.rfind("judged: lift error after the best-fit phase (+0.125 deg removed)", 0), 0u)
      << w.footer_judged;
  EXPECT_EQ(w.footer_detail.find("work speed program"), std::string::npos) << w.footer_detail;
  // Ground at a work speed program: the report says so, with the flanks' speed.
  r.settings += "speed.base_speed_rpm = 30.000000\nspeed.hold = flanks\nspeed.flank_speed_mm_per_min = 1200.000000\n";
  EXPECT_NE(cam_report_words(r).footer_detail.find("ground at a work speed program (flanks at 1200 mm/min)"),
            std::string::npos)
      << cam_report_words(r).footer_detail;
}

// What a cam checker's report carries beside the figures: the drawing and its revision, the
// gauge and its calibration day, the report's own id, the nose lift measured against the
// drawing's and the base circle radius; said as not given where the run's settings do not say.
TEST(CamReport, TheHeaderNamesTheDrawingTheGaugeAndTheReport) {
  StoredRun r = out_of_tolerance_run();
  r.summary.uuid = "6f1c2e0a-1b2c-4d5e-8f90-a1b2c3d4e5f6";
  r.settings =
      "part.base_circle_radius_mm = 18.000000\npart.drawing_number = 4711-0815\npart.drawing_revision = C\n"
      "gauge.id = LVDT-07\ngauge.calibration_date = 2026-10-01\n";
  for (std::size_t d = 0; d < 360; ++d) r.analysis.mean_lift_mm[d] = r.analysis.design_lift_mm[d] + 0.0021;
  std::vector<std::pair<std::string, std::string>> t = cam_report_words(r).traceability;
  const std::vector<std::pair<std::string, std::string>> expected = {{"Drawing", "4711-0815 rev C"},
                                                                     {"Gauge", "LVDT-07, calibrated 2026-10-01"},
                                                                     {"Part temperature", "not given"},
                                                                     {"Report", "grinder-1-42-6f1c2e0a"},
                                                                     {"Nose lift", "8.002 mm (drawing 8.000)"},
                                                                     {"Base circle r", "18.000 mm"}};
  EXPECT_EQ(t, expected);
  EXPECT_EQ(report_id(r.summary), "grinder-1-42-6f1c2e0a");

  r.settings = "compensation.gain = 1\n";
  r.summary.uuid.clear();
  t = cam_report_words(r).traceability;
  ASSERT_EQ(t.size(), 6u);
  EXPECT_EQ(t[0].second, "") << "no drawing given";
  EXPECT_EQ(t[1].second, "") << "no gauge given";
  EXPECT_EQ(t[2].second, "not given") << "no part temperature given";
  EXPECT_EQ(t[3].second, "grinder-1-42") << "a run stored without a UUID";
  EXPECT_EQ(t[5].second, "") << "no radius recorded";
}

// The lobe's angle against the datum, as a cam checker prints it: the measured nose on the work
// spindle, C = c0 + s * phase, against the nominal c0 and the difference; a lobe measured
// turning the other way (s = -1) moves the nose the other way. Not known without the run's
// frame or phase.
TEST(CamReport, TheHeaderGivesTheLobeAngleAgainstTheDatum) {
  StoredRun r = out_of_tolerance_run();
  r.summary.phase_error_deg = 0.125;
  Part frame;
  frame.c_offset_deg = 90.0;
  frame.rotation_sense = 1;
  r.geometry = frame;
  EXPECT_EQ(cam_report_words(r).lobe_angle, "C 90.125\u00b0 from the datum (nominal 90.000\u00b0, +0.125\u00b0)");
  r.geometry->rotation_sense = -1;
  r.geometry->c_offset_deg = 0.0;
  EXPECT_EQ(cam_report_words(r).lobe_angle, "C 359.875\u00b0 from the datum (nominal 0.000\u00b0, -0.125\u00b0)");
  r.geometry.reset();
  EXPECT_EQ(cam_report_words(r).lobe_angle, "not known (no frame or phase recorded)");
  EXPECT_EQ(cam_report_words(pin_run()).lobe_angle, "") << "a pin's index is a characteristic of its own";
}

// The part's temperature at measurement, as the PLC or the operator gave it: a cam checker's
// report prints it so a warm part's error is told from a wrong table. A pin's report too.
TEST(CamReport, TheHeaderSaysThePartTemperatureAndWhoGaveIt) {
  StoredRun r = out_of_tolerance_run();
  auto temperature = [](const StoredRun& run) {
    for (const auto& [label, value] : cam_report_words(run).traceability) {
      if (label == "Part temperature") return value;
    }
    return std::string("(no such field)");
  };
  r.settings = "gauge.id = LVDT-07\npart.temperature_c = 21.4\npart.temperature_source = plc\n";
  EXPECT_EQ(temperature(r), "21.4 \u00b0C (PLC)");
  r.settings = "part.temperature_c = -1.5\npart.temperature_source = operator\n";
  EXPECT_EQ(temperature(r), "-1.5 \u00b0C (operator)");
  r.settings = "part.temperature_c = warm\npart.temperature_source = operator\n";
  EXPECT_EQ(temperature(r), "not given") << "a line that is no number is not shown as one";
  r.characteristics.clear();
  r.settings = "part.kind = pin\npin.mode = c-x\npart.temperature_c = 20.0\npart.temperature_source = plc\n";
  EXPECT_EQ(temperature(r), "20.0 \u00b0C (PLC)");
}

TEST(CamReport, AnotherExtensionIsRefusedAndNothingWritten) {
  testing::TempDir dir;
  const fs::path out = dir / "run42.jpg";
  Status s = write_cam_report(out_of_tolerance_run(), out);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_NE(s.error().message.find(out.string()), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find(".pdf, .svg or .png"), std::string::npos) << s.error().message;
  EXPECT_EQ(files_in(dir.path()), 0u);
  EXPECT_FALSE(write_cam_report(out_of_tolerance_run(), dir / "report").ok()) << "no extension";
}

TEST(CamReport, FailuresLeaveNoFile) {
  testing::TempDir dir;
  // A directory that does not exist: kIo naming the file.
  Status s = write_cam_report(out_of_tolerance_run(), dir / "missing" / "run42.pdf");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kIo);
  EXPECT_NE(s.error().message.find("missing"), std::string::npos) << s.error().message;
  // An analysis that cannot be drawn leaves the file that was there as it was.
  const fs::path out = dir.write("run42.pdf", "the report filed yesterday");
  StoredRun bad = out_of_tolerance_run();
  bad.analysis.residual_error_um[17] = std::nan("");
  s = write_cam_report(bad, out);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kInvalidInput);
  EXPECT_EQ(slurp(out), "the report filed yesterday");
  EXPECT_EQ(files_in(dir.path()), 1u);
}

// ---- The trend plot ----

std::vector<RunCharacteristics> trend_runs() {
  std::vector<RunCharacteristics> runs;
  for (int i = 0; i < 12; ++i) {
    RunCharacteristics r;
    r.run.id = 100 + i;
    r.run.part = "intake-flat";
    r.run.lobe = 1;
    r.run.started_utc = "2026-11-" + std::to_string(10 + i) + "T08:00:00Z";
    Characteristic c;
    c.key = "lift_error";
    c.unit = "um";
    c.value = c.max = 4.0 + 0.9 * i;
    c.min = -3.0;
    c.limits.lower = -12.0;
    c.limits.upper = 12.0;
    c.verdict = c.value > 12.0 ? Verdict::kOut : Verdict::kIn;
    r.characteristics.push_back(c);
    Characteristic phase;
    phase.key = "phase";
    phase.unit = "deg";
    phase.value = phase.min = phase.max = 0.01 * i;
    r.characteristics.push_back(phase);
    runs.push_back(r);
  }
  return runs;
}

TEST(TrendPlot, WritesEachFormat) {
  testing::TempDir dir;
  ASSERT_TRUE(write_trend_plot(trend_runs(), "lift_error", dir / "t.png").ok());
  const std::string png = slurp(dir / "t.png");
  ASSERT_GT(png.size(), 24u);
  EXPECT_EQ(big_endian_u32(png, 16), static_cast<std::uint32_t>(std::lround(kTrendWidthPt * 2)));
  EXPECT_EQ(big_endian_u32(png, 20), static_cast<std::uint32_t>(std::lround(kTrendHeightPt * 2)));
  ASSERT_TRUE(write_trend_plot(trend_runs(), "phase", dir / "t.svg").ok());
  EXPECT_EQ(slurp(dir / "t.svg").rfind("<?xml", 0), 0u);
  ASSERT_TRUE(write_trend_plot(trend_runs(), "lift_error", dir / "t.pdf").ok());
  EXPECT_EQ(slurp(dir / "t.pdf").rfind("%PDF-", 0), 0u);
  EXPECT_EQ(files_in(dir.path()), 3u);
}

// An SVG page's text is SVG text, not glyph outlines: searchable, a fraction of the bytes, and
// escaped where a name holds XML's own characters. The axis title keeps its quarter turn.
TEST(TrendPlot, SvgTextIsText) {
  std::vector<RunCharacteristics> runs = trend_runs();
  for (RunCharacteristics& r : runs) r.run.part = "intake<flat> & co";
  Result<std::string> svg = trend_plot_svg(runs, "lift_error");
  ASSERT_TRUE(svg.ok()) << svg.error().message;
  EXPECT_EQ(svg->find("glyph"), std::string::npos) << "cairo drew the text as outlines";
  EXPECT_NE(svg->find(">intake&lt;flat&gt; &amp; co lobe 1 \u00b7 12 runs, oldest first"), std::string::npos);
  EXPECT_EQ(svg->find("intake<flat>"), std::string::npos);
  EXPECT_NE(svg->find("font-weight=\"bold\""), std::string::npos);  // the title
  // The y-axis title: rotated by -90 deg, matrix(cos, sin, -sin, cos, x, y) = (0 -1 1 0 ...).
  EXPECT_NE(svg->find("transform=\"matrix(0.000000 -1.000000 1.000000 0.000000 "), std::string::npos);
  // Every <text> is closed, and the text sits inside the document.
  std::size_t opened = 0, closed = 0;
  for (std::size_t at = svg->find("<text "); at != std::string::npos; at = svg->find("<text ", at + 1)) ++opened;
  for (std::size_t at = svg->find("</text>"); at != std::string::npos; at = svg->find("</text>", at + 1)) ++closed;
  EXPECT_GT(opened, 10u);
  EXPECT_EQ(opened, closed);
  EXPECT_LT(svg->rfind("</text>"), svg->rfind("</svg>"));
}

// Pixels of a colour in a PNG.
int count_colour(const Png& png, Png::Rgb want, int tol) {
  int n = 0;
  for (int y = 0; y < png.height(); ++y) {
    for (int x = 0; x < png.width(); ++x) n += Png::close(png.at_px(x, y), want, tol) ? 1 : 0;
  }
  return n;
}

// Out-of-tolerance runs are drawn as red points: the same runs all judged in tolerance show
// the red limit lines only.
TEST(TrendPlot, MarksRunsOutOfTolerance) {
  testing::TempDir dir;
  std::vector<RunCharacteristics> runs = trend_runs();
  ASSERT_TRUE(write_trend_plot(runs, "lift_error", dir / "out.png").ok());
  keep_picture(dir / "out.png");
  for (RunCharacteristics& r : runs) r.characteristics[0].verdict = Verdict::kIn;
  ASSERT_TRUE(write_trend_plot(runs, "lift_error", dir / "in.png").ok());
  const Png with_out(dir / "out.png");
  const Png all_in(dir / "in.png");
  ASSERT_TRUE(with_out.ok() && all_in.ok());
  constexpr Png::Rgb kRed{204, 26, 26};  // kOut 0.80 0.10 0.10
  const int red_lines = count_colour(all_in, kRed, 10);
  EXPECT_GT(red_lines, 500) << "the limits are drawn";
  // Three runs out (values 12.1, 13.0, 13.9 um), each a disc of 4 pt (8 px) radius.
  EXPECT_GT(count_colour(with_out, kRed, 10), red_lines + 3 * 150);
  EXPECT_GT(count_colour(all_in, kCurveColour, 10), count_colour(with_out, kCurveColour, 10));
}

TEST(TrendPlot, AnUnknownKeyListsTheKeysPresent) {
  testing::TempDir dir;
  Status s = write_trend_plot(trend_runs(), "roundness", dir / "t.png");
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.error().code, ErrorCode::kNotFound);
  EXPECT_NE(s.error().message.find("roundness"), std::string::npos) << s.error().message;
  EXPECT_NE(s.error().message.find("lift_error, phase"), std::string::npos) << s.error().message;
  EXPECT_EQ(files_in(dir.path()), 0u);

  std::vector<RunCharacteristics> old = trend_runs();
  for (RunCharacteristics& r : old) r.characteristics.clear();
  s = write_trend_plot(old, "lift_error", dir / "t.png");
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.error().message.find("before tolerances were recorded"), std::string::npos) << s.error().message;
  EXPECT_FALSE(write_trend_plot({}, "lift_error", dir / "t.png").ok());
  EXPECT_FALSE(write_trend_plot(trend_runs(), "lift_error", dir / "t.gif").ok());
  EXPECT_EQ(files_in(dir.path()), 0u);
}

// ---- The gear report ----

StoredGearRun report_gear_run(Verdict verdict, double worst_um) {
  StoredGearRun g;
  g.id = 12;
  GearRunRecord& r = g.record;
  r.started_utc = "2026-12-04T08:00:00Z";
  r.machine = "gear-grinder-2";
  r.part = "gear_71";
  r.source = "flank probe tcp:10.0.0.7:502";
  r.serial = "G-12";
  r.nc_file = "/nc/GEAR_71.SPF";
  r.ground_with_version = 3;
  r.required_class = 5;
  r.total_tolerance_um = 8.6;
  r.verdict = verdict;
  r.tolerance_class = verdict == Verdict::kIn ? 4 : 7;
  r.total_max_um = worst_um;
  r.total_mean_um = worst_um;
  for (int gap : {1, 20}) {
    for (const char* flank : {"left", "right"}) {
      GearTraceRecord t;
      t.gap = gap;
      t.flank = flank;
      t.total_um = worst_um;
      t.tolerance_class = r.tolerance_class;
      t.from_mm = -10.8;
      t.to_mm = 10.8;
      for (int i = 0; i <= 24; ++i) {
        t.z_mm.push_back(-12.0 + i);
        t.deviation_um.push_back((std::string(flank) == "left" ? 1 : -1) * worst_um * (i - 12) / 24.0);
      }
      r.traces.push_back(t);
    }
  }
  return g;
}

TEST(GearReport, DrawsEveryGapsLeadAndTheVerdictInItsColour) {
  testing::TempDir dir;
  ASSERT_TRUE(write_gear_report(report_gear_run(Verdict::kOut, 12.0), dir / "out.png").ok());
  ASSERT_TRUE(write_gear_report(report_gear_run(Verdict::kIn, 3.0), dir / "in.png").ok());
  keep_picture(dir / "out.png");
  const Png out(dir / "out.png");
  const Png in(dir / "in.png");
  ASSERT_TRUE(out.ok() && in.ok());
  // The left flanks' traces in blue (0.05, 0.30, 0.80), 2 gaps of a 24 mm face: hundreds of pixels.
  EXPECT_GT(count_colour(out, {13, 77, 204}, 30), 300);
  // OUT and the out rows in red; IN and the in rows in green.
  EXPECT_GT(count_colour(out, {204, 26, 26}, 30), count_colour(in, {204, 26, 26}, 30) + 100);
  EXPECT_GT(count_colour(in, {26, 140, 51}, 30), count_colour(out, {26, 140, 51}, 30) + 100);
  ASSERT_TRUE(write_gear_report(report_gear_run(Verdict::kOut, 12.0), dir / "report.pdf").ok());
  EXPECT_EQ(testing::slurp(dir / "report.pdf").rfind("%PDF", 0), 0u);
  EXPECT_FALSE(write_gear_report(report_gear_run(Verdict::kOut, 12.0), dir / "report.txt").ok());
  StoredGearRun bare = report_gear_run(Verdict::kOut, 12.0);
  bare.record.traces.clear();
  Status refused = write_gear_report(bare, dir / "bare.pdf");
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().message.find("no lead trace"), std::string::npos) << refused.error().message;
  EXPECT_FALSE(fs::exists(dir / "bare.pdf"));
}

// A gear whose profiles were measured: their table after the leads', each row's verdict in its
// colour; the same gear without profiles has none of those rows.
TEST(GearReport, TablesTheProfilesWhenMeasured) {
  testing::TempDir dir;
  StoredGearRun g = report_gear_run(Verdict::kIn, 3.0);
  ASSERT_TRUE(write_gear_report(g, dir / "leads.png").ok());
  for (int gap : {1, 20}) {
    for (const char* flank : {"left", "right"}) {
      GearProfileRecord p;
      p.gap = gap;
      p.flank = flank;
      p.total_um = 2.0;
      p.tolerance_class = 2;
      p.roll_mm = {25.0, 30.0, 35.0};
      p.deviation_um = {-1.0, 0.0, 1.0};
      g.record.profiles.push_back(p);
    }
  }
  g.record.profile_tolerance_um = 8.4;
  ASSERT_TRUE(write_gear_report(g, dir / "profiles.png").ok());
  keep_picture(dir / "profiles.png");
  const Png leads(dir / "leads.png");
  const Png profiles(dir / "profiles.png");
  ASSERT_TRUE(leads.ok() && profiles.ok());
  // Four more "in" verdicts in green, and a header's and a table's more ink.
  EXPECT_GT(count_colour(profiles, {26, 140, 51}, 30), count_colour(leads, {26, 140, 51}, 30) + 40);
  EXPECT_GT(count_colour(profiles, {26, 26, 31}, 40), count_colour(leads, {26, 26, 31}, 40) + 500);
}

}  // namespace
}  // namespace gaugeloop
