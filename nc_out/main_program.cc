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
using nc_text::parse_int;
using nc_text::trim;
using nc_text::upper;

// A block's code: the comment after ';' removed, blanks trimmed, the block number (N10) dropped.
std::string_view block_code(std::string_view line) {
  if (const size_t semi = line.find(';'); semi != std::string_view::npos) line = line.substr(0, semi);
  line = trim(line);
  if (line.size() > 1 && (line[0] == 'N' || line[0] == 'n') && std::isdigit(static_cast<unsigned char>(line[1]))) {
    size_t i = 1;
    while (i < line.size() && std::isdigit(static_cast<unsigned char>(line[i]))) ++i;
    line = trim(line.substr(i));
  }
  return line;
}

// One coupling on a block: the following axis (EGON's and LEADON's first argument, upper
// case) and the curve table number it names (EGON's 4th argument, LEADON's 3rd).
struct Coupling {
  std::string axis;
  int table = 0;
};

// Every coupling on one block, in the order written. `error` is set when one cannot be read.
std::vector<Coupling> couplings_on(std::string_view code, std::string& error) {
  const std::string u = upper(code);
  std::vector<Coupling> out;
  size_t from = 0;
  while (true) {
    size_t index = 0;
    size_t at = std::string::npos;
    for (const auto& [word, arg] : {std::pair<std::string_view, size_t>{"EGON(", 3}, {"LEADON(", 2}}) {
      const size_t found = u.find(word, from);
      if (found != std::string::npos && found < at) {
        at = found + word.size();
        index = arg;
      }
    }
    if (at == std::string::npos) return out;
    const size_t close = u.find(')', at);
    if (close == std::string::npos) {
      error = "the coupling has no closing ')'";
      return out;
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
    if (!n) {
      error = "the coupling's curve table number cannot be read";
      return out;
    }
    out.push_back({upper(args[0]), *n});
    from = close + 1;
  }
}

// Whether the block's first word (or EXTCALL's quoted argument) calls `name`.
bool calls_program(std::string_view code, const std::string& name) {
  const std::string_view first = code.substr(0, code.find_first_of(" \t("));
  if (upper(first) == upper(name)) return true;
  // Execution from external source: EXTCALL("<name>") runs the subprogram from a drive.
  return upper(first) == "EXTCALL" && upper(code).find("\"" + upper(name) + "\"") != std::string::npos;
}

}  // namespace

Result<int> coupled_table_number(std::string_view program, std::string_view file_name,
                                 std::string_view following_axis) {
  const std::vector<std::string_view> lines = lines_of(program);
  const std::string axis = upper(following_axis);
  for (size_t i = 0; i < lines.size(); ++i) {
    std::string error;
    const std::vector<Coupling> found = couplings_on(block_code(lines[i]), error);
    if (!error.empty()) {
      return make_error(ErrorCode::kInvalidInput,
                        std::string(file_name) + " line " + std::to_string(i + 1) + ": " + error);
    }
    for (const Coupling& c : found) {
      if (axis.empty() || c.axis == axis) return c.table;
    }
  }
  return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": no EGON or LEADON couples " +
                                                  (axis.empty() ? std::string("the infeed") : axis) +
                                                  " to a curve table");
}

std::string speed_program_name(std::string_view program_name) { return std::string(program_name) + "_SPEED"; }

Status check_main_calls_speed_program(std::string_view program, std::string_view file_name,
                                      std::string_view speed_subprogram) {
  for (const std::string_view line : lines_of(program)) {
    const std::string_view code = block_code(line);
    if (upper(code.substr(0, code.find_first_of(" \t("))) == upper(speed_subprogram)) return {};
  }
  return make_error(ErrorCode::kInvalidInput, std::string(file_name) +
                                                  ": the main program does not call the speed "
                                                  "subprogram " +
                                                  std::string(speed_subprogram) +
                                                  "; with a speed program on, use a main template that calls "
                                                  "{{program_name}}_SPEED (examples/sinumerik/cam_main_speed.mpf)");
}

std::string pin_y_program_name(std::string_view program_name) { return std::string(program_name) + "_Y"; }

