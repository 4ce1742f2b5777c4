// The run database: every measurement run, its analysis and its correction, kept in SQLite.
#pragma once

#include <cstdint>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "core/part.h"
#include "core/result.h"
#include "core/run.h"
#include "core/tolerance.h"

namespace gaugeloop {

namespace storage_internal {
struct Connection;  // SQLite connection; defined in storage/sqlite_db.h, never exposed
}  // namespace storage_internal

// Everything one run stores, written in one transaction by RunStore::insert_run.
// Timestamps are ISO 8601 UTC to the second, exactly "YYYY-MM-DDTHH:MM:SSZ", so that text
// order is time order.
struct RunRecord {
  std::string started_utc;   // "2026-11-22T02:34:44Z"
  std::string finished_utc;  // not earlier than started_utc
  // The run's global identity (core/uuid.h form); empty: a new one. Unique across the plant.
  std::string uuid;
  std::string machine;  // e.g. "grinder-1"; not empty
  std::string part;     // part name; not empty
  int lobe = 1;         // 1-based
  std::string gauge;    // gauge address, e.g. "tcp:127.0.0.1:1502"
  std::string note;     // operator note, may be empty
  // The measured part's serial number and the operator who measured it: free text, at most
  // 64 characters, no control characters (check_run_identity). Empty: not given (NULL).
  std::string serial;
  std::string operator_name;
  MeasuredRun measured;       // raw revolutions: >= 3, machine frame, amplifier revolution
                              // numbers strictly increasing, every value finite
  LobeAnalysis analysis;      // cam frame per-degree tables and summary figures, all finite
  DegreeTable correction_um;  // the correction computed from this run, cam frame, finite
  // The run whose correction was in force when the measured part was ground (it must be in
  // the database); empty: the part was ground from the design.
  std::optional<std::int64_t> correction_in_force_run;
  // The table version of the run's NC file that ground the measured part (>= 1; empty: the
  // design, or not known) and who said so: "plc", "option" (measure --ground-with),
  // "assumed" (the table in force when the run started) or "main_program" (the main program on
  // the control coupled an older table than the history's). Empty source with a version is
  // refused.
  std::optional<int> ground_with_version;
  std::string ground_with_source;
  // Measured only to inspect the part: correction_um is the correction in force, unchanged,
  // and nothing is pushed from the run.
  bool inspection = false;
  // The band of harmonics the correction fed back, 0..harmonics_fed_back (0..180), and the
  // amplitude a harmonic had to exceed to count as measured (um, >= 0; empty: the band was
  // fixed, or the revolutions showed no spread). Empty for an inspection.
  std::optional<int> harmonics_fed_back;
  std::optional<double> harmonic_threshold_um;
  // The settings the run was made with, as canonical "key = value" lines (part geometry,
  // analysis, compensation, poller, table step...): stored once per distinct text and named
  // by settings_hash(text), so two runs made alike show the same hash. Empty: not recorded.
  std::string settings;
  // The part as measured. If set, its follower and radii update the parts catalogue, and its
  // frame mapping (rotation_sense, c_offset_deg, probe_offset_deg) is kept with the run and
  // updates the lobes catalogue; `runs export` uses it to put revolutions in the cam frame.
  // name and lobe are ignored (the record's own part and lobe count).
  std::optional<Part> geometry;
  // The run's characteristics against the part's tolerances (judge_lobe), keys unique, every
  // figure and limit finite; and the run's verdict (combined_verdict of theirs).
  std::vector<Characteristic> characteristics;
  Verdict verdict = Verdict::kNotJudged;
  // Which lift error the lift, velocity and acceleration characteristics judged.
  LiftErrorReference lift_error_reference = LiftErrorReference::kBestFit;
};

// 16 lower-case hex digits of the 64-bit FNV-1a hash of `text`: names a settings text. Not a
// cryptographic hash; it tells settings apart, it does not guard them.
std::string settings_hash(std::string_view text);

// A serial number or operator name as a run keeps it: empty (not given), or 1 to 64
// characters of valid UTF-8 without control characters. kInvalidInput naming `what` (the
// option or field the value came from, e.g. "--serial") and what to change otherwise.
Status check_run_identity(std::string_view what, std::string_view value);

// One row of the run list.
struct RunSummary {
  std::int64_t id = 0;
  std::string uuid;  // the run's global identity (every run has one from schema 9 on)
  std::string started_utc;
  std::string machine;
  std::string part;
  int lobe = 1;
  std::string status;        // "measured", or "pushed" once an NC file was written
  int revolutions = 0;       // complete revolutions stored
  int degrees_captured = 0;  // samples stored: revolutions * 360
  double max_abs_error_um = 0.0;
  double rms_error_um = 0.0;
  double repeatability_um = 0.0;
  std::string nc_file;  // the NC program last pushed from this run; empty if none
  // Empty for runs stored before schema version 2, which did not compute them.
  std::optional<double> phase_error_deg;
  std::optional<double> base_circle_runout_um;
  double peak_to_valley_um = 0.0;
  std::string settings_hash;              // empty: not recorded
  std::string note;                       // operator note
  std::string raw_pruned_utc;             // when prune removed the raw samples; empty: still stored
  std::string serial;                     // the part's serial number; empty: not given (or before schema 7)
  std::string operator_name;              // who measured; empty: not given (or before schema 7)
  Verdict verdict = Verdict::kNotJudged;  // not judged for runs stored before schema 8
  // Which lift error the lift characteristics judged; empty where the history does not say
  // (the plant's central history).
  std::optional<LiftErrorReference> lift_error_reference;
};

// What a curve table is, as kept with each push, pending table and push journal entry.
// Empty optionals and interpolation: unknown (recorded before schema version 2 or 3, by
// record_nc_file, or not said).
struct TableFacts {
  std::string interpolation;                // "linear", "cspline"
  std::optional<int> block_count;           // table blocks in the program; >= 0
  std::optional<double> command_error_um;   // the table's command position error; finite, >= 0
  std::optional<int> point_count;           // points of the table (blocks + 1 for a spline's start)
  std::optional<double> correction_max_um;  // the largest |correction| the table carries
};

// One NC program written to the control from a run, as nc_pushes keeps it.
struct NcPush {
  std::int64_t id = 0;  // read back (nc_pushes.id: push order); ignored when recording
  std::string uuid;     // read back: the push's global identity; ignored when recording (a new one)
  // Read back; when recording, the run is an argument. 0: none, a program written from a
  // drawing (gaugeloop nc new) before any part was measured.
  std::int64_t run_id = 0;
  std::string pushed_utc;  // ISO 8601 UTC; empty when recording: now
  std::string nc_file;     // not empty; compared as text, so give every push of a file the same path
  // 1, 2, 3... per nc_file in push order: the version the program's header carries. When
  // recording: 0 takes the next one (record_nc_file does); any other value must be
  // next_table_version(nc_file), so two writers cannot both claim a version.
  int table_version = 0;
  // Why it was pushed: "run 12", "approved by anna", "rollback to version 3". When recording,
  // empty: "run <run id>". Empty for pushes recorded before schema version 3.
  std::string reason;
  TableFacts table;
  std::string program_hash;  // settings_hash() of the program text; empty if unknown
  // The whole program as written, byte for byte, so a diff or a rollback never depends on the
  // file on the control. Unset when not recorded (pushes before schema version 3, or without
  // text), and always unset in list_pushes and load_run results (load_push, last_push read it).
  std::optional<std::string> program_text;
};

// One file of a push, recorded with its intent: the table itself, its main program, its speed
// subprogram, a crankpin's Y table. Reconciliation and `nc check` compare every file on the
// control with the push last recorded, not the table alone, and put back the ones left from
// another push of ours.
// kCec: the slides' CEC file beside their LEC file (job/slide_files.h), pushed as one version.
enum class PushFileRole { kTable, kMain, kSpeed, kY, kCec };
std::string_view push_file_role_name(PushFileRole role);  // "table", "main", "speed", "y", "cec"

struct PushFile {
  PushFileRole role = PushFileRole::kTable;
  std::string path;  // as nc_file: give every push the same path
  std::string hash;  // settings_hash() of the text; begin_push computes it from text
  // The text as written, kept so that reconciliation can put the file back (the table's is the
  // push's program_text: not repeated here). Read back checked against hash.
  std::optional<std::string> text;
  int table_version = 0;  // read back: the version of the push that wrote it
};

// The ids a run database has handed out, kept outside it, beside it (<db>.ids, written atomically
// after a run is stored and after a push is recorded), so that commits the database lost are
// noticed: its write-ahead log deleted after a commit, or the file restored from an older copy.
struct IdMarks {
  std::int64_t run_id = 0;   // the highest run id handed out
  std::int64_t push_id = 0;  // the highest push id handed out
};

// <db>.ids.
std::filesystem::path id_marks_path(const std::filesystem::path& db_path);

// Commits a database lost: what <db>.ids says was handed out, what the database holds.
struct LostCommits {
  IdMarks marked;
  IdMarks held;
};

// "run database D lost commits: D.ids says run ids up to 12 and push ids up to 7 were handed
// out, the database holds them up to 10 and 6 (...); runs 11 to 12 and push 7 are not in the
// history"
std::string lost_commits_text(const std::filesystem::path& db_path, const LostCommits& lost);

// A push in the journal: recorded (begin_push) before its program is renamed into place on
// the control, and resolved after: completed (complete_push: the nc_pushes row) or abandoned
// (abandon_push: the control never got it). One intent at most is open per file.
struct PushIntent {
  std::int64_t id = 0;      // read back; ignored by begin_push
  std::string created_utc;  // read back; begin_push: now
  std::int64_t run_id = 0;  // the run whose table it is, stored; 0: none (nc new)
  // What the push records once completed. nc_file, table_version (the file's next version)
  // and program_text are required; reason empty: "run <run_id>".
  NcPush push;
  // An approval: the pending table it writes, who approved it and their note. Completing
  // it marks that table approved when it is still pending (else only the push is recorded).
  std::optional<std::int64_t> pending_id;
  std::string approved_by;
  std::string note;
  // Every file the push writes besides the table (the table is recorded from push). Read back
  // only by push_files_of.
  std::vector<PushFile> files;
};

// What completing an intent recorded.
struct PushCompletion {
  std::int64_t push_id = 0;
  int table_version = 0;
  bool decision_recorded = true;  // approval: false if the table had stopped being pending
};

// Filters for list_pushes; newest first (by push order).
struct PushQuery {
  int limit = 50;       // at most this many; >= 1
  std::string nc_file;  // exact path as recorded; empty = any
  std::string machine;  // of the run pushed; empty = any
  std::string part;     // of the run pushed; empty = any
  int lobe = 0;         // of the run pushed; 0 = any
};

// Why a rendered table waits instead of being written.
enum class PendingVerdict {
  kApply,  // compensation would apply it; it waits only for a person's approval
  kHold,   // compensation held it (see reason); a person may still approve it
};
std::string_view pending_verdict_name(PendingVerdict verdict);  // "apply", "hold"

// Lifecycle of a pending table: kPending -> kApproved (record_approved_push) | kRejected
// (reject_pending) | kSuperseded (add_pending of a newer table for the same nc_file). Only
// kPending changes; the other three are final.
enum class PendingStatus { kPending, kApproved, kRejected, kSuperseded };
std::string_view pending_status_name(PendingStatus status);  // "pending", "approved", ...

// A rendered NC program that was not written to the control, kept in nc_pending until a person
// approves or rejects it. At most one table per nc_file is pending: the newest measurement.
struct PendingTable {
  std::int64_t id = 0;      // read back; ignored by add_pending
  std::int64_t run_id = 0;  // the run it was computed from; must be stored (0 with gear_run_id)
  // A gear's stroke program: the gear run it was corrected from, stored; 0: a lobe's table.
  // Exactly one of run_id and gear_run_id is set (schema 13).
  std::int64_t gear_run_id = 0;
  std::string created_utc;   // ISO 8601 UTC; empty when adding: now
  std::string nc_file;       // where it would be written; not empty
  std::string program_text;  // the program as rendered; not empty. Empty in list_pending results.
  // A lobe ground at a work speed program: the speed subprogram rendered with the table
  // (table_version 0), which approving the table writes beside it. Empty in list_pending
  // results, for other tables and for tables kept before schema 16.
  std::optional<std::string> speed_program_text;
  PendingVerdict verdict = PendingVerdict::kApply;
  std::string reason;  // why it waits: "approval required", or the reasons compensation held it
  TableFacts table;
  // Read back; ignored by add_pending.
  PendingStatus status = PendingStatus::kPending;
  std::string decided_utc;                    // when it left kPending; empty while pending
  std::string decided_by;                     // who approved or rejected it; empty otherwise
  std::string note;                           // their note; may be empty
  std::optional<std::int64_t> push_id;        // kApproved: the nc_pushes row it became
  std::optional<std::int64_t> superseded_by;  // kSuperseded: the newer pending table
};

// Filters for list_pending; newest first.
struct PendingQuery {
  int limit = 50;                       // >= 1
  std::optional<PendingStatus> status;  // empty = any
  std::string nc_file;                  // empty = any
};

// A run as read back. Per-degree tables (raw lifts, profile, correction) are kept as counts
// of 0.1 nm and come back to within 0.05 nm (5e-8 mm, 5e-5 um) of what was written; every
// other number comes back exactly as written.
struct StoredRun {
  RunSummary summary;
  // Machine frame, in the order measured. Empty once pruned (summary.raw_pruned_utc set).
  std::vector<RevolutionSamples> revolutions;
  LobeAnalysis analysis;        // cam frame
  DegreeTable correction_um{};  // cam frame
  // The rest of the record, for reports.
  std::string finished_utc;
  std::string gauge;
  std::string note;
  std::int64_t polls = 0;
  std::int64_t reconnects = 0;
  std::int64_t discarded_revolutions = 0;
  std::optional<std::int64_t> correction_in_force_run;
  std::optional<int> ground_with_version;  // as RunRecord; empty before schema version 5
  std::string ground_with_source;
  bool inspection = false;
  // As RunRecord; empty for runs stored before schema 17.
  std::optional<int> harmonics_fed_back;
  std::optional<double> harmonic_threshold_um;
  std::string settings;  // the text settings_hash names; empty if not recorded
  // The frame mapping and geometry the run was measured with; empty if not recorded.
  // Only follower, radii, rotation_sense, c_offset_deg and probe_offset_deg are filled.
  std::optional<Part> geometry;
  std::vector<NcPush> pushes;  // oldest first, without program_text
  // As RunRecord; empty for runs stored before schema 8. The verdict is summary.verdict.
  std::vector<Characteristic> characteristics;
  LiftErrorReference lift_error_reference = LiftErrorReference::kBestFit;
};

// A run whose raw samples `runs prune` removed, and when (runs.raw_pruned_utc).
struct PrunedRun {
  std::int64_t id = 0;
  std::string uuid;
  std::string pruned_utc;
};

// A run's summary and its characteristics, for SPC, the AQDEF export and shafts.
struct RunCharacteristics {
  RunSummary run;
  std::vector<Characteristic> characteristics;  // in the order stored
};

// One characteristic over the runs a query selects, summed up by the database that holds them
// (runs spc): what the SPC figures are made of, without reading the runs one by one.
struct CharacteristicSummary {
  std::string key;
  std::string unit;  // as the newest run that has the key stored it
  int n = 0;         // runs that have the key (>= 1)
  // The mean, and the sum of the squared deviations from it (+inf for values too far apart):
  // two passes over the values. The file sums value / n (no sum of large values overflows
  // before the division); PostgreSQL takes avg() and refuses a sum that would overflow.
  double mean = 0.0;
  double squares = 0.0;
  bool all_equal = false;  // every value the same: the mean is that value exactly
  Limits limits;           // of the newest run that has the key
  std::int64_t limits_from_run = 0;
  bool limits_changed = false;  // some older run had other limits
  int out_count = 0;
  int judged_count = 0;  // verdict in or out
};

struct CharacteristicSummaries {
  int runs = 0;  // the runs selected, with or without characteristics
  std::string first_started_utc;
  std::string last_started_utc;
  // In the order the keys first appear: the oldest run first, then the position in the run.
  std::vector<CharacteristicSummary> by_key;
};

// Filters for list_runs and trend. Times are ISO 8601 UTC, "YYYY-MM-DDTHH:MM:SSZ".
struct RunQuery {
  int limit = 50;                  // at most this many runs; must be >= 1
  std::string part;                // exact part name; empty = any part
  int lobe = 0;                    // 0 = any lobe
  std::string machine;             // exact machine name; empty = any
  std::string serial;              // exact serial number (no wildcards, case counts); empty = any
  std::optional<Verdict> verdict;  // the run's verdict; empty = any
  std::string status;              // "measured" or "pushed"; empty = any
  int ground_with_from = 0;        // only parts ground with this table version or a later one; 0 = any
  std::string since_utc;           // started at or after; empty = no bound
  std::string until_utc;           // started before (exclusive); empty = no bound
};

// kInvalidInput, with the message every history gives, for a query no history can answer: a
// limit below 1, a negative lobe, a status other than measured/pushed, a malformed time bound.
// RunStore and the central history check every query with it.
Status check_run_query(const RunQuery& q);

// A gear measured on a gear checker (schema 12; docs/gears.md, "Gear runs"): its lead traces
// and what ISO 1328-1 makes of them. Gear runs have ids of their own (gear run 1, 2, ...),
// apart from the lobe runs'.
struct GearTraceRecord {
  int gap = 0;              // the tooth gap, 1-based
  std::string flank;        // "left" or "right"
  double total_um = 0.0;    // F_beta
  double form_um = 0.0;     // f_f_beta
  double slope_um = 0.0;    // f_H_beta, signed
  int tolerance_class = 0;  // of F_beta: 1 to 11, 12 beyond class 11
  double from_mm = 0.0;     // the evaluation range along Z
  double to_mm = 0.0;
  std::vector<double> z_mm;          // the trace across the face, increasing
  std::vector<double> deviation_um;  // one per z_mm
};

// A profile trace at the face's middle and its ISO 1328-1 figures (schema 21).
struct GearProfileRecord {
  int gap = 0;                // the tooth gap, 1-based
  std::string flank;          // "left" or "right"
  double total_um = 0.0;      // F_alpha
  double form_um = 0.0;       // f_f_alpha
  double slope_um = 0.0;      // f_H_alpha, signed
  int tolerance_class = 0;    // of F_alpha: 1 to 11, 12 beyond class 11
  double from_roll_mm = 0.0;  // the evaluation range along the roll length
  double to_roll_mm = 0.0;
  std::vector<double> roll_mm;       // the trace from the root towards the tip, increasing
  std::vector<double> deviation_um;  // one per roll_mm
};

struct GearRunRecord {
  std::string started_utc;  // ISO 8601 UTC
  std::string machine;
  std::string part;
  std::string source;  // where the traces came from: the checker, a file
  std::string serial;  // empty: not given
  std::string operator_name;
  std::string note;
  std::string nc_file;                       // the stroke program the gear was ground from
  std::optional<int> ground_with_version;    // that program's version; empty: not known
  std::optional<int> required_class;         // the drawing's flank tolerance class; empty: not judged
  std::optional<double> total_tolerance_um;  // F_betaT of required_class for this gear
  Verdict verdict = Verdict::kNotJudged;     // every flank's F_beta within required_class's tolerance
  int tolerance_class = 0;                   // of the worst flank's F_beta
  double total_max_um = 0.0;                 // of the flanks' F_beta
  double total_mean_um = 0.0;
  double form_mean_um = 0.0;
  double slope_mean_abs_um = 0.0;
  std::vector<GearTraceRecord> traces;  // at most one per gap and flank
  // The profiles measured with the leads (none: not measured, as by a flank probe that traces
  // leads only), at most one per gap and flank; with a required class, the verdict holds every
  // F_alpha to profile_tolerance_um too.
  std::vector<GearProfileRecord> profiles;
  std::optional<double> profile_tolerance_um;  // F_alphaT of required_class; only with profiles
};

struct StoredGearRun {
  std::int64_t id = 0;
  GearRunRecord record;
  std::optional<int> pushed_version;           // the stroke version pushed from this gear; empty: none
  std::optional<double> mesh_residual_rms_um;  // of the identification that pushed it
};

// Filters for list_gear_runs; as RunQuery's.
struct GearRunQuery {
  int limit = 50;
  std::string part;
  std::string machine;
  std::string serial;
  std::optional<Verdict> verdict;
  std::string since_utc;
  std::string until_utc;
};

enum class EventKind {
  kFault,    // something failed: the gauge, the database, the NC directory...
  kRefusal,  // a guard or the geometry refused: a correction too large, a lobe not grindable
  kInfo,     // a step worth keeping: a PLC request, a cycle's outcome, a config reload (schema 4)
};
std::string_view event_kind_name(EventKind kind);  // "fault", "refusal", "info"
// kRefused is a refusal; every other code a fault.
EventKind event_kind_for(ErrorCode code);

// A fault or refusal worth keeping, usually one that stopped a run (so no run row holds it),
// or a step of the service (kInfo) that someone may ask about later.
struct EventRecord {
  std::string at_utc;  // ISO 8601 UTC; empty when recording: now
  std::string uuid;    // the event's global identity; empty when recording: a new one
  EventKind kind = EventKind::kFault;
  std::string code;  // error_code_name() of the error, e.g. "gauge timeout"
  std::string machine;
  std::string part;
  int lobe = 0;                        // 0: not about one lobe
  std::optional<std::int64_t> run_id;  // the run it concerns, if one was stored
  std::string message;                 // the error message as the user saw it; not empty
};

struct StoredEvent {
  std::int64_t id = 0;
  EventRecord event;
  // The UUID of event.run_id's run, read by events_after for the central history (its key for
  // the run); empty: no run, or the run is no longer in the file.
  std::string run_uuid;
};

struct EventQuery {
  int limit = 50;  // newest first, at most this many; >= 1
  std::string machine;
  std::string part;
  std::optional<EventKind> kind;
  std::string since_utc;  // inclusive
  std::string until_utc;  // exclusive
};

// How thoroughly RunStore::check_integrity reads the file. Both read every page.
enum class IntegrityCheck {
  kQuick,  // PRAGMA quick_check: b-tree pages, records, NOT NULL; O(pages). Before a run.
  kFull,   // PRAGMA integrity_check: also that every index matches its table and UNIQUE holds;
           // O(rows log rows). `gaugeloop db check`, the service's check beside the runs, every backup.
};

// The newest run (by started_utc, then id, as list_runs orders) of one machine, part and lobe.
struct LobeLastRun {
  std::string machine;
  std::string part;
  int lobe = 1;
  std::int64_t run_id = 0;
  std::string started_utc;
  double max_abs_error_um = 0.0;
  Verdict verdict = Verdict::kNotJudged;
};

// What the service's /metrics shows of the database, read in one snapshot.
struct StoreMetrics {
  // Runs by status: "measured" and "pushed" always present (0 when none).
  std::map<std::string, std::int64_t> runs_by_status;
  // Events by event_kind_name(): "fault", "refusal" and "info" always present.
  std::map<std::string, std::int64_t> events_by_kind;
  // Runs by verdict_name(): "in", "out" and "not_judged" always present; runs stored before
  // schema 8 count as not judged.
  std::map<std::string, std::int64_t> runs_by_verdict;
  std::int64_t pending_tables = 0;  // NC tables waiting for approval (status pending)
  // One entry per machine, part and lobe ever measured, ordered by machine, part, then lobe.
  std::vector<LobeLastRun> last_runs;
};

// ---- the plant (schema 9): messages for the broker and replication to the central history ----

// Whether runs and pushes queue plant messages, and how many may wait.
struct OutboxSettings {
  bool enabled = false;             // set by a service with a broker configured
  std::int64_t max_depth = 100000;  // >= 1; past it the oldest waiting message is dropped and counted
};

// One message waiting in the outbox, oldest first (delivery order).
struct OutboxMessage {
  std::int64_t id = 0;       // delivery order; what outbox_delivered takes
  std::string uuid;          // the message's identity: a consumer drops a second delivery by it
  std::string topic;         // "run", "nc", "verdict", "state"
  std::int64_t run_id = 0;   // run, verdict: the run; nc: the push's run; state: 0
  std::int64_t push_id = 0;  // nc: the push; otherwise 0
  std::string created_utc;   // when the record was stored
  std::string payload;       // verdict, state: the JSON to publish; run, nc: empty (made from the record)
};

// The outbox as /metrics and health show it.
struct OutboxCounts {
  OutboxSettings settings;
  std::int64_t depth = 0;          // messages waiting
  std::int64_t sent_total = 0;     // acknowledged and deleted, ever
  std::int64_t dropped_total = 0;  // dropped over max_depth, ever
  std::string oldest_utc;          // created_utc of the oldest waiting; empty when none
};

// A push as replicated: the push with its run's identity and machine.
struct ReplicatedPush {
  NcPush push;
  std::string run_uuid;
  std::string machine;
};

// What RunStore::open did to a file written by an older gaugeloop.
struct SchemaUpgrade {
  int from_version = 0;          // the file's schema version before (>= 1)
  std::filesystem::path backup;  // the copy of the file as it was, written before migrating
};

// The run database on one file. Owns one SQLite connection.
// Thread: use one RunStore per thread; any number of stores (threads or processes) may open
// the same file. The database runs in WAL mode, so readers are never blocked by a writer;
// a writer waits up to 5 s for another writer before failing with kStorage.
// Movable, not copyable; a moved-from store may only be destroyed or assigned to.
// Errors: kStorage for anything SQLite refuses (the message names the operation, the file
// and SQLite's reason), kIo if the directory cannot be created, kInvalidInput for a record
// or query that breaks the contracts above, kNotFound for an unknown run id, push or pending
// table, kRefused for a decision on a pending table that is no longer pending.
// The queries a run history answers, whichever database holds it: the local file (RunStore)
// or the plant's central history in PostgreSQL (plant/). Same filters, same rows, in the same
// order, so every query command prints the same whichever it reads.
class RunHistory {
 public:
  virtual ~RunHistory() = default;
  virtual Result<std::vector<RunSummary>> list_runs(const RunQuery& q) const = 0;
  virtual Result<std::vector<RunSummary>> trend(const RunQuery& q) const = 0;
  // The runs q selects, oldest first, each with its characteristics in the order stored; with a
  // key, only that characteristic (a trend plot's one line: a run without it has none).
  virtual Result<std::vector<RunCharacteristics>> characteristics(const RunQuery& q, const std::string& key) const = 0;
  Result<std::vector<RunCharacteristics>> characteristics(const RunQuery& q) const { return characteristics(q, {}); }
  // Over the same runs as characteristics(q), each key summed up: the file reads the window's
  // characteristics in one statement and sums them up as they come, PostgreSQL sums them up
  // itself, so the rows never cross the network.
  virtual Result<CharacteristicSummaries> characteristic_summaries(const RunQuery& q) const = 0;
};

class RunStore : public RunHistory {
 public:
  // Opens (creating the parent directories and the file if need be) and brings the schema
  // up to date. ":memory:" opens a private in-memory database. A database written by a
  // newer gaugeloop (higher schema version) is refused.
  // A file with no write permission bits at all (0444) is refused for root too: such a file
  // is treated as frozen (see open_read_only).
  // A file at an older schema version (1 or more) holding a run or an event is first copied with SQLite's online backup
  // API to "<db_path>.schema<N>-backup-<YYYYMMDDTHHMMSSZ>" (a "-2", "-3"... suffix if that
  // name is taken), the copy checked with integrity_check, and only then upgraded; if the
  // copy fails, nothing is upgraded and the error says why. schema_upgrade() names the copy.
  static Result<RunStore> open(const std::filesystem::path& db_path);

