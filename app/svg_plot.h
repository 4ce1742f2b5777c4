// The lobe error of one run as an SVG picture: polar and linear, with the tolerance band.
#pragma once

#include <optional>
#include <string>

#include "core/run.h"

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

}  // namespace gaugeloop
