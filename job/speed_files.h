// The speed subprogram beside a table program: where it lives, writing it with the table, and
// reading it back from the NC directory (docs/nc_output.md, "Variable work speed on the
// control").
#pragma once

#include <filesystem>
#include <string_view>

#include "core/result.h"
#include "job/nc_files.h"
#include "job/nc_push.h"
#include "nc_out/speed_table.h"
#include "storage/run_store.h"

namespace gaugeloop {

// <stem>_SPEED.SPF in the table program's directory (CAM.SPF -> CAM_SPEED.SPF): the name the
// main program calls, speed_program_name(stem) (nc_out/main_program.h).
std::filesystem::path speed_program_path(const std::filesystem::path& nc_file);

// Writes `speed_program` (render_speed_program's text) to speed_program_path(nc_file) under
// the NC directory's lock, atomically (the control sees the old file or the new one), then
// reads it back from the directory: it must be byte for byte the text given. kInvalidInput for a text that is not a
// gaugeloop speed program (nothing is written); kIo for a lock, write or read that failed; kRefused if what was read
// back differs.
Status write_speed_program(const std::filesystem::path& nc_file, std::string_view speed_program,
                           NcFiles& files = real_nc_files());

// The speed program beside `nc_file`, parsed and its checksum verified. kNotFound if there is
// none; the errors of parse_speed_program and verify_speed_checksum, naming the file.
Result<ParsedSpeedProgram> read_speed_program(const std::filesystem::path& nc_file, NcFiles& files = real_nc_files());

// push_program with a speed program: before anything is written, checks that `speed_program`
// is a gaugeloop speed program and that the main program (options.main, if a template is set)
// calls the speed subprogram; then pushes it with the table and the main program as one push
// (push_program, the speed file beside the table: written first, so that a main program calling
// it never finds it missing, and recorded with the push). Stopped between the two, the control
// holds the new speed and the previous table until reconciliation puts the speed file of the
// push in force back. Errors: as push_program ("not pushed").
Result<PushCompletion> push_program_with_speed(RunStore& store, const std::filesystem::path& nc_file,
                                               const PushFacts& facts, const RenderForVersion& render,
                                               std::string_view speed_program, const PushOptions& options = {});

}  // namespace gaugeloop