  // Opens an existing database for reading only: never creates, migrates or writes the file,
  // so it works on a file without write permission and in a read-only directory or mount.
  // With no write-ahead log beside it (no "-wal" with content, no "-shm") and either no write
  // permission bits on the file or a directory this process cannot write, the file is opened
  // immutable (no lock, no -shm or -wal created): nothing can be writing it, since a writer
  // needs the -wal, and open() refuses a file without write permission bits.
  // Errors: kNotFound if there is no file; kStorage for a file SQLite cannot read, a file
  // without a gaugeloop schema, an older schema (the message names `gaugeloop db upgrade`)
  // or a newer one. Writing through the store fails with kStorage.
  static Result<RunStore> open_read_only(const std::filesystem::path& db_path);

  // Reads the whole file (see IntegrityCheck), then PRAGMA foreign_key_check. A damaged file
  // is kStorage: "database <file> is damaged: <the first problems>; ..." saying to restore the
  // last sound backup. Call before measuring, so that no run is built on, or stored into, a
  // damaged file. kQuick takes about as long as reading the file once. On a store opened
  // read-only the CHECK constraints are not verified (SQLite does not load them there).
  Status check_integrity(IntegrityCheck depth = IntegrityCheck::kQuick) const;

  // After open(): what it upgraded, and the copy it made first; empty if the schema was
  // already the latest or the file was new.
  std::optional<SchemaUpgrade> schema_upgrade() const;

