// What one measurement run is made of, from raw gauge samples to the lift error table.
// Shared by acquisition (produces samples), compensation (analyses) and storage (keeps).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace gaugeloop {

inline constexpr int kDegreesPerRevolution = 360;
// The same, as a count of table entries.
inline constexpr std::size_t kDegrees = static_cast<std::size_t>(kDegreesPerRevolution);

// One value per whole degree, index = degree in [0, 360).
using DegreeTable = std::array<double, kDegreesPerRevolution>;

// The one angle convention of every angle shown (charts, polar views, texts, JSON): a lobe's
// cam angle from the nose, a pin's angle from the crank radius outward, in (-180, 180], the
// opening side negative. A DegreeTable (and a per-degree CSV, as the drawing's lift tables)
// indexes the same angle taken modulo 360.
constexpr int signed_degree(int index) { return index > 180 ? index - kDegreesPerRevolution : index; }
constexpr int signed_degree(std::size_t index) { return signed_degree(static_cast<int>(index)); }
// The table index of a signed (or any whole) degree.
constexpr std::size_t degree_index(int degree) {
  return static_cast<std::size_t>(((degree % kDegreesPerRevolution) + kDegreesPerRevolution) % kDegreesPerRevolution);
}

// Gauge readings of one revolution of the work spindle, one per whole machine degree of C.
// Units: mm of gauge reading (probe lift), not yet zeroed.
struct RevolutionSamples {
  std::int64_t revolution = 0;  // the amplifier's revolution count, unwrapped
  DegreeTable lift_mm{};
};

// The raw result of acquisition: complete revolutions only, never mixed.
// Invariant: every revolution has all 360 degrees.
struct MeasuredRun {
  std::vector<RevolutionSamples> revolutions;
  std::int64_t polls = 0;                  // requests made to the gauge during the run
  std::int64_t reconnects = 0;             // times the link was re-established
  std::int64_t discarded_revolutions = 0;  // started but incomplete, thrown away
};

// The diagnosis of one averaged lobe against its design.
// Frame: cam frame, index = cam angle in whole degrees (0 at the nose).
struct LobeAnalysis {
  DegreeTable design_lift_mm{};  // what a flat probe should read on the design lobe
  DegreeTable mean_lift_mm{};    // average over revolutions, zeroed on the base circle
  DegreeTable spread_um{};       // per-degree standard deviation across revolutions
  DegreeTable error_um{};        // mean - design
  double zero_offset_mm = 0.0;   // gauge reading subtracted to zero the base circle
  double max_abs_error_um = 0.0;
  double rms_error_um = 0.0;
  double peak_to_valley_um = 0.0;
  double repeatability_um = 0.0;  // largest per-degree spread
  int revolutions = 0;            // averaged into the mean (0: not known, e.g. made by hand)
  // Inspection figures, as a cam inspection report gives them.
  double phase_error_deg = 0.0;                    // lobe rotation that best explains the error, least squares
  double base_circle_runout_um = 0.0;              // total indicator reading of the base circle
  std::array<double, 31> harmonic_amplitude_um{};  // |error| harmonics 0..30 (Eigen FFT)
  // The lift error after removing the best-fit phase (phase_error_deg), the profile error a
  // cam inspection report shows, and its figures; equal to error_um for a round design.
  DegreeTable residual_error_um{};
  double max_abs_residual_um = 0.0;
  double rms_residual_um = 0.0;
  double peak_to_valley_residual_um = 0.0;
  // The base circle over the base-circle window: peak to valley as a dial reads it, and
  // roundness (peak to valley after the least-squares circle).
  double dial_runout_um = 0.0;
  double roundness_um = 0.0;
};

}  // namespace gaugeloop
