// Which error a stored run's verdicts judge, once for every view of the run (the run page and
// its plot, `runs plot`, `runs show`, the JSON, the cam report): the curve a picture draws its
// tolerance band around is the one the characteristics judged, named beside it.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "core/run.h"
#include "core/tolerance.h"
#include "storage/run_store.h"

namespace gaugeloop {

// The error a run's verdicts judge, with its figures.
struct JudgedError {
  enum class Basis {
    kBestFit,             // a lobe's lift error after the best-fit phase
    kNominal,             // a lobe's lift error at nominal timing, as its tolerances asked
    kNominalNoBestFit,    // at nominal timing: judged after best fit, but stored without that table
    kLeastSquaresCircle,  // a pin's radius error less the least-squares circle
  };
  Basis basis = Basis::kBestFit;
  // The judged curve, um, cam frame (pin degrees for a pin), index = degree.
  DegreeTable error_um{};
  // The error as measured at the nominal timing when the judged curve is another (a lobe
  // judged after the best-fit phase, a pin less its least-squares circle); empty otherwise.
  std::optional<DegreeTable> raw_error_um;
  // What the judged curve is, as a label reads: "lift error after the best-fit phase",
  // "lift error at nominal timing", "radius error less the least-squares circle".
  std::string name;
  // The short form the page's table and the plot's headline put beside a verdict:
  // "after best-fit phase", "at nominal timing", "less LS circle".
  std::string reference;
  double max_abs_um = 0.0;
  int max_abs_at_deg = 0;  // where, signed (signed_degree)
  double rms_um = 0.0;
  double peak_to_valley_um = 0.0;
};

// The judged error of `run`: a lobe's lift error as its tolerances named it (best fit or
// nominal), except a best-fit table of zeros beside a raw error that is not (a run stored before
// the best-fit error was kept), where the raw error is all there is; a pin's radius error less
// the least-squares circle (what roundness judges).
JudgedError judged_error(const StoredRun& run);

// The limits in force at each nose-centred degree x = -179..180 (index x + 179) for a figure
// ("lift_error"...): the whole turn's, narrowed by a zone's own where a zone with limits covers
// x (both are judged there), so that a value outside them is a value some verdict judged out.
using DegreeLimits = std::array<Limits, 360>;
DegreeLimits limits_per_degree(const std::vector<Characteristic>& characteristics, const std::string& figure);

// The same limits indexed by cam degree 0..359 (the frame of DegreeTable).
DegreeLimits limits_per_cam_degree(const std::vector<Characteristic>& characteristics, const std::string& figure);

// The short form of the curve a run's error characteristics judge ("after best-fit phase", "at
// nominal timing", "less LS circle"), as JudgedError::reference says it.
std::string_view judged_reference_text(PartKind kind, LiftErrorReference reference);

// Whether `key`'s figure is taken from the judged error curve (lift, velocity and acceleration
// error and their zones of a lobe; a pin's roundness), so that a view names the curve beside it.
bool judges_error_curve(const std::string& key, PartKind kind);

}  // namespace gaugeloop