  RunStore(RunStore&& other) noexcept;
  RunStore& operator=(RunStore&& other) noexcept;
  RunStore(const RunStore&) = delete;
  RunStore& operator=(const RunStore&) = delete;
  ~RunStore();

  // Stores the whole record with status "measured" and returns its id. All or nothing: on
  // any error no row of the run is left behind. The record is validated before anything is
  // written; a non-finite value is kInvalidInput naming the table, column and degree.
  Result<std::int64_t> insert_run(const RunRecord& run);

  // Marks the run "pushed" and remembers the NC program written from it (replacing any
  // earlier one as the run's nc_file), and records the push (time: now, the next table version
  // of the file, reason "run <id>") in nc_pushes.
  // kNotFound if there is no such run; kInvalidInput if nc_path is empty.
  Status record_nc_file(std::int64_t run_id, const std::string& nc_path);

  // As record_nc_file, with what was pushed (see NcPush): table version, reason, interpolation,
  // blocks, command position error, point count, largest correction, and the program text
  // (`program_text`, or push.program_text if that is empty), kept whole with its hash.
  // One transaction. kInvalidInput if push.table_version is neither 0 nor the file's next
  // version (another push claimed it since the caller asked next_table_version: nothing is
  // recorded, and the file the caller wrote carries a version that is not its own), or for a
  // negative count or non-finite figure. Pending tables are not touched.
  Status record_push(std::int64_t run_id, const NcPush& push, std::string_view program_text = {});

