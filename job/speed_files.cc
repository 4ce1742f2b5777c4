// Writing the speed subprogram beside the table and reading it back.
#include "job/speed_files.h"

#include "job/pin_files.h"
#include "nc_out/main_program.h"

namespace gaugeloop {

std::filesystem::path speed_program_path(const std::filesystem::path& nc_file) {
  return nc_file.parent_path() / (speed_program_name(nc_file.stem().string()) + ".SPF");
}

Status write_speed_program(const std::filesystem::path& nc_file, std::string_view speed_program, NcFiles& files) {
  const std::filesystem::path path = speed_program_path(nc_file);
  Result<ParsedSpeedProgram> meant = parse_speed_program(speed_program, path.string());
  if (!meant) return meant.error();
  if (Status s = verify_speed_checksum(*meant, path.string()); !s) {
    return make_error(ErrorCode::kInvalidInput, s.error().message);
  }
  return write_program_beside(path, speed_program, "speed program", files);
}

Result<ParsedSpeedProgram> read_speed_program(const std::filesystem::path& nc_file, NcFiles& files) {
  const std::filesystem::path path = speed_program_path(nc_file);
  Result<std::optional<std::string>> text = files.read_program(path);
  if (!text) return text.error();
  if (!*text) return make_error(ErrorCode::kNotFound, path.string() + ": no speed program on the control");
  Result<ParsedSpeedProgram> parsed = parse_speed_program(**text, path.string());
  if (!parsed) return parsed.error();
  if (Status s = verify_speed_checksum(*parsed, path.string()); !s) return s.error();
  return parsed;
}

Result<PushCompletion> push_program_with_speed(RunStore& store, const std::filesystem::path& nc_file,
                                               const PushFacts& facts, const RenderForVersion& render,
                                               std::string_view speed_program, const PushOptions& options) {
  const std::filesystem::path speed_path = speed_program_path(nc_file);
  Result<ParsedSpeedProgram> parsed = parse_speed_program(speed_program, speed_path.string());
  if (!parsed) return parsed.error();
  if (Status s = verify_speed_checksum(*parsed, speed_path.string()); !s) {
    return make_error(ErrorCode::kInvalidInput, s.error().message);
  }
  if (!options.main.template_text.empty()) {
    // Which version comes next does not change what the main program calls: version 1 will do.
    Result<std::string> table = render(1);
    if (!table) return table.error();
    Result<std::string> main = render_main_for_table(options.main, nc_file, *table);
    if (!main) return main.error();
    if (Status s = check_main_calls_speed_program(*main, options.main.template_name,
                                                  speed_program_name(nc_file.stem().string()));
        !s) {
      return s.error();
    }
  }
  PushOptions with_speed = options;
  with_speed.beside.push_back(ProgramBeside{PushFileRole::kSpeed, speed_path, std::string(speed_program)});
  return push_program(store, nc_file, facts, render, with_speed);
}

}  // namespace gaugeloop
