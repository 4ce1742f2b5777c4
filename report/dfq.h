// The AQDEF (Q-DAS ASCII transfer format) export: runs' characteristics as one .dfq file a
// plant's SPC system (qs-STAT, procella, ...) reads. docs/aqdef.md says which K-fields carry
// what and where the format description comes from.
#pragma once

#include <string>
#include <vector>

#include "core/result.h"
#include "core/run.h"
#include "core/tolerance.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Characteristic keys of the harmonics of the lift error: "harmonic.1" .. "harmonic.30".
inline constexpr std::string_view kHarmonicKeyPrefix = "harmonic.";
inline constexpr int kMaxDfqHarmonics = 30;

struct DfqOptions {
  // Harmonics 1..harmonics of the characteristics given (harmonic_characteristics) are
  // written; 0: none, whatever the runs carry. At most kMaxDfqHarmonics.
  int harmonics = 0;
  // K1086 (work cycle / operation) of every part block; empty: not written.
  std::string operation = "cam grinding";
};

// Harmonics 1..count (1 <= count <= kMaxDfqHarmonics) of a run's lift error as
// characteristics "harmonic.<k>": amplitude in um, no tolerance (not judged). Append them to
// a run's characteristics before write_dfq to export them.
std::vector<Characteristic> harmonic_characteristics(const LobeAnalysis& analysis, int count);

// The .dfq file of `runs` (any order; written oldest first, by started_utc then id).
//
// One part block per (part, lobe), in the order of each one's oldest run: K1001 the part
// name, K1002 "lobe N", K1081 the machine when all the block's runs share one, K1086 the
// operation. One characteristic per key present in the block's runs, in the order of the
// oldest run's characteristics and then new keys as they appear, numbered 1.. across the
// whole file (K0100 is their total); its unit and limits are those of the newest run that has
// it. Nominal 0 (every characteristic is an error or a figure whose ideal is 0). Runout,
// roundness and harmonics without a lower limit get the natural lower boundary 0.
// Per run and characteristic it has: K0001 value, K0002 0 (valid), K0004 started_utc as
// DD.MM.YYYY/HH:MM:SS (UTC), K0006 the run id, K0008 operator, K0010 machine, K0014 serial
// (the last three only when not empty). A run lacking one of its block's characteristics
// writes a placeholder for it: K0001 0, K0002 255.
//
// ASCII only, CRLF line ends, numbers with a '.' whatever the locale.
// kInvalidInput (naming the run and the field) for: no runs, a block without any
// characteristic (runs stored before tolerances), text outside printable ASCII or longer
// than its K-field allows, a value or limit that is not finite, one key with two units, a
// started_utc that is not "YYYY-MM-DDTHH:MM:SSZ", harmonics outside 0..kMaxDfqHarmonics.
Result<std::string> write_dfq(const std::vector<RunCharacteristics>& runs, const DfqOptions& options);

}  // namespace gaugeloop