  // The version the next push to `nc_file` gets: 1 + the highest recorded (1 if none). Ask
  // before rendering, as the program's header carries it. kInvalidInput for an empty path.
  Result<int> next_table_version(const std::string& nc_file) const;

  // Pushes newest first (by push order), without program_text (load_push has it).
  // kInvalidInput for a limit below 1 or a negative lobe.
  Result<std::vector<NcPush>> list_pushes(const PushQuery& q) const;

  // One push of a file, with program_text. kNotFound names the file, the version and the
  // versions the file has.
  Result<NcPush> load_push(const std::string& nc_file, int table_version) const;

  // The newest push of a file (the program the control should hold), with program_text;
  // empty if the file was never pushed.
  Result<std::optional<NcPush>> last_push(const std::string& nc_file) const;

  // Every NC file a program was pushed to, as recorded, in name order.
  Result<std::vector<std::string>> pushed_files() const;

  // The push with nc_pushes.id `push_id`, without program_text; empty if there is none.
  Result<std::optional<NcPush>> push_by_id(std::int64_t push_id) const;

  // Keeps a rendered table that was not written and returns its id. In the same transaction,
  // a table still pending for the same nc_file becomes kSuperseded (superseded_by: the new
  // one, decided_utc: its created_utc): only the newest measurement can be approved.
  // kNotFound if the run is not stored; kInvalidInput for an empty nc_file or program_text,
  // a malformed time, a negative count or a non-finite figure.
  Result<std::int64_t> add_pending(const PendingTable& table);

