// The slides' compensation files: LEC (%_N_AX_EEC_INI) and CEC (%_N_NC_CEC_INI).
#include "nc_out/slide_compensation.h"

#include <cctype>
#include <cmath>
#include <optional>

#include "core/number_text.h"
#include "nc_out/nc_text.h"
#include "nc_out/table_program.h"

namespace gaugeloop {
namespace {

using nc_text::code_of;
using nc_text::lines_of;
using nc_text::parse_int;
using nc_text::parse_number;
using nc_text::trim;
using nc_text::upper;

constexpr std::string_view kKind = "slide compensation";
constexpr int kDecimals = 4;  // mm: 0.1 um

std::string_view first_line(SlideTableKind kind) {
  return kind == SlideTableKind::kLeadscrew ? "%_N_AX_EEC_INI" : "%_N_NC_CEC_INI";
}

bool is_axis_name(const std::string& n) {
  if (n.empty() || n.size() > 32) return false;
  for (const char c : n) {
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_') return false;
  }
  return true;
}

const std::string& name_of(const SlideAxisNames& names, char axis) { return axis == 'Y' ? names.y : names.z; }

// The control's value for an error the table takes out: LEC moves the axis against a positive
// value, CEC adds it to the output axis' position.
double control_value(SlideTableKind kind, double error_mm) {
  return kind == SlideTableKind::kLeadscrew ? error_mm : -error_mm;
}

std::string mm(double v) {
  const std::string s = format_fixed(nc_text::round_to(v, kDecimals), kDecimals);
  return s == "-0.0000" ? "0.0000" : s;
}

// One assignment line: $NAME[args]=value, read.
struct Assignment {
  std::string name;               // upper case, with the $
  std::vector<std::string> args;  // trimmed, upper case, parentheses kept
  std::string value;              // trimmed
};

std::optional<Assignment> assignment_of(std::string_view code) {
  if (code.empty() || code.front() != '$') return std::nullopt;
  const std::size_t open = code.find('[');
  const std::size_t close = code.find(']');
  const std::size_t eq = code.find('=', close == std::string_view::npos ? 0 : close);
  if (open == std::string_view::npos || close == std::string_view::npos || eq == std::string_view::npos ||
      close < open || eq < close) {
    return std::nullopt;
  }
  Assignment a;
  a.name = upper(trim(code.substr(0, open)));
  std::string_view args = code.substr(open + 1, close - open - 1);
  while (true) {
    const std::size_t comma = args.find(',');
    a.args.push_back(upper(trim(args.substr(0, comma))));
    if (comma == std::string_view::npos) break;
    args.remove_prefix(comma + 1);
  }
  if (!trim(code.substr(close + 1, eq - close - 1)).empty()) return std::nullopt;
  a.value = std::string(trim(code.substr(eq + 1)));
  return a;
}

}  // namespace

std::string_view slide_compensation_file_name(SlideTableKind kind) {
  return kind == SlideTableKind::kLeadscrew ? "AX_EEC.INI" : "NC_CEC.INI";
}

Result<std::string> render_slide_compensation(SlideTableKind kind, const std::vector<SlideCompensationTable>& tables,
                                              const SlideAxisNames& names,
                                              const std::map<std::string, std::string>& header) {
  for (const std::string* n : {&names.y, &names.z}) {
    if (!is_axis_name(*n)) {
      return make_error(ErrorCode::kInvalidInput, "`" + *n + "` is not a machine axis' name (letters, digits, _)");
    }
  }
  if (names.y == names.z) {
    return make_error(ErrorCode::kInvalidInput, "Y and Z are both named `" + names.y + "`: each needs its own name");
  }
  std::string body = "CHANDATA(1)";
  int count = 0;
  int points = 0;
  bool lec_axis_done[2] = {false, false};
  for (const SlideCompensationTable& t : tables) {
    if (t.kind != kind) continue;
    const std::string what = std::string(kind == SlideTableKind::kLeadscrew ? "LEC" : "CEC") + " table of " +
                             std::string(1, t.output_axis) + " over " + std::string(1, t.input_axis);
    if (t.error_mm.empty()) return make_error(ErrorCode::kInvalidInput, "the " + what + " has no points");
    if (!(t.step_mm > 0.0) || !std::isfinite(t.step_mm) || !std::isfinite(t.min_mm)) {
      return make_error(ErrorCode::kInvalidInput, "the " + what + ": its step must be positive, its start finite");
    }
    if ((t.input_axis != 'Y' && t.input_axis != 'Z') || (t.output_axis != 'Y' && t.output_axis != 'Z')) {
      return make_error(ErrorCode::kInvalidInput, "a slide table acts on Y or Z, over Y or Z");
    }
    if (kind == SlideTableKind::kLeadscrew) {
      if (t.input_axis != t.output_axis) {
        return make_error(ErrorCode::kInvalidInput, "the " + what + ": an LEC table is of one axis over itself");
      }
      bool& done = lec_axis_done[t.output_axis == 'Y' ? 0 : 1];
      if (done) return make_error(ErrorCode::kInvalidInput, "two LEC tables of " + std::string(1, t.output_axis));
      done = true;
    }
    for (std::size_t i = 0; i < t.error_mm.size(); ++i) {
      if (!std::isfinite(t.error_mm[i])) {
        return make_error(ErrorCode::kInvalidInput, "the " + what + ": point " + std::to_string(i) + " is not finite");
      }
    }
    const std::string n = std::to_string(count);
    const std::string out_name = name_of(names, t.output_axis);
    if (kind == SlideTableKind::kLeadscrew) {
      for (std::size_t i = 0; i < t.error_mm.size(); ++i) {
        body +=
            "\n$AA_ENC_COMP[0," + std::to_string(i) + "," + out_name + "]=" + mm(control_value(kind, t.error_mm[i]));
      }
      body += "\n$AA_ENC_COMP_STEP[0," + out_name + "]=" + mm(t.step_mm);
      body += "\n$AA_ENC_COMP_MIN[0," + out_name + "]=" + mm(t.min_mm);
      body += "\n$AA_ENC_COMP_MAX[0," + out_name + "]=" + mm(t.max_mm());
      body += "\n$AA_ENC_COMP_IS_MODULO[0," + out_name + "]=0";
    } else {
      for (std::size_t i = 0; i < t.error_mm.size(); ++i) {
        body += "\n$AN_CEC[" + n + "," + std::to_string(i) + "]=" + mm(control_value(kind, t.error_mm[i]));
      }
      body += "\n$AN_CEC_INPUT_AXIS[" + n + "]=(" + name_of(names, t.input_axis) + ")";
      body += "\n$AN_CEC_OUTPUT_AXIS[" + n + "]=(" + out_name + ")";
      body += "\n$AN_CEC_STEP[" + n + "]=" + mm(t.step_mm);
      body += "\n$AN_CEC_MIN[" + n + "]=" + mm(t.min_mm);
      body += "\n$AN_CEC_MAX[" + n + "]=" + mm(t.max_mm());
      body += "\n$AN_CEC_DIRECTION[" + n + "]=0";
      body += "\n$AN_CEC_MULT_BY_TABLE[" + n + "]=0";
      body += "\n$AN_CEC_IS_MODULO[" + n + "]=0";
    }
    ++count;
    points += static_cast<int>(t.error_mm.size());
  }
  if (count == 0) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string("no ") + (kind == SlideTableKind::kLeadscrew ? "LEC" : "CEC") + " table to write");
  }
  std::string out(first_line(kind));
  out += kind == SlideTableKind::kLeadscrew ? "\n; the slides' leadscrew error compensation"
                                            : "\n; the slides' sag and angularity compensation";
  append_header_line(out, "kind", std::string(kKind));
  std::map<std::string, std::string> all = header;
  all["y_axis_name"] = names.y;
  all["z_axis_name"] = names.z;
  for (const auto& [key, value] : all) append_header_line(out, key, value);
  append_header_line(out, "table_count", std::to_string(count));
  append_header_line(out, "point_count", std::to_string(points));
  append_header_line(out, "body_checksum_fnv1a64", table_body_checksum(body));
  out += "\n" + body + "\nM17\n";
  return out;
}

