// Was the measured part ground with the table in force? The evidence its lift error gives.
#pragma once

#include <string>
#include <string_view>

#include "core/run.h"

namespace gaugeloop {

// What a part's lift error says about the table that ground it.
//
// The table in force changed the target by `change_um` (its correction minus the one it was
// built on). A part ground with that table differs from the part measured to build it by about
// that change (the machine follows a change of its path at the low harmonics compensation
// feeds back); the same part measured again, or a part ground before the table, differs from
// it only by the gauge's noise. So, with both errors smoothed to the harmonics compensation
// uses (0..max_harmonic):
//   difference_rms_um = RMS over the cam degrees of smooth(error_now - error_before)
//   change_rms_um     = RMS of the table's change
//   noise_rms_um      = what difference_rms_um would be from the gauge alone: the spread of
//                       each run's revolutions (sqrt(mean spread^2 / revolutions)), combined,
//                       scaled by sqrt((2 max_harmonic + 1) / 360) for the smoothing
// Verdict:
//   kCannotTell   change_rms_um < 3 noise_rms_um: the table changed the lobe by less than the
//                 gauge can tell apart from a re-measurement;
//   kNotGround    difference_rms_um < 0.5 change_rms_um: the part does not show half of the
//                 table's change: it was not ground with it (measured again, or older);
//   kGround       otherwise.
enum class TableEvidenceVerdict { kGround, kNotGround, kCannotTell };
std::string_view table_evidence_verdict_name(TableEvidenceVerdict verdict);  // "ground", "not ground", "cannot tell"

struct TableEvidence {
  TableEvidenceVerdict verdict = TableEvidenceVerdict::kCannotTell;
  double change_rms_um = 0.0;
  double difference_rms_um = 0.0;
  double noise_rms_um = 0.0;
  // One sentence with the three figures, for the report and the event.
  std::string describe() const;
};

// The runs compared: the part measured now, and the part measured to build the table in force.
struct MeasuredError {
  const DegreeTable* error_um = nullptr;   // analysis.error_um, cam frame
  const DegreeTable* spread_um = nullptr;  // analysis.spread_um
  int revolutions = 3;                     // >= 1
};

TableEvidence judge_table_evidence(const MeasuredError& now, const MeasuredError& before, const DegreeTable& change_um,
                                   int max_harmonic);

}  // namespace gaugeloop