  // Pending tables newest first, without program_text. kInvalidInput for a limit below 1.
  Result<std::vector<PendingTable>> list_pending(const PendingQuery& q) const;

  // One pending table with its program_text. kNotFound if absent.
  Result<PendingTable> load_pending(std::int64_t id) const;

  // kPending -> kRejected, by `by` (not empty) with `note`, now. kRefused, naming its status,
  // if the table is no longer pending (nothing changes); kNotFound if absent.
  Status reject_pending(std::int64_t id, const std::string& by, const std::string& note);

  // Approving a table is writing it: the caller checks the table is still pending
  // (load_pending), writes the program to the control, then calls this, which in one
  // transaction records the push (as record_push, for the pending table's run) and marks the
  // table kApproved by `by` (not empty) with `note`, pointing at the push. Fields left unset
  // in `push` come from the pending table: nc_file, interpolation, block_count,
  // command_error_um, correction_max_um, point_count and program_text (pass the text actually
  // written if it differs, e.g. a header carrying the table version); reason defaults to
  // "approved by <by>". kInvalidInput if push.nc_file names another file, or as record_push.
  // kRefused, naming its status, if the table stopped being pending since it was checked
  // (rejected, or superseded by a newer measurement): then nothing is recorded, and the
  // caller, which already wrote the file, must still record that push with record_push so
  // the history matches the control.
  Status record_approved_push(std::int64_t pending_id, const NcPush& push, const std::string& by,
                              const std::string& note = {});

