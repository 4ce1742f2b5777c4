// Writing a curve-table program (or a gear's stroke program) to the control: the one way every
// push goes (a measured run, an approval, a rollback, a stroke), so each is checked, versioned,
// written atomically and recorded alike.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "job/nc_files.h"
#include "nc_out/table_program.h"
#include "storage/run_store.h"

namespace gaugeloop {

// kRefused: NC program `nc_file` <what>, which gaugeloop does not overwrite; the message says how
// to keep the change and, in `again`, the command that overwrites it ("push the stroke with ...").
Error refused_as_edited(const std::filesystem::path& nc_file, const std::string& what, std::string_view again);

// Refuses (kRefused) to overwrite `nc_file` when the program there is not the one last
// pushed to it: its table was edited by hand (its body no longer matches its checksum, or
// its points differ from the pushed program's), its header names another run, table version
// or checksum than the push recorded last, or it is not a gaugeloop table at all. The message
// names the file and line, the version last pushed and what to do. A missing file is fine
// (the control may have been cleaned); so is a file never pushed that is absent. A file that
// holds the program of a push still open in the journal (written, its record interrupted) is
// that push's, not a hand edit.
Status check_not_edited_by_hand(const RunStore& store, const std::filesystem::path& nc_file,
                                NcFiles& files = real_nc_files());

// What a push records besides the program.
struct PushFacts {
  std::int64_t run_id = 0;
  std::string reason;  // "run 12", "approved by anna", "rollback to version 3"
  TableFacts table;
  // An approval: the pending table pushed, who approved it and their note; the push and the
  // decision are recorded in one transaction.
  std::optional<std::int64_t> pending_id;
  std::string approved_by;
  std::string note;
};

// Renders a program for a table version (the header carries it, and the table number that
// version goes to: table_number_for_version, nc_out/table_program.h).
using RenderForVersion = std::function<Result<std::string>(int table_version)>;

// Where a program comes from, for its comment lines ({{origin}}): "run 12", or for run 0 "the
// drawing (no part measured yet)", a program written by nc new.
std::string origin_text(std::int64_t run_id);

// The main program beside a table program: <stem>_MAIN.MPF in the same directory (CAM.SPF ->
// CAM_MAIN.MPF).
std::filesystem::path main_program_path(const std::filesystem::path& nc_file);

// Every file a push to `nc_file` may write: the table itself, its main program, its speed
// subprogram (job/speed_files.h) and a crankpin's Y table (job/pin_files.h).
std::vector<std::filesystem::path> files_of_push(const std::filesystem::path& nc_file);

// Where the main program comes from: its template and what the table program does not say.
struct MainProgramSource {
  std::string template_text;  // empty: no main program is written
  std::string template_name;  // for messages
  std::string part;           // empty: the run's (approve_pending, rollback_to_version)
  int lobe = 0;               // 0: the run's
  std::string created_utc;    // empty: now
  // A crankpin ground in C-X-Y: the main program also calls the Y table subprogram
  // (y_program_name, e.g. CRANK_PIN1_Y) and couples Y through y_table_number, the number of
  // y_table_numbers the table's version goes to (table_number_for_version). Empty: X alone.
  std::string y_program_name;
  TableNumbers y_table_numbers{0, 0};
  // For an approval or a rollback: the main program of a crankpin ground C-X (its run's
  // settings say so), used instead of template_text; empty: template_text for every part.
  std::string pin_cx_template_text;
  std::string pin_cx_template_name;
  // For a gear's stroke program (nc_out/stroke_program.h): the main program coupling C to B, Z,
  // Y and SIM1 (examples/sinumerik/gear_main.mpf), used instead of template_text; empty:
  // template_text for every program.
  std::string gear_template_text;
  std::string gear_template_name;
  // For a correction layer (a table whose header names its design table, nc_out/table_layer.h):
  // the main program coupling the design table and the layer (examples/sinumerik/
  // cam_main_layer.mpf), used instead of template_text; empty: template_text. The design
  // table's program is design_table_program when given (before it is on the control), else
  // read from beside the table through `files` (null: the real NC directory).
  std::string layer_template_text;
  std::string layer_template_name;
  // For an approval of a table kept with its speed subprogram (a lobe ground at a work speed
  // program): the main program that calls it (examples/sinumerik/cam_main_speed.mpf), used
  // instead of template_text; empty: template_text, which must call it too.
  std::string speed_template_text;
  std::string speed_template_name;
  std::string design_table_program;
  NcFiles* files = nullptr;
};

// The main program for `table_program` (version and table number set, as pushed to
// `nc_file`), rendered with render_main_program (nc_out/main_program.h): program_name is
// nc_file's stem; run_id, table_version, table_number, table_start_c_deg (its first leading
// value), point_count and interpolation are the table program's; with a Y table
// (source.y_program_name), y_program_name and y_table_number too. A table program that starts
// with an archive header gets a main program that does too (archive_header,
// nc_out/table_program.h). kInvalidInput for a table program that does not parse or a
// template that does not render.
Result<std::string> render_main_for_table(const MainProgramSource& source, const std::filesystem::path& nc_file,
                                          std::string_view table_program);

// The main program for a gear's stroke program (as pushed to `nc_file`), rendered with
// render_gear_main_program (nc_out/main_program.h) from source.gear_template_text (or
// template_text when that is empty): program_name is nc_file's stem, the gearbox's lines are
// built from the factors the stroke program's header carries (s_bc, s_zc_deg_per_mm,
// s_yc_deg_per_mm), and run_id, table_version, point_count, sim_max_abs_deg and part are its
// header's too (part: source.part when given). kInvalidInput for a stroke that does not parse,
// a header without the factors or a template that does not render.
Result<std::string> render_main_for_stroke(const MainProgramSource& source, const std::filesystem::path& nc_file,
                                           std::string_view stroke_program);

// The steps of a push, in order; a test seam to interrupt one between any two.
enum class PushStep {
  kIntentRecorded,    // the journal holds the intent and the program; the control is untouched
  kTemporaryWritten,  // the temporary file beside the program is written, not flushed
  kFlushed,           // ... flushed to disk, not renamed
  kRenamed,           // the control holds the new program; the push is not yet recorded
  kMainWritten,       // ... and the main program coupling its table (only with a main program)
  kRecorded,          // the push is recorded and the intent completed
};
std::string_view push_step_name(PushStep step);

// A program written beside the table by the same push: a speed subprogram, a crankpin's Y
// table. (The main program is push_program's own.)
struct ProgramBeside {
  PushFileRole role = PushFileRole::kSpeed;
  std::filesystem::path path;
  std::string text;
};

struct PushOptions {
  bool overwrite_edited = false;  // a person approved overwriting a program edited by hand
  // Written after the intent is recorded and before the table, each atomically and read back;
  // recorded with the intent, so that reconciliation and `nc check` hold them to the push.
  std::vector<ProgramBeside> beside;
  std::function<void(PushStep step)> observer;
  NcFiles* files = nullptr;  // null: the real NC directory (real_nc_files)
  // Written after the table, beside it (main_program_path), coupling the table just written;
  // empty template: none.
  MainProgramSource main;
};

// The push as one recoverable step. Under the NC directory's lock (DirectoryLock, so one
// push at a time): reconcile_pushes for the file, check_not_edited_by_hand (skipped with
// overwrite_edited), take the next table version and render; record the intent with the
// program, and the hash and text of every other file it writes, in the journal
// (RunStore::begin_push); write the programs beside (options.beside), then the table atomically
// (temporary file, fsync, rename: the control sees the old program or the new one, never a
// mixture); with a main program, write it the same way after the table; then complete the
// intent, recording the push (and an approval's decision) in one transaction. A file beside
// that cannot be written: the push is abandoned and the files beside are put back as the last
// push wrote them (best effort; reconciliation does it otherwise).
// The main program is rendered before anything is written (its errors refuse the push). A
// main program left coupling the number the new table goes to (its write failed or was
// interrupted after an earlier table) is first rewritten for the table last pushed, so the
// table a coupling may hold is never the one redefined (docs/nc_output.md). A main program
// that cannot be written after the table was: the push is recorded (the control holds the
// table) and the write's error returned, saying the main program still couples the previous
// table.
// Interrupted anywhere (kill, power cut, disk full, database locked), the next push or
// reconcile_pushes finds the intent and the file and records or abandons it: the history
// never misses a program the control holds. Errors: the check's kRefused; render's errors;
// kStorage or kIo before the rename ("not pushed": the program in force stays); kStorage after
// it ("written, its record is completed by the next push or `gaugeloop nc reconcile`").
Result<PushCompletion> push_program(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                                    const RenderForVersion& render, const PushOptions& options = {});

// A main program that couples another table than the one its table subprogram defines: a push
// cut (or failed) after the table was in place and before the main program was. The control
// then grinds the older table still in its memory while the history holds the newer one.
struct StaleMain {
  std::filesystem::path main_file;
  std::filesystem::path nc_file;
  int coupled_number = 0;   // the table number the main program couples
  int coupled_version = 0;  // the newest other version pushed to that number
  int table_number = 0;     // the number the table on the control defines
  int table_version = 0;    // the version on the control
  bool repointed = false;   // reconcile wrote the main program again, coupling table_number
};

// "CAM_MAIN.MPF couples table 1, that of version 3, while CAM.SPF on the control is version 4
// (table 2): the control grinds version 3"
std::string stale_main_text(const StaleMain& stale);

// The main program beside `nc_file` (main_program_path) against the table on the control:
// empty when either is missing, the table is a gear's stroke, the two agree, or the main
// program couples a number no other pushed version of the file went to (not a push's
// leftover: left alone).
Result<std::optional<StaleMain>> find_stale_main(const RunStore& store, const std::filesystem::path& nc_file,
                                                 NcFiles& files = real_nc_files());

// A file the last push of a program wrote beside its table (main program, speed subprogram,
// Y table) that the control does not hold as written.
struct PushFileMismatch {
  PushFile file;  // as the push recorded it, with its text
  bool missing = false;
  // The file holds what a push of ours wrote for this version (another push's file: put back
  // by reconciliation); empty: no push of ours wrote it (a hand edit: left, and said).
  std::optional<int> written_for;
  bool restored = false;  // reconciliation wrote it again as the push recorded it
};

// "CAM_SPEED.SPF holds the speed subprogram written for version 3, not that of version 4, the
// version in force"
std::string push_file_mismatch_text(const PushFileMismatch& m);

// Every file the last push of `nc_file` recorded beside its table, against the control: the
// ones that differ. Empty for a program last pushed before pushes recorded their files, and
// for the table itself (check_not_edited_by_hand holds it). kStorage for a recorded text that
// fails its hash.
Result<std::vector<PushFileMismatch>> compare_push_files(const RunStore& store, const std::filesystem::path& nc_file,
                                                         NcFiles& files = real_nc_files());

// What reconcile_pushes did.
struct ReconcileReport {
  int completed = 0;                   // intents whose program the control holds: recorded as pushed
  int abandoned = 0;                   // intents whose program never reached the control
  int leftovers_removed = 0;           // temporary files of interrupted writes
  std::vector<StaleMain> stale_mains;  // found, repointed or not
  // Files beside a table that were not as its last push wrote them: put back (restored) or,
  // edited by hand, left.
  std::vector<PushFileMismatch> files;
  // Commits the database lost (RunStore::check_ids), noticed before anything else: the ids
  // already go on past them and an event records it.
  std::optional<LostCommits> lost_commits;
  std::vector<std::string> messages;  // one line per intent resolved, file removed or main program found
};

// Brings the journal and the control into agreement for `nc_file`, under the directory's
// lock. First the ids the database handed out are held to its marks (RunStore::check_ids), so
// a database that lost commits hands out none of their ids again. Then an open intent whose
// program the file holds byte for byte is completed (recorded as pushed, "found on the
// control"), any other open intent is abandoned, and leftover temporary files of ours (of the
// table, its main program, its speed subprogram and a pin's Y table) are removed. Then a stale
// main program (find_stale_main) is written again for the table on the control: as the last
// push recorded it when it did, else from `main` when it has a template and the table is not a
// crankpin's ground C-X-Y (its Y table needs a measurement); otherwise it is reported and left.
// Then every other file the last push recorded (compare_push_files) that is missing or holds
// another push's file of ours is written again as recorded; one edited by hand is reported and
// left. The table itself is never called edited by hand here.
Result<ReconcileReport> reconcile_pushes(RunStore& store, const std::filesystem::path& nc_file,
                                         NcFiles& files = real_nc_files(), const MainProgramSource* main = nullptr);

// The table version the next push to `nc_file` gets, once pushes interrupted earlier are
// settled (reconcile_pushes through options.files; push_program settles them again under the
// lock): what a file written before the table names, a speed subprogram's `table_version`.
Result<int> next_table_version_settled(RunStore& store, const std::filesystem::path& nc_file,
                                       const PushOptions& options);

// reconcile_pushes for every file a program was pushed to (the service at start, `gaugeloop
// nc reconcile`). An error stops it only for a file with an open intent; another file that
// cannot be read or locked now is named in the messages ("not checked") and the rest go on.
Result<ReconcileReport> reconcile_all_pushes(RunStore& store, const MainProgramSource* main = nullptr,
                                             NcFiles& files = real_nc_files());

// What an approval or a rollback pushed.
struct PushOutcome {
  std::string nc_file;
  int table_version = 0;
  std::int64_t run_id = 0;  // whose table it is
  // Approval only: false if the table stopped pending between the check and the write (a
  // newer measurement superseded it); the push is then recorded alone.
  bool decision_recorded = true;
  bool stroke = false;           // a gear's stroke program (nc_out/stroke_program.h), not a curve table
  bool slides = false;           // the slides' tables (AX_EEC.INI with NC_CEC.INI beside it)
  std::int64_t gear_run_id = 0;  // approval of a stroke: the gear run it was corrected from
};

// `gaugeloop nc approve` and POST /api/nc/approve: pushes pending table `pending_id` (still
// pending: else kRefused naming its status) and records the push and the approval by `by`
// in one transaction. The table of a crankpin ground C-X-Y is refused (kRefused): its Y table
// would not follow it (a measurement writes both). A hand-edited program is overwritten only with `overwrite_edited`.
// With a main program template in `main`, the main program is rewritten to couple it. A table
// kept with its speed subprogram (a lobe ground at a work speed program) has that written first,
// naming the version pushed, as push_program_with_speed writes it.
Result<PushOutcome> approve_pending(RunStore& store, std::int64_t pending_id, const std::string& by,
                                    const std::string& note, bool overwrite_edited, const MainProgramSource& main = {});

// `gaugeloop nc rollback` and POST /api/nc/rollback: pushes the program of `table_version`
// of `nc_file` again, as a new version (header updated, body untouched); its run becomes the
// one in force. A version pushed with a speed subprogram (recorded with its push) gets it back,
// naming the new version, with main.speed_template_text as the main template when given, as
// an approval does. kNotFound for a version never pushed or pushed without its text; kRefused
// for the table of a crankpin ground C-X-Y (its Y table would not follow).
Result<PushOutcome> rollback_to_version(RunStore& store, const std::string& nc_file, int table_version,
                                        const std::string& by, const MainProgramSource& main = {});

// `program` with its `; gaugeloop table_version: N` header line set to `table_version`, for
// a program rendered before its version was known (a pending table) or re-pushed (a
// rollback); a program whose header names its table_numbers also gets the number of that
// version (header line and CTABDEF), so approvals and rollbacks alternate like any push. The
// table body, and so its checksum, is untouched. kInvalidInput if the program has no such
// line.
Result<std::string> with_table_version(std::string_view program, int table_version);

}  // namespace gaugeloop
