// The lobe error of one run as an SVG picture: polar and linear, with the tolerance band.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/run.h"
#include "storage/run_store.h"

namespace gaugeloop {

struct ErrorPlot {
  std::string title;     // e.g. "Run 12 · intake_flat lobe 1 · grinder-1"
  std::string subtitle;  // e.g. "2026-11-22 02:34 UTC · pushed"
  // Lift error (measured - design), um, cam frame, index = cam degree (0 at the nose).
  DegreeTable error_um{};
  // Per-degree standard deviation across revolutions, um: drawn as a band around the error.
  std::optional<DegreeTable> spread_um;
  // The correction computed from the run, um, cam frame: drawn dashed when set.
  std::optional<DegreeTable> correction_um;
  // Symmetric tolerance: the band -t..+t is drawn and degrees outside it are marked. > 0.
  std::optional<double> tolerance_um;
  std::string footer;  // one line of small print (figures, database, settings hash)
};

// A self-contained SVG 1.1 document (no scripts, no external fonts or files), 1200 x 640 px,
// that prints on A4 landscape. Numbers use '.' whatever the C locale. Pure: no I/O.
// Precondition: every value is finite.
std::string render_error_plot_svg(const ErrorPlot& plot);

// A stored run's error plot as `runs plot` and the run page draw it: title, subtitle (time,
// status, serial and note) and the error, spread and correction curves. The tolerance band and
// the footer are the caller's.
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
