// The lobe error of one run as an SVG picture: polar and linear, with the tolerance band.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/run.h"
#include "core/tolerance.h"
#include "storage/run_store.h"

namespace gaugeloop {

struct ErrorPlot {
  std::string title;     // e.g. "Run 12 · intake_flat lobe 1 · grinder-1"
  std::string subtitle;  // e.g. "2026-11-22 02:34 UTC · pushed"
  // The error the verdicts judge, um, index = degree (cam frame, 0 at the nose, for a lobe):
  // the tolerance band is drawn around it, and the headline's largest error and degrees outside
  // are of it.
  DegreeTable error_um{};
  // What error_um is, named in the headline and the legend.
  std::string error_name = "lift error = measured \u2212 design";
  // The error as measured at nominal timing when error_um is another (after the best-fit phase,
  // less a least-squares circle): drawn thin and grey, labelled, never judged on the picture.
  std::optional<DegreeTable> raw_error_um;
  std::string axis_label = "lift error (\u00b5m)";
  std::string angle_title = "cam angle (deg, 0 = nose, opening side negative)";
  std::string angle_word = "cam";  // "max |error| ... at cam -59°" (signed_degree)
  std::string frame_note = "cam frame, 0\u00b0 at the nose";
  // Per-degree standard deviation across revolutions, um: drawn as a band around the error.
  std::optional<DegreeTable> spread_um;
  // The correction computed from the run, um, cam frame: drawn dashed when set.
  std::optional<DegreeTable> correction_um;
  // The limits in force at each degree (index = degree, as error_um; the whole turn's narrowed by
  // a zone's, limits_per_cam_degree): the band drawn and the degrees outside it marked. Wins over tolerance_um.
  std::optional<std::array<Limits, kDegreesPerRevolution>> limits_um;
  // A symmetric tolerance -t..+t at every degree, when limits_um is not set. > 0.
  std::optional<double> tolerance_um;
  std::string footer;  // one line of small print (figures, database, settings hash)
};

// The error plot's layout: wide, the polar and linear panels side by side, 1200 x 640 px, that
// prints on A4 landscape; narrow, the same stacked, 380 x 1060 px, for a phone held upright
// (its text reads at the size drawn when the picture is as wide as the phone).
enum class PlotShape { kWide, kNarrow };

// A self-contained SVG 1.1 document (no scripts, no external fonts or files). Numbers use '.'
// whatever the C locale. Pure: no I/O. Precondition: every value is finite.
std::string render_error_plot_svg(const ErrorPlot& plot, PlotShape shape = PlotShape::kWide);

// A stored run's error plot as `runs plot` and the run page draw it: title, subtitle (time,
// status, serial and note), the judged error (judged_error) with its name, the raw error beside
// it when that is another curve, the spread, the correction, and the limits per degree the run
// was judged against (none for a pin: roundness is a figure of the whole curve), and a footer
// of the judged curve's figures, then the raw error's, phase, repeatability and revolutions.
ErrorPlot run_error_plot(const StoredRun& run);

// Every part of a grinding loop on one sheet (gaugeloop demo --iterations): the lift error
// profile of each part over the cam degrees, first to last from light to dark, and the
// convergence beside it: measured and true largest error per part, and the floor (what a
// perfect table leaves under the same vibration).
struct LoopPlotPart {
  std::string label;       // e.g. "part 2 · v7"
  DegreeTable error_um{};  // measured lift error, cam frame
  double measured_max_um = 0.0;
  double true_max_um = 0.0;
  double floor_max_um = 0.0;
};

struct LoopPlot {
  std::string title;
  std::string subtitle;
  std::vector<LoopPlotPart> parts;  // in the order ground; at least one
  std::string footer;
};

// A self-contained SVG 1.1 document, 1200 x 640 px, like render_error_plot_svg. Pure.
// Precondition: every value is finite.
std::string render_loop_plot_svg(const LoopPlot& plot);

}  // namespace gaugeloop