Result<std::vector<SlideCompensationTable>> parse_slide_compensation(std::string_view text, std::string_view file_name,
                                                                     const SlideAxisNames& names) {
  const std::vector<std::string_view> lines = lines_of(text);
  auto fail = [&](std::size_t i, const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ":" + std::to_string(i + 1) + ": " + why);
  };
  std::optional<SlideTableKind> kind;
  std::map<std::string, std::string> header;
  std::string body;
  bool in_body = false, ended = false;
  // Per table (LEC: by axis; CEC: by number): its values by point and its parameters.
  struct Draft {
    std::map<int, double> values;
    std::map<std::string, double> numbers;
    std::map<std::string, std::string> axes;
    std::size_t first_line = 0;
  };
  std::map<std::string, Draft> drafts;
  std::vector<std::string> order;
  auto axis_letter = [&](std::string v) -> std::optional<char> {
    if (v.size() > 2 && v.front() == '(' && v.back() == ')') v = v.substr(1, v.size() - 2);
    if (v == upper(names.y)) return 'Y';
    if (v == upper(names.z)) return 'Z';
    return std::nullopt;
  };
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string_view l = trim(lines[i]);
    if (!kind) {
      if (l.empty()) continue;
      if (upper(l) == first_line(SlideTableKind::kLeadscrew)) {
        kind = SlideTableKind::kLeadscrew;
      } else if (upper(l) == first_line(SlideTableKind::kInterpolatory)) {
        kind = SlideTableKind::kInterpolatory;
      } else {
        return fail(i, "the file begins with `" + std::string(l) + "`, not %_N_AX_EEC_INI or %_N_NC_CEC_INI");
      }
      continue;
    }
    if (!in_body && read_header_line(l, header)) continue;
    const std::string_view code = code_of(l);
    if (code.empty()) {
      if (in_body && !ended) body += "\n" + std::string(lines[i]);
      continue;
    }
    if (ended) return fail(i, "a line after M17");
    if (upper(code) == "M17") {
      ended = true;
      continue;
    }
    body += (in_body ? "\n" : "") + std::string(lines[i]);
    if (!in_body) {
      in_body = true;
      if (upper(code) != "CHANDATA(1)") return fail(i, "`" + std::string(code) + "`: expected CHANDATA(1) first");
      continue;
    }
    const std::optional<Assignment> a = assignment_of(code);
    if (!a) return fail(i, "`" + std::string(code) + "`: not an assignment $NAME[...]=value");
    const bool lec = *kind == SlideTableKind::kLeadscrew;
    const std::string prefix = lec ? "$AA_ENC_COMP" : "$AN_CEC";
    if (a->name.rfind(prefix, 0) != 0) {
      return fail(i, "`" + a->name + "` in a " + std::string(lec ? "LEC" : "CEC") + " file: gaugeloop reads only " +
                         prefix + "...");
    }
    const std::string param = a->name.substr(prefix.size());  // "" for the values
    std::string key;
    if (lec) {
      const std::size_t want = param.empty() ? 3 : 2;
      if (a->args.size() != want || a->args.front() != "0")
        return fail(i, "expected [0," + std::string(param.empty() ? "N," : "") + "axis]");
      key = a->args.back();
      if (!axis_letter(key))
        return fail(i, "axis `" + key + "` is neither Y (" + names.y + ") nor Z (" + names.z + ")");
    } else {
      const std::size_t want = param.empty() ? 2 : 1;
      if (a->args.size() != want || !parse_int(a->args.front()))
        return fail(i, "expected [t" + std::string(param.empty() ? ",N" : "") + "]");
      key = a->args.front();
    }
    if (drafts.find(key) == drafts.end()) {
      order.push_back(key);
      drafts[key].first_line = i;
    }
    Draft& d = drafts[key];
    if (param.empty()) {
      const std::optional<int> n = parse_int(a->args[1]);
      const std::optional<double> v = parse_number(a->value);
      if (!n || *n < 0 || *n > 100000) return fail(i, "point `" + a->args[1] + "` is not a point number");
      if (!v) return fail(i, "`" + a->value + "` is not a number");
      if (!d.values.emplace(*n, *v).second) return fail(i, "point " + std::to_string(*n) + " is given twice");
      continue;
    }
    if (param == "_INPUT_AXIS" || param == "_OUTPUT_AXIS") {
      if (lec) return fail(i, "`" + a->name + "` is not an LEC parameter");
      const std::optional<char> axis = axis_letter(upper(a->value));
      if (!axis) return fail(i, "axis `" + a->value + "` is neither Y (" + names.y + ") nor Z (" + names.z + ")");
      d.axes[param] = std::string(1, *axis);
      continue;
    }
    const std::optional<double> v = parse_number(a->value);
    if (!v) return fail(i, "`" + a->value + "` is not a number");
    const bool known = param == "_STEP" || param == "_MIN" || param == "_MAX" || param == "_IS_MODULO" ||
                       (!lec && (param == "_DIRECTION" || param == "_MULT_BY_TABLE"));
    if (!known) return fail(i, "`" + a->name + "`: gaugeloop does not read this parameter");
    if ((param == "_IS_MODULO" || param == "_DIRECTION" || param == "_MULT_BY_TABLE") && *v != 0.0) {
      return fail(i, "`" + a->name + "=" + a->value + "`: gaugeloop writes and reads tables with it 0 only");
    }
    d.numbers[param] = *v;
  }
  if (!kind) return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": empty");
  if (!ended) return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": no M17 at the end");
  while (!body.empty() && body.back() == '\n') body.pop_back();
  const auto sum = header.find("body_checksum_fnv1a64");
  if (header.find("kind") == header.end() || header.at("kind") != kKind || sum == header.end()) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) +
                                                    ": no `; gaugeloop kind: slide compensation` and checksum header "
                                                    "lines; not a table gaugeloop wrote");
  }
  if (sum->second != table_body_checksum(body)) {
    return make_error(ErrorCode::kRefused, std::string(file_name) +
                                               ": the tables were edited by hand: their checksum is " +
                                               table_body_checksum(body) + ", the header says " + sum->second);
  }
  std::vector<SlideCompensationTable> out;
  for (const std::string& key : order) {
    const Draft& d = drafts.at(key);
    SlideCompensationTable t;
    t.kind = *kind;
    if (*kind == SlideTableKind::kLeadscrew) {
      t.input_axis = t.output_axis = *axis_letter(key);
    } else {
      if (d.axes.count("_INPUT_AXIS") == 0 || d.axes.count("_OUTPUT_AXIS") == 0) {
        return fail(d.first_line, "CEC table " + key + " has no input or output axis");
      }
      t.input_axis = d.axes.at("_INPUT_AXIS")[0];
      t.output_axis = d.axes.at("_OUTPUT_AXIS")[0];
    }
    for (const char* p : {"_STEP", "_MIN", "_MAX"}) {
      if (d.numbers.count(p) == 0)
        return fail(d.first_line, "table " + key + " has no " + std::string(p + 1) + " (" +
                                      std::string(*kind == SlideTableKind::kLeadscrew ? "$AA_ENC_COMP" : "$AN_CEC") +
                                      p + ")");
    }
    t.step_mm = d.numbers.at("_STEP");
    t.min_mm = d.numbers.at("_MIN");
    for (int n = 0; n < static_cast<int>(d.values.size()); ++n) {
      const auto v = d.values.find(n);
      if (v == d.values.end()) return fail(d.first_line, "table " + key + " lacks point " + std::to_string(n));
      t.error_mm.push_back(control_value(*kind, v->second));
    }
    if (!(t.step_mm > 0.0) || t.error_mm.empty() || std::abs(t.max_mm() - d.numbers.at("_MAX")) > 1e-4) {
      return fail(d.first_line, "table " + key + ": MAX " + mm(d.numbers.at("_MAX")) + " is not MIN + STEP x " +
                                    std::to_string(t.error_mm.size() > 0 ? t.error_mm.size() - 1 : 0) + " (" +
                                    mm(t.max_mm()) + "), or it has no point");
    }
    out.push_back(std::move(t));
  }
  return out;
}

std::map<std::string, std::string> program_header(std::string_view text) {
  std::map<std::string, std::string> header;
  for (const std::string_view line : lines_of(text)) {
    const std::string_view l = trim(line);
    if (read_header_line(l, header)) continue;
    if (!l.empty() && l.front() != ';' && l.front() != '%') break;  // the body
  }
  return header;
}

bool is_slide_compensation(std::string_view text) {
  const std::map<std::string, std::string> header = program_header(text);
  const auto kind = header.find("kind");
  return kind != header.end() && kind->second == kKind;
}

Result<std::vector<SlideCompensationTable>> parse_slide_compensation(std::string_view text,
                                                                     std::string_view file_name) {
  const std::map<std::string, std::string> header = program_header(text);
  SlideAxisNames names;
  if (const auto y = header.find("y_axis_name"); y != header.end()) names.y = y->second;
  if (const auto z = header.find("z_axis_name"); z != header.end()) names.z = z->second;
  return parse_slide_compensation(text, file_name, names);
}

}  // namespace gaugeloop