  // The push journal (see PushIntent). begin_push records the intent durably, in one
  // transaction, and returns its id: kRefused if another intent is open for the file (a push
  // under way or interrupted: reconcile it first), kInvalidInput if push.table_version is not
  // the file's next version or the text is empty, kNotFound if the run is not stored.
  Result<std::int64_t> begin_push(const PushIntent& intent);
  // In one transaction: records the push (as record_push, or record_approved_push for an
  // approval), and marks the intent completed with `resolution` (e.g. "written"). kRefused if
  // the intent is not open.
  Result<PushCompletion> complete_push(std::int64_t intent_id, const std::string& resolution);
  // Marks an open intent abandoned (the control does not hold its program), saying why.
  Status abandon_push(std::int64_t intent_id, const std::string& resolution);
  // Open intents, oldest first, with program_text; of one file, or of every file if empty.
  Result<std::vector<PushIntent>> open_push_intents(const std::string& nc_file = {}) const;
  // The files the last completed push of `nc_file` recorded (the table first, with its hash
  // and without text), with their texts checked against their hashes (kStorage names a
  // damaged one). Empty for a file never pushed, or last pushed before pushes recorded their
  // files.
  Result<std::vector<PushFile>> files_of_last_push(const std::string& nc_file) const;
  // The same for the push of `table_version` of `nc_file` (a rollback writes its files again);
  // empty when it recorded none.
  Result<std::vector<PushFile>> files_of_push(const std::string& nc_file, int table_version) const;
  // The newest push of ours (completed or abandoned) that wrote `hash` to `path`, as a file of
  // any role: its table version; empty when none did (a file edited by hand, or not ours).
  Result<std::optional<int>> version_that_wrote(const std::string& path, const std::string& hash) const;

