// The Y table program beside a crankpin's X table (C-X-Y), and the push of both: where the Y
// file lives, writing it so that it always belongs to the table version pushed with it, and
// reading it back (docs/crankpins.md, "On the control").
#pragma once

#include <filesystem>
#include <string_view>

#include "core/result.h"
#include "job/nc_files.h"
#include "job/nc_push.h"
#include "storage/run_store.h"

namespace gaugeloop {

// <stem>_Y.SPF in the X table program's directory (CRANK_PIN1.SPF -> CRANK_PIN1_Y.SPF); the
// main program calls it as {{y_program_name}}.
std::filesystem::path y_table_program_path(const std::filesystem::path& nc_file);

// Writes `text` to `path` beside a table program: under the NC directory's lock, our leftover
// temporary files removed, atomically (the control sees the old file or the new one), then
// read back, which must give the text byte for byte. `what` names the file's role in messages
// ("speed program", "Y table"). kIo for a lock, write or read that failed (the file on the
// control, if any, stays); kRefused if what was read back differs.
Status write_program_beside(const std::filesystem::path& path, std::string_view text, std::string_view what,
                            NcFiles& files);

// Renders the Y table program for a table version (its header carries the version, and its
// CTABDEF number follows it as the X table's does).
using RenderYForVersion = std::function<Result<std::string>(int table_version)>;

// push_program for a C-X-Y pin: the Y table first, then the X table and the main program.
// Pushes interrupted earlier are reconciled, the next table version of `nc_file` taken, the Y
// program rendered for it and checked (a gaugeloop table program following Y, its checksum
// sound), and pushed with the X table and the main program as one push (push_program, the Y
// table beside the X table: written first and recorded with the push), which must give the
// same version. The Y table goes to the number of its version, not the one a coupling holds, so
// a push stopped between the two leaves the control grinding with the previous X and Y tables,
// a matched pair, and reconciliation puts the previous Y file back. Errors: as push_program
// ("not pushed"); kStorage if the X table was given another version than the Y table's
// (another push came between: push again).
Result<PushCompletion> push_pin_programs(RunStore& store, const std::filesystem::path& nc_file, const PushFacts& facts,
                                         const RenderForVersion& render_x, const RenderYForVersion& render_y,
                                         const PushOptions& options = {});

}  // namespace gaugeloop
