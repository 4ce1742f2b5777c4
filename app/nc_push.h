// Writing a curve-table program to the control: the one way every push goes (a measured run,
// an approval, a rollback), so each is checked, versioned, written atomically and recorded
// alike.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// Refuses (kRefused) to overwrite `nc_file` when the program there is not the one last
// pushed to it: its table was edited by hand (its body no longer matches its checksum, or
// its points differ from the pushed program's), or it is not a gaugeloop table at all. The
// message names the file and line, the version last pushed and what to do. A missing file
// is fine (the control may have been cleaned); so is a file never pushed that is absent.
Status check_not_edited_by_hand(const RunStore& store, const std::filesystem::path& nc_file);

// What a push records besides the program.
struct PushFacts {
  std::int64_t run_id = 0;
  std::string reason;  // "run 12", "approved by anna", "rollback to version 3"
  std::string interpolation;
  std::optional<int> block_count;
  std::optional<double> command_error_um;
  std::optional<int> point_count;
  std::optional<double> correction_max_um;
};

// Renders a program for a table version (the header carries it).
using RenderForVersion = std::function<Result<std::string>(int table_version)>;

// check_not_edited_by_hand (skipped when `overwrite_edited`: a person approved overwriting
// it), then the next table version, render, write atomically
// (temporary file, fsync, rename: the control sees the old program or the new one, never a
// mixture), then record the push. `record` replaces store.record_push when given (an
// approval records the push and its decision in one transaction). Returns the version
// pushed. Errors: the check's kRefused; render's errors; kIo for the write; storage errors.
// A failure after the write says the file was written but not recorded.
using RecordPush = std::function<Status(const NcPush& push)>;
Result<int> push_program(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                         const RenderForVersion& render, const RecordPush& record = {}, bool overwrite_edited = false);

// What an approval or a rollback pushed.
struct PushOutcome {
  std::string nc_file;
  int table_version = 0;
  std::int64_t run_id = 0;  // whose table it is
  // Approval only: false if the table stopped pending between the check and the write (a
  // newer measurement superseded it); the push is then recorded alone.
  bool decision_recorded = true;
};

// `gaugeloop nc approve` and POST /api/nc/approve: pushes pending table `pending_id` (still
// pending: else kRefused naming its status) and records the push and the approval by `by`
// in one transaction. A hand-edited program is overwritten only with `overwrite_edited`.
Result<PushOutcome> approve_pending(RunStore& store, std::int64_t pending_id, const std::string& by,
                                    const std::string& note, bool overwrite_edited);

// `gaugeloop nc rollback` and POST /api/nc/rollback: pushes the program of `table_version`
// of `nc_file` again, as a new version (header updated, body untouched); its run becomes the
// one in force. kNotFound for a version never pushed or pushed without its text.
Result<PushOutcome> rollback_to_version(RunStore& store, const std::string& nc_file, int table_version,
                                        const std::string& by);

// `program` with its `; gaugeloop table_version: N` header line set to `table_version`, for
// a program rendered before its version was known (a pending table) or re-pushed (a
// rollback). The table body, and so its checksum, is untouched. kInvalidInput if the
// program has no such line.
Result<std::string> with_table_version(std::string_view program, int table_version);

}  // namespace gaugeloop