  // Writes the ids handed out so far (the AUTOINCREMENT sequences of runs and pushes) to
  // id_marks_path(path()), atomically; nothing for an in-memory database. kIo if it cannot.
  Status mark_ids() const;
  // <db>.ids against the database. When it marks ids the database no longer holds, in one
  // transaction: the sequences are raised past the marks (no run or push id is handed out
  // twice) and a fault event (code "lost commits") records lost_commits_text; what was found
  // is returned. Empty when they agree or there is no mark. kInvalidInput for a marks file
  // that does not read, naming its line.
  Result<std::optional<LostCommits>> check_ids();
  // As check_ids, changing nothing (db check).
  Result<std::optional<LostCommits>> find_lost_commits() const;
  // True when run `run_id` is not in the database though its id was handed out (up to the
  // runs' sequence or <db>.ids): a run of a lost commit, not another database's.
  Result<bool> lost_run(std::int64_t run_id) const;

  // Stores a fault or refusal; returns its id. kInvalidInput for an empty message or code, a
  // malformed time; kStorage if run_id names no run.
  Result<std::int64_t> record_event(const EventRecord& event);
  // Stores `events` in order in one transaction (a burst of the service's steps costs one
  // commit, not one each): all of them or, on any refusal, none. Errors as record_event.
  Status record_events(const std::vector<EventRecord>& events);

  // Events newest first.
  Result<std::vector<StoredEvent>> list_events(const EventQuery& q) const;

  // Runs newest first (by started_utc, then by id). kInvalidInput for a malformed time bound,
  // a status other than measured/pushed, or a negative lobe.
  Result<std::vector<RunSummary>> list_runs(const RunQuery& q) const override;

  // The same filters, oldest first: the runs of a lobe over time (q.limit: the newest that
  // many, still returned oldest first).
  Result<std::vector<RunSummary>> trend(const RunQuery& q) const override;

  // The runs trend() returns (oldest first), each with its characteristics.
  using RunHistory::characteristics;
  Result<std::vector<RunCharacteristics>> characteristics(const RunQuery& q, const std::string& key) const override;
  Result<CharacteristicSummaries> characteristic_summaries(const RunQuery& q) const override;

  // Deletes the raw samples of runs started before `cutoff_utc` (exclusive), keeping every
  // summary, profile, correction, push and event, and marks those runs pruned at `now_utc`.
  // Returns how many runs lost their raw samples. One transaction. The freed pages are reused
  // by later runs; `VACUUM` in sqlite3 gives them back to the file system.
  Result<std::int64_t> prune_raw_samples(const std::string& cutoff_utc, const std::string& now_utc);

  // The run of this machine, part and lobe whose table was pushed last (by push order, not by
  // when the run was measured): the table in force, with which the next part is ground. After
  // a rollback re-pushes an older run's table, that older run is the one in force. Empty if
  // none was pushed yet.
  Result<std::optional<std::int64_t>> last_pushed_run(const std::string& machine, const std::string& part,
                                                      int lobe) const;