Result<std::string> render_main_program(std::string_view template_text, std::string_view template_name,
                                        const std::map<std::string, std::string>& values) {
  const auto y_number_value = values.find("y_table_number");
  const auto y_program_value = values.find("y_program_name");
  if ((y_number_value == values.end()) != (y_program_value == values.end())) {
    return make_error(ErrorCode::kInvalidInput, std::string(template_name) +
                                                    ": a crankpin ground C-X-Y needs both y_table_number and "
                                                    "y_program_name to render its main program, not one of them");
  }
  const bool with_y = y_number_value != values.end();
  Result<std::string> program = render_nc_template(template_text, template_name, values);
  if (!program) return program.error();
  const std::string& subprogram = values.at("program_name");
  const std::string& number = values.at("table_number");
  const std::string y_subprogram = with_y ? y_program_value->second : std::string();
  const std::string y_number = with_y ? y_number_value->second : std::string();
  auto refuse = [&](const std::string& why) {
    const std::string how = with_y
                                ? "; call both table subprograms, {{program_name}} and {{y_program_name}}, and couple "
                                  "EGON(X,\"FINE\",C,{{table_number}},0) and EGON(Y,\"FINE\",C,{{y_table_number}},0) "
                                  "(docs/nc_output.md, crankpin programs)"
                                : "; call the table subprogram with {{program_name}} and couple with "
                                  "EGON(X,\"FINE\",C,{{table_number}},0) (docs/nc_output.md)";
    return make_error(ErrorCode::kInvalidInput,
                      std::string(template_name) + ": the rendered main program " + why + how);
  };
  if (with_y && y_number == number) {
    return refuse("would couple X and Y through the same curve table " + number +
                  "; give the Y table its own pair of table numbers");
  }
  bool calls = false;
  bool calls_y = false;
  int x_line = 0;  // 1-based line of the first coupling of X (with Y) or of any coupling (without)
  int y_line = 0;  // 1-based line of the first coupling of Y
  const std::vector<std::string_view> lines = lines_of(*program);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view code = block_code(lines[i]);
    calls = calls || calls_program(code, subprogram);
    calls_y = calls_y || (with_y && calls_program(code, y_subprogram));
    std::string error;
    const std::vector<Coupling> found = couplings_on(code, error);
    const std::string where = "line " + std::to_string(i + 1);
    if (!error.empty()) return refuse("has a coupling that cannot be read at " + where + " (" + error + ")");
    for (const Coupling& c : found) {
      const std::string table = std::to_string(c.table);
      if (!with_y) {
        if (table != number) {
          return refuse("couples curve table " + table + " at " + where + ", not table " + number +
                        ", the one the subprogram defines");
        }
        if (x_line == 0) x_line = static_cast<int>(i + 1);
        continue;
      }
      // A crankpin ground C-X-Y: each axis to its own table, so the wheel never follows the
      // other axis' path.
      if (c.axis == "X" && table != number) {
        return refuse("couples X to curve table " + table + " at " + where + ", not table " + number +
                      ", the X table " + subprogram + " defines");
      }
      if (c.axis == "Y" && table != y_number) {
        return refuse("couples Y to curve table " + table + " at " + where + ", not table " + y_number +
                      ", the Y table " + y_subprogram + " defines");
      }
      if (c.axis != "X" && c.axis != "Y") {
        return refuse("couples axis " + c.axis + " at " + where + "; a crankpin ground C-X-Y couples X and Y only");
      }
      int& first = c.axis == "X" ? x_line : y_line;
      if (first == 0) first = static_cast<int>(i + 1);
    }
  }
  if (!calls) return refuse("does not call the table subprogram " + subprogram);
  if (!with_y) {
    if (x_line == 0) return refuse("couples no curve table (no EGON or LEADON)");
    return program;
  }
  if (!calls_y) {
    return refuse("does not call the Y table subprogram " + y_subprogram +
                  (y_line > 0 ? ", yet couples Y to table " + y_number + " at line " + std::to_string(y_line) +
                                    ", which only that subprogram defines"
                              : std::string()));
  }
  if (x_line == 0) return refuse("does not couple X to curve table " + number);
  if (y_line == 0) return refuse("does not couple Y to curve table " + y_number);
  return program;
}

namespace {

// A block's code without blanks, upper case: `EGON(C, "FINE", B,...)` as `EGON(C,"FINE",B,...)`.
std::string squeezed(std::string_view code) {
  std::string out;
  for (const char c : upper(code)) {
    if (c != ' ' && c != '\t') out += c;
  }
  return out;
}

// Whether a block defines or switches a coupling of any axis.
bool is_coupling_block(std::string_view code) {
  const std::string u = squeezed(code);
  for (const char* word : {"EGDEF(", "EGON(", "EGONSYN(", "EGONSYNE(", "LEADON(", "TRAILON("}) {
    if (u.find(word) != std::string::npos) return true;
  }
  return false;
}

}  // namespace

Result<std::string> render_gear_main_program(std::string_view template_text, std::string_view template_name,
                                             const std::map<std::string, std::string>& values) {
  Result<std::string> program = render_nc_template(template_text, template_name, values);
  if (!program) return program.error();
  const std::string& subprogram = values.at("program_name");
  std::vector<std::string> coupling;
  for (const std::string_view line : lines_of(values.at("gearbox_coupling"))) coupling.push_back(squeezed(line));
  auto refuse = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(template_name) + ": the rendered main program " + why +
                          "; put {{gearbox_coupling}} on a line of its own before the block that calls the stroke "
                          "subprogram {{program_name}}, as examples/sinumerik/gear_main.mpf does (docs/gears.md)");
  };
  std::size_t coupled = 0;  // lines of the gearbox coupling found, in order
  bool calls = false;
  const std::vector<std::string_view> lines = lines_of(*program);
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string_view code = block_code(lines[i]);
    const std::string where = "line " + std::to_string(i + 1);
    if (is_coupling_block(code)) {
      if (coupled == coupling.size() || squeezed(code) != coupling[coupled]) {
        return refuse("makes a coupling of its own at " + where + " (`" + std::string(code) +
                      "`): the gearbox with SIM1 is written by gaugeloop with the part's factors, and a second "
                      "one would fight it");
      }
      ++coupled;
      continue;
    }
    if (calls_program(code, subprogram)) {
      if (coupled < coupling.size()) {
        return refuse("calls the stroke subprogram " + subprogram + " at " + where +
                      " before C is coupled to B, Z, Y and SIM1: the stroke's SIM1 would move nothing");
      }
      calls = true;
    }
  }
  if (coupled < coupling.size()) {
    return refuse(
        "does not couple C to B, Z, Y and SIM1 (no {{gearbox_coupling}}): the stroke's SIM1 would move "
        "nothing and the gear would be ground uncompensated");
  }
  if (!calls) return refuse("does not call the stroke subprogram " + subprogram);
  return program;
}

}  // namespace gaugeloop
