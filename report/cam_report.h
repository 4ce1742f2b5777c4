// The cam report a quality engineer files (one page: identity, lift, velocity and acceleration
// error with their tolerance bands, polar view, harmonics, characteristics and verdicts) and
// the trend plot of one characteristic over the runs of a lobe. Drawn with cairo; PDF, SVG or
// PNG by the file's extension.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// The report's page: A4 landscape, points. A PNG has 2 pixels per point (1684 x 1191).
inline constexpr double kReportWidthPt = 841.89;
inline constexpr double kReportHeightPt = 595.28;
inline constexpr double kReportPngPixelsPerPoint = 2.0;

// kInvalidInput naming `out` and the formats unless its extension is .pdf, .svg or .png (any
// case): what write_cam_report and write_trend_plot check first.
Status check_page_file_name(const std::filesystem::path& out);

// Writes the cam report of `run` to `out`: PDF, SVG or PNG by its extension (any case).
// The lift error charted and judged is the one run.lift_error_reference names (best fit:
// analysis.residual_error_um, nominal: analysis.error_um), nose-centred over -180..180 cam
// degrees (cam frame index d is drawn at d up to 180 and at d - 360 above), the raw lift
// error (error_um) faint behind it; velocity and acceleration error are its derivatives
// (error_derivatives). Tolerance bands come from run.characteristics: a zone's band from
// "<figure>.<zone>" over its from_deg..to_deg, the whole-turn "<figure>" limits elsewhere; a
// run without characteristics gets no bands and its table says it was not judged.
// The file is written atomically: it holds the whole page or is left as it was.
// Errors: kInvalidInput naming the file for another extension; kIo naming the file if it
// cannot be written (no such directory, no permission); kInvalidInput for an analysis
// holding a non-finite value.
Status write_cam_report(const StoredRun& run, const std::filesystem::path& out);

// The words a report prints around its figures, told from what the run measured (run_part:
// a lobe or a crankpin). A pin's page speaks of the radius error over pin degrees (pin
// frame, 0 along the crank radius outward), titles its characteristics as a pin's, and
// leaves out what only a lobe has (velocity and acceleration error, phase, base circle
// runout). write_cam_report draws exactly these words; a test reads them here.
struct CamReportWords {
  std::string page_title;         // "Cam inspection report", "Pin inspection report"
  std::string item;               // "lobe 3", "pin 1"
  std::string item_label;         // "Lobe", "Pin": the identity field
  std::string angle_axis;         // the charts' x axis title
  std::string error_axis;         // the error chart's y axis title
  std::string error_chart;        // the error chart's title
  std::string polar_title;        // the polar view's title
  std::string polar_zero;         // the polar view's label at 0 degrees
  std::string polar_angle;        // the polar view's scale line starts with it: "cam deg", "pin deg"
  std::string polar_reference;    // what its rings are about: "base circle", "least-squares circle"
  std::string harmonics_title;    // the harmonics chart's title
  bool derivative_charts = true;  // velocity and acceleration error: a lobe's only
  // The table's, in run.characteristics' order; " *" after those of the judged error curve.
  std::vector<std::string> characteristic_titles;
  std::string table_note;     // beside the table's title: "* of the lift error after the best-fit phase"
  std::string footer_judged;  // the footer's first line
  std::string footer_detail;  // and its second
  // The header's third line, label and value: the drawing (number and revision from the part
  // file), the gauge (inventory number and calibration day), the report's id (machine, run and
  // the run's UUID, one per run everywhere), and a lobe's nose lift (measured against the
  // drawing's) and base circle radius. "–" where the run's settings do not say.
  std::vector<std::pair<std::string, std::string>> traceability;
  // The lift chart's legend: "judged", "raw", then "tolerance" (or "N° out") only where the
  // chart draws a band.
  std::vector<std::string> lift_legend;
  // A lobe's angle against the datum, the header's second line: where its measured nose stands
  // on the work spindle (nose_angle) against the drawing's, and the difference. Empty for a pin.
  std::string lobe_angle;
};

// The id a run's report carries: "<machine>-<run id>-<first 8 hex digits of its UUID>"
// (without the UUID's part for a run stored without one).
std::string report_id(const RunSummary& run);
CamReportWords cam_report_words(const StoredRun& run);

// Where the report draws the lift error chart, for checking a rendered page: the plot area
// (points from the page's top left, y down) and the ranges it shows (x: cam degrees
// -180..180, y: lift error in um, upwards).
struct ChartPlacement {
  double left_pt = 0.0, top_pt = 0.0, width_pt = 0.0, height_pt = 0.0;
  double x_min = 0.0, x_max = 0.0, y_min = 0.0, y_max = 0.0;
  double x_pt(double x) const { return left_pt + (x - x_min) / (x_max - x_min) * width_pt; }
  double y_pt(double y) const { return top_pt + height_pt - (y - y_min) / (y_max - y_min) * height_pt; }
};
ChartPlacement cam_report_lift_chart(const StoredRun& run);

// The trend page: 297 x 167 mm landscape, points.
inline constexpr double kTrendWidthPt = 841.89;
inline constexpr double kTrendHeightPt = 473.0;

// The runs of a plot of characteristic `key`: those `q` selects, oldest first, each with only
// that characteristic (one row a run read); when none has it, the newest run alone with all of
// its characteristics, so that write_trend_plot names the keys it has.
Result<std::vector<RunCharacteristics>> trend_plot_runs(const RunHistory& history, const RunQuery& q,
                                                        const std::string& key);

// Writes the plot of characteristic `key` over `runs` (oldest first, as
// RunStore::characteristics returns them) to `out` (PDF, SVG or PNG by its extension): its
// value per run in run order (run ids and dates on the x axis) with its limits as lines and
// the runs out of tolerance marked. Runs without the key are left out.
// Errors: kNotFound if no run has the key (the message lists the keys the runs have) or
// there are no runs; kInvalidInput for another extension; kIo if the file cannot be written.
Status write_trend_plot(const std::vector<RunCharacteristics>& runs, const std::string& key,
                        const std::filesystem::path& out);

// The same page as SVG text, written nowhere (what the HTTP API sends). The same errors but
// kInvalidInput and kIo for the file.
Result<std::string> trend_plot_svg(const std::vector<RunCharacteristics>& runs, const std::string& key);

}  // namespace gaugeloop