  // The figures /metrics shows, in one read snapshot. Its cost does not grow with the history:
  // the counts come from row_counts (kept by triggers), the pending tables from their partial
  // index (at most one per NC file), the newest run of each lobe from one seek per lobe in
  // runs_by_lobe_started. kStorage if SQLite refuses.
  Result<StoreMetrics> metrics_snapshot() const;

  // One run, read in a single snapshot. kNotFound if absent.
  Result<StoredRun> load_run(std::int64_t run_id) const;

  // load_run without what is kept per degree (the raw revolutions, and the design, mean, error,
  // correction and residual of the profile) and without its pushes: the run's record, its
  // details and characteristics, which is what the central history copies. kNotFound if absent.
  Result<StoredRun> load_run_record(std::int64_t run_id) const;
  // The records (as load_run_record reads them) of the runs after `after_id` in id order, at
  // most `limit`, in one snapshot: what the central sync copies in one batch. With
  // `per_degree`, their per-degree tables too, as load_run reads them (the raw revolutions
  // unless pruned), but not their pushes.
  Result<std::vector<StoredRun>> run_records_after(std::int64_t after_id, int limit, bool per_degree = false) const;

  // ---- gear runs (schema 12) ----
  // Stores a measured gear and its traces in one transaction. kInvalidInput for a record that
  // contradicts itself (no trace, a trace's z_mm and deviation_um of different lengths, two
  // traces of one gap and flank, a verdict without a required class), naming the field.
  Result<std::int64_t> insert_gear_run(const GearRunRecord& run);
  // The correction made from gear run `id`: the residual of the mesh-error fit, and the stroke
  // version pushed (empty: none yet; a stroke waiting for approval gets its version when
  // approved, in the approval's transaction). kNotFound for an unknown id.
  Status record_gear_correction(std::int64_t id, double mesh_residual_rms_um, std::optional<int> stroke_version);
  // Newest first; traces left out (load_gear_run has them). kInvalidInput as check_run_query.
  Result<std::vector<StoredGearRun>> list_gear_runs(const GearRunQuery& q) const;
  // One gear run with its traces. kNotFound if absent.
  Result<StoredGearRun> load_gear_run(std::int64_t id) const;

  // ---- the outbox (schema 9; docs/plant.md) ----
  // Turns queuing on or off and sets the bound. Messages already waiting stay.
  Status configure_outbox(const OutboxSettings& settings);
  // Up to `limit` (>= 1) waiting messages, oldest first.
  Result<std::vector<OutboxMessage>> outbox_batch(int limit) const;
  // Deletes the messages the broker acknowledged and counts them sent, in one transaction; or,
  // kSkipped, messages that cannot be sent (their run or push gone, too large for the broker),
  // counted dropped. Ids no longer waiting (dropped meanwhile) are ignored.
  enum class OutboxOutcome { kSent, kSkipped };
  Status outbox_delivered(const std::vector<std::int64_t>& ids, OutboxOutcome outcome = OutboxOutcome::kSent);
  // Queues a service state message (its JSON payload, not empty). Returns the message id, or
  // 0 when the outbox is not enabled (nothing queued).
  Result<std::int64_t> enqueue_state(const std::string& payload_json);
  Result<OutboxCounts> outbox_counts() const;

  // ---- replication (schema 9): records in local id order after `after_id`, at most `limit` ----
  Result<std::vector<std::int64_t>> run_ids_after(std::int64_t after_id, int limit) const;
  // Which of `uuids` name runs in this file (the others are other grinders' runs, listed from
  // the central history).
  Result<std::set<std::string>> runs_here(const std::vector<std::string>& uuids) const;
  // With `program_text`, each push's program text too (push.program_text; empty for a push
  // recorded without it).
  Result<std::vector<ReplicatedPush>> pushes_after(std::int64_t after_id, int limit, bool program_text = false) const;
  Result<std::vector<StoredEvent>> events_after(std::int64_t after_id, int limit) const;
  // The runs whose raw samples were pruned, in order of (raw_pruned_utc, id), after the run
  // `after_id` pruned at `after_utc` (empty and 0: from the first), at most `limit`: how the
  // central sync follows the grinder's prunes (schema 22 indexes them).
  Result<std::vector<PrunedRun>> runs_pruned_after(const std::string& after_utc, std::int64_t after_id,
                                                   int limit) const;

  // Takes the write lock and lets it go again, writing nothing: before a measurement, so that
  // a database another program keeps locked (waiting up to 5 s, as every write does) is found
  // before the gauge is read rather than after. kStorage naming the file and what to do.
  Status check_writable();

  // The file this store was opened on, as given to open().
  const std::filesystem::path& path() const;

  // The NC directory the curve tables are pushed to now (the service's [nc] dir, the CLI's
  // --nc-dir or <data-dir>/nc). The history names a program in it by its file name alone
  // (NC_FILE.SPF), and every path it gives back (NcPush, PendingTable, PushIntent, a run's
  // nc_file) is that name inside this directory: a data directory copied, moved or restored
  // from a backup keeps its history for the control it is used with, and never reaches the
  // directory it came from. Without it, paths are stored as given and names read back bare.
  void set_nc_dir(const std::filesystem::path& nc_dir);
  const std::filesystem::path& nc_dir() const;

 private:
  explicit RunStore(std::unique_ptr<storage_internal::Connection> conn);

  // Heap-allocated so its address survives a move of the store.
  std::unique_ptr<storage_internal::Connection> conn_;
};

}  // namespace gaugeloop
