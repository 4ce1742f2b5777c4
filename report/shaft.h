// The shaft record of one serial number: every lobe of a camshaft, the newest run of it, its
// verdict and its index (angular position) error against the shaft's nominal layout.
//
// Where a lobe's nose stands on the machine. The part's kinematics put cam angle psi (cam
// frame, nose at 0) under the wheel at machine angle C = s * psi + c0 (s = rotation_sense,
// c0 = c_offset_deg: where the design nose stands); the gauge reads cam angle
// beta = s (C - c0 - probe_offset) (cam_angle_at_probe_deg), the same mapping seen from the
// probe, which lies probe_offset further on. A positive phase error phi means the measured
// lobe's features appear phi degrees later in cam angle than the design's: the measured nose
// is at cam angle psi = phi. Putting psi = phi into the kinematics, the measured nose stands at
//     C_nose = c0 + s * phi.
// The probe offset drops out: it shifts where the gauge reads, not where the nose is.
//
// Index error. The shaft file places lobe i at angle_i (degrees, in the sense of C) from the
// shaft's reference, which stands at C = reference_c_deg when the shaft is clamped, so its
// nominal nose is at C_nominal = reference_c_deg + angle_i and
//     index error_i = wrap(C_nose_i - C_nominal_i), wrapped to (-180, 180].
// Relative to the datum (the first lobe of the shaft file, d):
//     relative_i = wrap((C_nose_i - C_nose_d) - (angle_i - angle_d)) = wrap(error_i - error_d),
// which no longer holds reference_c_deg: an error in how the shaft was clamped (the C angle
// of its reference) moves every nose alike and cancels. The datum's own relative error is 0.
//
// Verdict words: a lobe is "in", "out" or "not_judged" (its run's verdict) or "not_measured"
// (no run of that part, lobe and serial). An index is "in" when |index error| <=
// index_tolerance_deg, "out" beyond it, "not_judged" without a tolerance or without the
// run's frame mapping or phase. The shaft is "out" if any lobe or index is out; "in" only
// when every lobe is measured and in and every index is in; "incomplete" when a lobe is not
// measured (and nothing is out); "not_judged" otherwise.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// One lobe of a shaft as its shaft file names it.
struct ShaftLobe {
  int lobe = 1;                     // lobe number (the part file's), unique on the shaft
  std::string part;                 // part name (the part file's)
  std::filesystem::path part_file;  // where it was read from
  double angle_deg = 0.0;           // nominal nose position from the shaft's reference, sense of C
};

// A camshaft: its lobes and their nominal angular positions.
struct ShaftLayout {
  std::string name;
  double reference_c_deg = 0.0;               // C angle of the shaft's reference when clamped
  std::optional<double> index_tolerance_deg;  // +- this on each lobe's index error; > 0
  std::vector<ShaftLobe> lobes;               // in the file's order; the first is the datum
};

// One lobe of one serial's shaft record.
struct ShaftLobeRecord {
  ShaftLobe lobe;
  std::optional<RunSummary> run;             // the newest run of the part, lobe and serial; empty: none
  std::string verdict;                       // "in", "out", "not_judged", "not_measured"
  std::optional<double> phase_deg;           // the run's phase error
  double nominal_c_deg = 0.0;                // reference_c_deg + angle_deg, wrapped to [0, 360)
  std::optional<double> nose_c_deg;          // c0 + s * phase, wrapped to [0, 360)
  std::optional<double> index_error_deg;     // (-180, 180]
  std::optional<double> relative_error_deg;  // to the datum lobe; (-180, 180]
  std::string index_verdict;                 // "in", "out", "not_judged"
  std::string note;                          // why the index is not given, if it is not
};

struct ShaftRecord {
  std::string serial;
  ShaftLayout layout;
  std::vector<ShaftLobeRecord> lobes;  // one per layout lobe, in its order
  std::string verdict;                 // "in", "out", "incomplete", "not_judged"
};

// `degrees` wrapped to (-180, 180].
double wrap_deg_180(double degrees);

// Where the run's measured nose stands on the work spindle, C = c0 + s * phase, against its
// nominal c0 (both wrapped to [0, 360)) (c_offset_deg: the design nose's C from the spindle's zero, where the
// part's datum is clamped). Empty without the run's frame mapping or phase.
struct NoseAngle {
  double nominal_c_deg = 0.0;
  double measured_c_deg = 0.0;
  double deviation_deg() const { return wrap_deg_180(measured_c_deg - nominal_c_deg); }
};
std::optional<NoseAngle> nose_angle(const StoredRun& run);

// The record from the newest run of each layout lobe (runs[i] for layout.lobes[i]; empty:
// not measured). A run's nose position needs its geometry (frame mapping) and its phase error
// (summary.phase_error_deg); without them its index is not given and `note` says why.
ShaftRecord shaft_record(const ShaftLayout& layout, const std::string& serial,
                         const std::vector<std::optional<StoredRun>>& runs);

// Reads the newest run of each lobe with that serial from the store (list_runs by serial,
// part and lobe, then load_run) and builds the record. kInvalidInput for an empty or
// malformed serial; the store's errors as they come.
Result<ShaftRecord> load_shaft_record(const RunStore& store, const ShaftLayout& layout, const std::string& serial);

// `runs shaft --json`: the record with null for what is not given.
nlohmann::json shaft_record_json(const ShaftRecord& record);

// `runs shaft --shaft FILE`: a heading naming the shaft, serial, reference, tolerance and datum;
// one row per lobe (lobe, part, run id, started, verdict, phase, index error, relative to the
// datum, index verdict; "-" for what is not given); the shaft verdict; a line per lobe whose
// index is not given, saying why.
std::string shaft_record_text(const ShaftRecord& record);

}  // namespace gaugeloop
