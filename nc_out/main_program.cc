// Rendering and reading back the main program.
#include "nc_out/main_program.h"

#include <cctype>
#include <charconv>
#include <optional>
#include <vector>

#include "nc_out/nc_template.h"
#include "nc_out/nc_text.h"

namespace gaugeloop {
namespace {

using nc_text::lines_of;
using nc_text::trim;
using nc_text::upper;

std::optional<int> parse_int(std::string_view s) {
  s = trim(s);
  int v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

// A block's code: the comment after ';' removed, blanks trimmed, the block number (N10) dropped.
std::string_view code_of(std::string_view line) {
  if (const size_t semi = line.find(';'); semi != std::string_view::npos) line = line.substr(0, semi);
  line = trim(line);
  if (line.size() > 1 && (line[0] == 'N' || line[0] == 'n') && std::isdigit(static_cast<unsigned char>(line[1]))) {
    size_t i = 1;
    while (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i]))) ++i;
    line = trim(line.substr(i));
  }
  return line;
}

// The coupling on one block: the table number EGON (4th argument) or LEADON (3rd) names;
// empty when the block has none. `error` is set when it has one that cannot be read.
std::optional<int> coupling_on(std::string_view code, std::string& error) {
  const std::string u = upper(code);
  size_t index = 0;
  size_t at = std::string::npos;
  for (const auto& [word, arg] : {std::pair<const char*, size_t>{"EGON(", 3}, {"LEADON(", 2}}) {
    at = u.find(word);
    if (at != std::string::npos) {
      index = arg;
      at += std::string_view(word).size();
      break;
    }
  }
  if (at == std::string::npos) return std::nullopt;
  const size_t close = u.find(')', at);
  if (close == std::string::npos) {
    error = "the coupling has no closing ')'";
    return std::nullopt;
  }
  std::vector<std::string_view> args;
  std::string_view rest = code.substr(at, close - at);
  while (true) {
    const size_t comma = rest.find(',');
    args.push_back(trim(rest.substr(0, comma)));
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  std::optional<int> n = args.size() > index ? parse_int(args[index]) : std::nullopt;
  if (!n) error = "the coupling's curve table number cannot be read";
  return n;
}

}  // namespace

Result<int> coupled_table_number(std::string_view program, std::string_view file_name) {
  const std::vector<std::string_view> lines = lines_of(program);
  for (size_t i = 0; i < lines.size(); ++i) {
    std::string error;
    std::optional<int> n = coupling_on(code_of(lines[i]), error);
    if (!error.empty()) {
      return make_error(ErrorCode::kInvalidInput,
                        std::string(file_name) + " line " + std::to_string(i + 1) + ": " + error);
    }
    if (n) return *n;
  }
  return make_error(ErrorCode::kInvalidInput,
                    std::string(file_name) + ": no EGON or LEADON couples the infeed to a curve table");
}

std::string speed_program_name(std::string_view program_name) { return std::string(program_name) + "_SPEED"; }

Status check_main_calls_speed_program(std::string_view program, std::string_view file_name,
                                      std::string_view speed_subprogram) {
  for (const std::string_view line : lines_of(program)) {
    const std::string_view code = code_of(line);
    if (upper(code.substr(0, code.find_first_of(" \t("))) == upper(speed_subprogram)) return {};
  }
  return make_error(ErrorCode::kInvalidInput, std::string(file_name) +
                                                  ": the main program does not call the speed "
                                                  "subprogram " +
                                                  std::string(speed_subprogram) +
                                                  "; with a speed program on, use a main template that calls "
                                                  "{{program_name}}_SPEED (examples/sinumerik/cam_main_speed.mpf)");
}

Result<std::string> render_main_program(std::string_view template_text, std::string_view template_name,
                                        const std::map<std::string, std::string>& values) {
  Result<std::string> program = render_nc_template(template_text, template_name, values);
  if (!program) return program.error();
  const std::string& subprogram = values.at("program_name");
  const std::string& number = values.at("table_number");
  auto refuse = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(template_name) + ": the rendered main program " + why +
                                                    "; call the table subprogram with {{program_name}} and couple with "
                                                    "EGON(X,\"FINE\",C,{{table_number}},0) (docs/nc_output.md)");
  };
  bool calls = false;
  bool couples = false;
  const std::vector<std::string_view> lines = lines_of(*program);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view code = code_of(lines[i]);
    const std::string_view first = code.substr(0, code.find_first_of(" \t("));
    if (upper(first) == upper(subprogram)) calls = true;
    // Execution from external source: EXTCALL("<name>") runs the table subprogram from a drive.
    if (upper(first) == "EXTCALL" && upper(code).find("\"" + upper(subprogram) + "\"") != std::string::npos) {
      calls = true;
    }
    std::string error;
    const std::optional<int> n = coupling_on(code, error);
    const std::string where = "line " + std::to_string(i + 1);
    if (!error.empty()) return refuse("has a coupling that cannot be read at " + where + " (" + error + ")");
    if (n && std::to_string(*n) != number) {
      return refuse("couples curve table " + std::to_string(*n) + " at " + where + ", not table " + number +
                    ", the one the subprogram defines");
    }
    if (n) couples = true;
  }
  if (!calls) return refuse("does not call the table subprogram " + subprogram);
  if (!couples) return refuse("couples no curve table (no EGON or LEADON)");
  return program;
}

}  // namespace gaugeloop
