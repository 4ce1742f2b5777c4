// Rendering and reading back the main program.
#include "nc_out/main_program.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <optional>
#include <vector>

#include "nc_out/nc_template.h"
#include "nc_out/nc_text.h"
#include "nc_out/table_program.h"

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

// One leading axis of an EGON: its name (upper case) and its factor's numerator and
// denominator as written (a denominator of 0 makes the numerator a curve table's number).
struct LeadingLink {
  std::string axis;
  std::optional<double> numerator;
  std::optional<double> denominator;
};

// An EGON read in full: EGON(following axis, block change, leading axis 1, numerator 1,
// denominator 1, ...). `error` set when it cannot be read.
struct GearboxCoupling {
  std::string following;
  std::vector<LeadingLink> leading;
};

std::vector<std::string_view> arguments_of(std::string_view inside) {
  std::vector<std::string_view> args;
  while (true) {
    const size_t comma = inside.find(',');
    args.push_back(trim(inside.substr(0, comma)));
    if (comma == std::string_view::npos) return args;
    inside = inside.substr(comma + 1);
  }
}

// Every EGON on a block, with all its leading axes, and whether the block holds a LEADON
// (which has one leading axis: a layer cannot be made with it).
std::vector<GearboxCoupling> gearbox_couplings_on(std::string_view code, bool& leadon, std::string& error) {
  const std::string u = upper(code);
  leadon = leadon || u.find("LEADON(") != std::string::npos;
  std::vector<GearboxCoupling> out;
  for (size_t at = u.find("EGON("); at != std::string::npos; at = u.find("EGON(", at + 1)) {
    const size_t open = at + 5;
    const size_t close = u.find(')', open);
    if (close == std::string::npos) {
      error = "the coupling has no closing ')'";
      return out;
    }
    const std::vector<std::string_view> args = arguments_of(std::string_view(u).substr(open, close - open));
    if (args.size() < 5 || (args.size() - 2) % 3 != 0) {
      error =
          "EGON needs the following axis, the block change and a leading axis, numerator and denominator "
          "for each leading axis";
      return out;
    }
    GearboxCoupling c;
    c.following = std::string(args[0]);
    for (size_t i = 2; i + 2 < args.size(); i += 3) {
      c.leading.push_back(
          {std::string(args[i]), nc_text::parse_number(args[i + 1]), nc_text::parse_number(args[i + 2])});
    }
    out.push_back(std::move(c));
  }
  return out;
}

