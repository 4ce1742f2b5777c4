// The run history as data: the JSON and CSV the `runs`, `events` and `nc` commands print and
// the HTTP API serves, built once here so both say the same thing, and the UTC time bounds both
// accept.
#pragma once

#include <ctime>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/pin.h"
#include "core/result.h"
#include "core/tolerance.h"
#include "core/utc_time.h"
#include "storage/run_store.h"

namespace gaugeloop {

// The value of `key` in a run's settings text ("key = value" lines, as the measure job writes
// them); empty if not there.
std::string run_setting(const std::string& settings, std::string_view key);

// What a stored run measured, told from its settings text (the lines `part.kind = pin` and
// `pin.mode = c-x` or `c-x-y`, as the measure job writes them): a lobe unless they say pin,
// so runs stored before pins, and runs without settings, read as lobes. No schema change: the
// settings are the run's record of what it was.
struct RunPart {
  PartKind kind = PartKind::kLobe;
  std::optional<PinMode> pin_mode;  // a pin's mode when its settings name a known one
  bool pin() const { return kind == PartKind::kPin; }
};
RunPart run_part(const StoredRun& run);

// The part's temperature at measurement as a run keeps it (the settings lines
// part.temperature_c and part.temperature_source, job/measure_job.cc): temperature_c empty when
// not given (runs stored before it was kept too), source "plc" or "operator".
struct RunPartTemperature {
  std::optional<double> temperature_c;
  std::string source;
};
RunPartTemperature run_part_temperature(const StoredRun& run);
// "21.4 °C (PLC)", "21.4 °C (operator)" or "not given"; `unit` after the number: "\u00b0C"
// on a page, "degC" on a terminal.
std::string part_temperature_text(const RunPartTemperature& t, std::string_view unit);

// One row of `runs list --json` and `runs trend --json`. Figures a run did not record (phase,
// runout, settings hash, prune time) are null.
nlohmann::json run_summary_json(const RunSummary& run);

// `runs show --json`: the summary plus the rest of the record, the worst degrees (cam frame;
// pin degrees for a pin), the frame mapping (null if not recorded), every push of the run
// (nc_push_json, oldest first), and what was measured: part_kind "lobe" or "pin" and, for a
// pin, pin_mode "c-x" or "c-x-y" (null if its settings name none); judged_error: the curve the
// error characteristics judge (judged_error: name, reference, max_abs_um, max_abs_at_deg,
// rms_um, peak_to_valley_um), and on each characteristic `judges`: that reference when its
// figure is of that curve, else null.
nlohmann::json run_detail_json(const StoredRun& run);

// One characteristic of a run against its tolerances: key, title, unit, value, min, max,
// lower_limit and upper_limit (null: none), verdict, from_deg and to_deg (null: not a zone).
// The title is the one for `kind` (characteristic_title).
nlohmann::json characteristic_json(const Characteristic& c, PartKind kind = PartKind::kLobe);
nlohmann::json characteristics_json(const std::vector<Characteristic>& characteristics,
                                    PartKind kind = PartKind::kLobe);

// One NC push as `nc history --json` and `runs show --json` list it, without the program text.
// Figures not recorded (pushes made by older versions) are null.
nlohmann::json nc_push_json(const NcPush& push);

// One pending table as `nc pending --json` lists it, without the program text.
nlohmann::json pending_table_json(const PendingTable& table);

// A gear run as `gear runs list --json` (with_traces false) and `gear runs show --json` and GET
// /api/gear-runs/{id} (with its traces: gap, flank, figures, z_mm, deviation_um) print it;
// null for what was not recorded.
nlohmann::json gear_run_json(const StoredGearRun& run, bool with_traces);

// One row of `events --json`; lobe and run_id are null when the event is not about one.
nlohmann::json event_json(const StoredEvent& event);

// `runs export`: RFC 4180 CSV, CRLF line ends, the header on the first line. One row per cam
// degree: design, each raw revolution, mean, spread, error, correction, then the run's identity
// (run_id, machine, part, lobe, started_utc, note) repeated on every row. Numbers are written
// with a decimal point whatever the locale; text fields are quoted when they need it. Raw
// revolutions are put in the cam frame when the run recorded its frame mapping, else kept in the
// machine frame and the columns say so. The columns do not depend on pruning: a pruned run keeps
// one revN column per recorded revolution, with empty fields. `comments` puts '#' lines saying
// the run, the frame and the units before the header (a spreadsheet reads them as data rows).
std::string run_csv(const StoredRun& run, bool comments = false);

// A time bound given by a person, UTC: "2026-11-22", "2026-11-22T08:30" or
// "2026-11-22T08:30:00Z" (a space for the T is fine). A bound covers its whole unit, so an
// `until` bound (exclusive in RunQuery and EventQuery) moves past it: until 2026-11-22 includes
// that day, until 2026-11-22T08:30 that minute. Empty text is no bound (empty result).
// kInvalidInput naming `name` (e.g. "--since") and saying what to write.
Result<std::string> time_bound(const std::string& text, bool until, std::string_view name);

// A command's --since and --until (time_bound) into a query's since_utc and until_utc; the
// first that is not a time is the error, and nothing is set then.
Status set_time_bounds(const std::string& since, const std::string& until, std::string& since_utc,
                       std::string& until_utc);

}  // namespace gaugeloop