// A correction layer's main program (render_main_program): both subprograms called, X coupled
// to C through the design table and to SIM1 through the layer, SIM1 to C 1:1, nothing else.
Status check_layered_main(std::string_view program, std::string_view template_name,
                          const std::map<std::string, std::string>& values) {
  const std::string& subprogram = values.at("program_name");
  const std::string& number = values.at("table_number");
  const std::string& design_subprogram = values.at("design_program_name");
  const std::string& design_number = values.at("design_table_number");
  const std::string layer_axis = upper(values.count("leading_axis") ? values.at("leading_axis") : "SIM1");
  auto refuse = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(template_name) + ": the rendered main program of a correction layer " + why +
                          "; call {{design_program_name}} and {{program_name}}, couple EGON(" + layer_axis +
                          ",\"FINE\",C,1,1) and EGON(X,\"FINE\",C,{{design_table_number}},0," + layer_axis +
                          ",{{table_number}},0), as examples/sinumerik/cam_main_layer.mpf does (docs/nc_output.md)");
  };
  if (number == design_number) {
    return refuse("would couple the design and the layer through the same curve table " + number +
                  "; give the design table a number of its own");
  }
  auto is_number = [](const std::optional<double>& v, const std::string& n) {
    return v && n == std::to_string(static_cast<long long>(*v)) && *v == std::floor(*v);
  };
  bool calls = false;
  bool calls_design = false;
  bool x_coupled = false;
  bool layer_follows_c = false;
  bool leadon = false;
  const std::vector<std::string_view> lines = lines_of(program);
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view code = block_code(lines[i]);
    calls = calls || calls_program(code, subprogram);
    calls_design = calls_design || calls_program(code, design_subprogram);
    std::string error;
    const std::vector<GearboxCoupling> found = gearbox_couplings_on(code, leadon, error);
    const std::string where = " at line " + std::to_string(i + 1);
    if (!error.empty()) return refuse("has a coupling that cannot be read" + where + " (" + error + ")");
    if (leadon) return refuse("couples with LEADON" + where + ", which takes one leading axis");
    for (const GearboxCoupling& c : found) {
      if (c.following == "X") {
        bool design = false;
        bool layer = false;
        for (const LeadingLink& l : c.leading) {
          const bool table = l.denominator && *l.denominator == 0.0;
          if (l.axis == "C" && table && is_number(l.numerator, design_number)) {
            design = true;
          } else if (l.axis == layer_axis && table && is_number(l.numerator, number)) {
            layer = true;
          } else {
            return refuse("couples X to " + l.axis + where + " otherwise than through the design table " +
                          design_number + " (from C) or the layer " + number + " (from " + layer_axis + ")");
          }
        }
        if (!design || !layer) {
          return refuse("couples X" + where + " without " +
                        (design ? "the layer " + number + " from " + layer_axis
                                : "the design table " + design_number + " from C") +
                        ": the gearbox would grind " + (design ? "without the correction" : "the correction alone"));
        }
        x_coupled = true;
      } else if (c.following == layer_axis) {
        if (c.leading.size() != 1 || c.leading[0].axis != "C" || !c.leading[0].numerator || !c.leading[0].denominator ||
            *c.leading[0].denominator == 0.0 || *c.leading[0].numerator != *c.leading[0].denominator) {
          return refuse("couples " + layer_axis + where +
                        " otherwise than to C 1:1: the layer would be read at "
                        "another angle than the design");
        }
        layer_follows_c = true;
      } else {
        return refuse("couples axis " + c.following + where + "; a lobe's layer couples X and " + layer_axis + " only");
      }
    }
  }
  if (!calls_design) return refuse("does not call the design table's subprogram " + design_subprogram);
  if (!calls) return refuse("does not call the layer's subprogram " + subprogram);
  if (!x_coupled) return refuse("does not couple X to the design table and the layer");
  if (!layer_follows_c) return refuse("does not couple " + layer_axis + " to C");
  return {};
}

}  // namespace

Result<int> coupled_table_number(std::string_view program, std::string_view file_name,
                                 std::string_view following_axis) {
  const std::vector<std::string_view> lines = lines_of(program);
  const std::string axis = upper(following_axis);
  // A correction layer's main program: the table pushed is the one coupled from SIM1.
  for (const std::string_view line : lines) {
    std::string error;
    bool leadon = false;
    for (const GearboxCoupling& c : gearbox_couplings_on(block_code(line), leadon, error)) {
      if (!axis.empty() && c.following != axis) continue;
      for (const LeadingLink& l : c.leading) {
        if (l.axis == kLayerLeadingAxis && l.denominator && *l.denominator == 0.0 && l.numerator) {
          return static_cast<int>(*l.numerator);
        }
      }
    }
  }
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

std::string design_program_name(std::string_view program_name) { return std::string(program_name) + "_DESIGN"; }

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
  const bool layered = values.count("design_table_number") != 0;
  if (layered != (values.count("design_program_name") != 0)) {
    return make_error(ErrorCode::kInvalidInput, std::string(template_name) +
                                                    ": a correction layer needs both design_table_number and "
                                                    "design_program_name to render its main program, not one of them");
  }
  Result<std::string> program = render_nc_template(template_text, template_name, values);
  if (!program) return program.error();
  if (layered) {
    if (with_y) {
      return make_error(ErrorCode::kInvalidInput,
                        std::string(template_name) + ": a correction layer is a lobe's; a crankpin has no layer");
    }
    if (Status c = check_layered_main(*program, template_name, values); !c) return c.error();
    return program;
  }
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
