// Header, checksum, rendering with read-back, and the parser of a pushed table program.
#include "nc_out/table_program.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <optional>
#include <variant>

#include "core/number_text.h"
#include "nc_out/nc_template.h"
#include "nc_out/nc_text.h"

namespace gaugeloop {
namespace {

using nc_text::code_of;
using nc_text::parse_int;
using nc_text::parse_number;
using nc_text::trim;
using nc_text::upper;
using nc_text::words_of;

constexpr std::string_view kHeaderPrefix = "; gaugeloop ";

// Lines without their '\n' or trailing '\r'.
std::vector<std::string_view> split_lines(std::string_view text) {
  std::vector<std::string_view> lines;
  size_t pos = 0;
  while (pos <= text.size()) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view l = text.substr(pos, nl - pos);
    if (!l.empty() && l.back() == '\r') l.remove_suffix(1);
    lines.push_back(l);
    if (nl == text.size()) break;
    pos = nl + 1;
  }
  return lines;
}

// The following axis the template's CTABDEF names (its first argument, upper case), so that
// the blocks are written under the axis the table defines: X for the infeed, Y for the wheel
// height of a crankpin ground C-X-Y. X when the template has no readable CTABDEF; the
// read-back then refuses it with its line.
std::string template_following_axis(std::string_view template_text) {
  for (const std::string_view line : split_lines(template_text)) {
    const std::vector<std::string_view> words = words_of(code_of(line));
    if (words.empty() || upper(words.front()).rfind("CTABDEF", 0) != 0) continue;
    const std::string_view code = code_of(line);
    const size_t open = code.find('(');
    if (open == std::string_view::npos) break;
    const std::string_view rest = code.substr(open + 1);
    const std::string axis = upper(trim(rest.substr(0, rest.find_first_of(",)"))));
    const bool name = !axis.empty() && std::isalpha(static_cast<unsigned char>(axis.front())) &&
                      std::all_of(axis.begin(), axis.end(), [](char ch) {
                        return ch == '_' || std::isalnum(static_cast<unsigned char>(ch)) != 0;
                      });
    if (name) return axis;
    break;
  }
  return "X";
}

}  // namespace

Result<std::string> archive_header(std::string_view name, NcProgramKind kind) {
  const bool ok = !name.empty() && name.size() <= 24 && std::all_of(name.begin(), name.end(), [](char ch) {
    return ch == '_' || std::isalnum(static_cast<unsigned char>(ch)) != 0;
  });
  if (!ok) {
    return make_error(ErrorCode::kInvalidInput,
                      "program `" + std::string(name) +
                          "` cannot carry an archive header: the HMI reads a punched-tape file name of 1 to 24 "
                          "letters, digits or '_'; rename the program or set [nc] archive_header = false");
  }
  const bool main = kind == NcProgramKind::kMainProgram;
  return "%_N_" + std::string(name) + (main ? "_MPF" : "_SPF") + "\n;$PATH=/_N_" + (main ? "MPF" : "SPF") + "_DIR\n";
}

bool has_archive_header(std::string_view program) { return !program.empty() && program.front() == '%'; }

std::string table_body_checksum(std::string_view body) {
  std::uint64_t h = 14695981039346656037ull;  // FNV-1a 64-bit offset basis
  for (char ch : body) {
    if (ch == '\r') continue;
    h ^= static_cast<unsigned char>(ch);
    h *= 1099511628211ull;  // FNV 64-bit prime
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

int table_number_for_version(const TableNumbers& numbers, std::int64_t table_version) {
  return table_version <= 0 ? numbers[0] : numbers[static_cast<std::size_t>((table_version - 1) % 2)];
}

void append_header_line(std::string& out, std::string_view key, std::string_view value) {
  if (!out.empty()) out += '\n';
  out += kHeaderPrefix;
  out += key;
  out += ": ";
  out += value;
}

bool read_header_line(std::string_view line, std::map<std::string, std::string>& header) {
  if (line.substr(0, kHeaderPrefix.size()) != kHeaderPrefix) return false;
  const std::string_view kv = line.substr(kHeaderPrefix.size());
  const size_t colon = kv.find(':');
  if (colon != std::string_view::npos) {
    header[std::string(trim(kv.substr(0, colon)))] = std::string(trim(kv.substr(colon + 1)));
  }
  return true;
}

std::string render_table_header(const CurveTable& table, const TableProvenance& provenance, std::string_view body) {
  std::string out;
  auto line = [&out](std::string_view key, const std::string& value) { append_header_line(out, key, value); };
  line("run_id", std::to_string(provenance.run_id));
  line("table_version", std::to_string(provenance.table_version));
  if (provenance.table_numbers[0] != 0) {
    line("table_number", std::to_string(table_number_for_version(provenance.table_numbers, provenance.table_version)));
    line("table_numbers",
         std::to_string(provenance.table_numbers[0]) + " " + std::to_string(provenance.table_numbers[1]));
  }
  line("interpolation", std::string(interpolation_name(table.interpolation)));
  line("point_count", std::to_string(table.points.size()));
  line("block_count", std::to_string(table.block_count()));
  line("command_error_um", format_fixed(table.error.max_abs_um, 3));
  line("command_error_at_c_deg", format_fixed(table.error.at_c_deg, 3));
  line("seam_c_deg", table.points.empty() ? std::string("0.000") : format_fixed(table.points.front().c_deg, 3));
  line("writer", table.writer);
  if (!provenance.grinding_cycle.empty()) line("grinding_cycle", provenance.grinding_cycle);
  if (!provenance.part.empty()) {
    line("part", provenance.part);
    line("lobe", std::to_string(provenance.lobe));
  }
  if (!provenance.pin_mode.empty()) line("pin_mode", provenance.pin_mode);
  if (provenance.design_table_number != 0) {
    line("design_program", provenance.design_program);
    line("design_table_number", std::to_string(provenance.design_table_number));
  }
  line("body_checksum_fnv1a64", table_body_checksum(body));
  return out;
}

namespace {

// What the table's following axis holds, as one comment line.
std::string table_note(const std::string& axis, const TableProvenance& p) {
  if (p.design_table_number != 0) {
    return axis + ": the correction alone, mm, added by the gearbox to the design table " +
           std::to_string(p.design_table_number) + " (" + p.design_program +
           ".SPF); SIM1: the virtual axis following C 1:1, degrees.";
  }
  if (!p.layer_program.empty()) {
    return axis + ": wheel infeed in mm from the base-circle position, the design's whole path; the correction is " +
           "the layer " + p.layer_program + ".SPF, added by the gearbox; C: work spindle in degrees.";
  }
  if (!p.pin_mode.empty()) {
    return axis + ": wheel infeed in mm, 0 with the pin farthest from the wheel, twice its throw with it nearest; " +
           "C: work spindle in degrees.";
  }
  return axis + ": wheel infeed in mm from the base-circle position; C: work spindle in degrees.";
}

}  // namespace

Result<std::string> render_table_program(std::string_view template_text, std::string_view template_name,
                                         std::map<std::string, std::string> values, const CurveTable& table,
                                         const TableProvenance& provenance, const CurveTableFormat& format) {
  if (Status s = validate_curve_points(table.points); !s) return s.error();
  const std::string axis = template_following_axis(template_text);
  const bool layer = provenance.design_table_number != 0;
  const std::string leading = layer ? std::string(kLayerLeadingAxis) : std::string("C");
  const std::string body = render_table_blocks(table.points, table.interpolation, format, axis, leading);
  values["table_blocks"] = body;
  values["table_header"] = render_table_header(table, provenance, body);
  values["point_count"] = std::to_string(table.points.size());
  values["block_count"] = std::to_string(table.block_count());
  values["interpolation"] = std::string(interpolation_name(table.interpolation));
  values["command_error_um"] = format_fixed(table.error.max_abs_um, 3);
  const bool numbered = provenance.table_numbers[0] != 0;
  const int number = table_number_for_version(provenance.table_numbers, provenance.table_version);
  if (numbered) values["table_number"] = std::to_string(number);
  values["leading_axis"] = leading;
  const std::string number_text = values.count("lobe") != 0 ? values.at("lobe") : std::to_string(provenance.lobe);
  values["table_subject"] = (provenance.pin_mode.empty() ? "lobe " : "pin ") + number_text;
  values["table_note"] = table_note(axis, provenance);
  Result<std::string> program = render_nc_template(template_text, template_name, values);
  if (!program) return program.error();
  // Read back what would be pushed: it must be the table we meant, checksum and all.
  auto refuse = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(template_name) +
                                                    ": the rendered program does not read back as the table written (" +
                                                    why +
                                                    "); put {{table_header}} before CTABDEF and "
                                                    "{{table_blocks}} alone between CTABDEF and CTABEND");
  };
  Result<ParsedTable> back = parse_table_program(*program, template_name);
  if (!back) return refuse(back.error().message);
  if (Status s = verify_table_checksum(*back, template_name); !s) return refuse(s.error().message);
  if (Status s = compare_table_points(*back, table.points, template_name, format); !s) {
    return refuse(s.error().message);
  }
  if (back->interpolation != table.interpolation) return refuse("interpolation differs");
  if (numbered && back->table_number != number) {
    return refuse("CTABDEF names table " + std::to_string(back->table_number) + ", not table " +
                  std::to_string(number) + "; write CTABDEF(" + axis + ",{{leading_axis}},{{table_number}},1)");
  }
  if (layer && nc_text::upper(back->leading_axis) != leading) {
    return refuse("CTABDEF's leading axis is " + back->leading_axis + ", not " + leading +
                  (layer ? ", the virtual axis a correction layer follows" : std::string()) + "; write CTABDEF(" +
                  axis + ",{{leading_axis}},{{table_number}},1)");
  }
  return program;
}

namespace {

// CTABDEF(following axis, leading axis, table number, periodicity[, memory]) on `code` into
// `t`. Returns why it cannot be read; empty when it was.
std::string read_ctabdef(std::string_view code, ParsedTable& t) {
  // Rejoin: the arguments may contain blanks.
  const size_t open = code.find('(');
  const size_t close = code.rfind(')');
  if (open == std::string_view::npos || close == std::string_view::npos || close < open) {
    return "CTABDEF needs (following axis, leading axis, table number, periodicity)";
  }
  std::vector<std::string_view> args;
  std::string_view rest = code.substr(open + 1, close - open - 1);
  while (true) {
    const size_t comma = rest.find(',');
    args.push_back(trim(rest.substr(0, comma)));
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  std::optional<int> n = args.size() >= 4 ? parse_int(args[2]) : std::nullopt;
  std::optional<int> p = args.size() >= 4 ? parse_int(args[3]) : std::nullopt;
  if (args.size() < 4 || args.size() > 5 || args[0].empty() || args[1].empty() || !n || !p) {
    return "CTABDEF needs (following axis, leading axis, table number, periodicity[, memory])";
  }
  t.following_axis = upper(args[0]);
  t.leading_axis = upper(args[1]);
  t.table_number = *n;
  t.periodicity = *p;
  return "";
}

// The spline's end conditions, modal as on the control: the last of BAUTO/BNAT/BTAN and of
// EAUTO/ENAT/ETAN programmed.
struct SplineEnds {
  bool bnat = false;
  bool enat = false;
};

// One block between CTABDEF and CTABEND: its point (if it has one) appended to `t`, line
// `line` (1-based) kept with it. Returns why it cannot be read; empty when it was.
// `PO[axis]=(end[,a2[,a3]])` of a POLY block: the axis and its values, or why not.
struct PolyWord {
  std::string axis;
  std::vector<double> values;
};
std::variant<PolyWord, std::string> read_poly_word(std::string_view w) {
  const std::string u = upper(w);
  const std::size_t close = u.find("]=(");
  if (close == std::string::npos || u.back() != ')') return "`" + std::string(w) + "`: expected PO[axis]=(end,a2,a3)";
  PolyWord out;
  out.axis = u.substr(3, close - 3);
  std::string_view rest = w.substr(close + 3, w.size() - close - 4);
  while (true) {
    const std::size_t comma = rest.find(',');
    const std::optional<double> v = parse_number(trim(rest.substr(0, comma)));
    if (!v) return "`" + std::string(w) + "`: not a number in the polynomial's values";
    out.values.push_back(*v);
    if (comma == std::string_view::npos) break;
    rest = rest.substr(comma + 1);
  }
  if (out.values.size() > 3) return "`" + std::string(w) + "`: a cubic has the end point, a2 and a3 at most";
  return out;
}

std::string read_table_block(const std::vector<std::string_view>& words, int line, ParsedTable& t, SplineEnds& ends) {
  std::optional<double> c;
  std::optional<double> x;
  double a2 = 0.0;
  double a3 = 0.0;
  std::optional<Interpolation> mode;
  for (std::string_view w : words) {
    const std::string u = upper(w);
    if (u == "G1" || u == "G01") {
      mode = Interpolation::kLinear;
    } else if (u == "CSPLINE") {
      mode = Interpolation::kCubicSpline;
    } else if (u == "POLY") {
      mode = Interpolation::kPoly;
    } else if (u.rfind("PO[", 0) == 0) {
      std::variant<PolyWord, std::string> po = read_poly_word(w);
      if (const std::string* why = std::get_if<std::string>(&po)) return *why;
      const PolyWord& pw = std::get<PolyWord>(po);
      if (pw.axis == t.leading_axis) {
        if (pw.values.size() != 1) {
          return "`" + std::string(w) + "`: the leading axis is given by its end point alone (it moves linearly)";
        }
        c = pw.values[0];
      } else if (pw.axis == t.following_axis) {
        x = pw.values[0];
        a2 = pw.values.size() > 1 ? pw.values[1] : 0.0;
        a3 = pw.values.size() > 2 ? pw.values[2] : 0.0;
      } else {
        return "`" + std::string(w) + "`: neither the leading axis " + t.leading_axis + " nor the following axis " +
               t.following_axis;
      }
    } else if (u == "BNAT" || u == "ENAT" || u == "BAUTO" || u == "EAUTO" || u == "BTAN" || u == "ETAN") {
      // Only BNAT + ENAT is modelled; the others are read so that natural_ends says no.
      if (u[0] == 'B') ends.bnat = u == "BNAT";
      if (u[0] == 'E') ends.enat = u == "ENAT";
    } else {
      bool read = false;
      for (const std::string* a : {&t.leading_axis, &t.following_axis}) {
        if (u.size() > a->size() && u.compare(0, a->size(), *a) == 0) {
          std::string_view value = w.substr(a->size());
          if (!value.empty() && value.front() == '=') value.remove_prefix(1);
          const std::optional<double> v = parse_number(value);
          if (!v) return "`" + std::string(w) + "`: not a number after " + *a;
          (*a == t.leading_axis ? c : x) = *v;
          read = true;
          break;
        }
      }
      if (!read) {
        return "`" + std::string(w) + "` in the curve table: gaugeloop reads only G1, CSPLINE, BNAT/ENAT, POLY " +
               "with PO[axis]=(...) (PL not programmed), block numbers, " + t.leading_axis + " and " + t.following_axis;
      }
    }
  }
  if (!c && !x && !mode) return "";
  if (!c) return "a table block needs the leading axis " + t.leading_axis;
  if (!x && t.points.empty()) return "the first table block needs " + t.following_axis + " too";
  const Interpolation block_mode = mode ? *mode : (t.points.empty() ? Interpolation::kLinear : t.interpolation);
  if (t.points.size() == 1) {
    t.interpolation = block_mode;
  } else if (t.points.size() > 1 && block_mode != t.interpolation) {
    auto word = [](Interpolation i) {
      return i == Interpolation::kLinear ? "G1" : i == Interpolation::kCubicSpline ? "CSPLINE" : "POLY";
    };
    return std::string("the table mixes ") + word(t.interpolation) + " and " + word(block_mode) +
           " segments; gaugeloop models one kind per table";
  }
  if (!t.points.empty() && !(*c > t.points.back().c_deg)) {
    return t.leading_axis + " " + format_fixed(*c, 3) + " does not increase";
  }
  if ((a2 != 0.0 || a3 != 0.0) && block_mode != Interpolation::kPoly) {
    return "polynomial coefficients outside POLY: the block is not a cubic segment";
  }
  t.points.push_back({*c, x ? *x : t.points.back().x_mm, t.points.empty() ? 0.0 : a2, t.points.empty() ? 0.0 : a3});
  t.point_lines.push_back(line);
  return "";
}

}  // namespace

Result<ParsedTable> parse_table_program(std::string_view text, std::string_view file_name) {
  const std::vector<std::string_view> lines = split_lines(text);
  auto fail = [&](size_t index, const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ":" + std::to_string(index + 1) + ": " + why);
  };
  ParsedTable t;
  std::optional<size_t> def;
  std::optional<size_t> end;
  SplineEnds ends;
  for (size_t i = 0; i < lines.size(); ++i) {
    const std::string_view l = trim(lines[i]);
    if (read_header_line(l, t.header)) continue;
    const std::vector<std::string_view> words = words_of(code_of(l));
    if (words.empty()) continue;
    const std::string first = upper(words.front());
    if (first.rfind("CTABDEF", 0) == 0) {
      if (def) return fail(i, "a second CTABDEF; gaugeloop reads programs with one curve table");
      if (std::string why = read_ctabdef(code_of(l), t); !why.empty()) return fail(i, why);
      t.ctabdef_line = static_cast<int>(i + 1);
      def = i;
      continue;
    }
    if (first == "CTABEND") {
      if (!def) return fail(i, "CTABEND without CTABDEF");
      if (end) return fail(i, "a second CTABEND");
      end = i;
      t.ctabend_line = static_cast<int>(i + 1);
      continue;
    }
    if (!def || end) continue;  // outside the table: the user's own program
    if (std::string why = read_table_block(words, static_cast<int>(i + 1), t, ends); !why.empty()) return fail(i, why);
  }
  if (!def)
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": no CTABDEF: not a curve table program");
  if (!end) return fail(*def, "CTABDEF is not closed by CTABEND");
  if (t.points.size() < 2) return fail(*def, "the curve table has fewer than 2 points");
  t.natural_ends = t.interpolation == Interpolation::kCubicSpline && ends.bnat && ends.enat;
  std::string body;
  for (size_t i = *def + 1; i < *end; ++i) {
    if (i > *def + 1) body += '\n';
    body += lines[i];
  }
  t.body_checksum = table_body_checksum(body);
  return t;
}

Status verify_table_checksum(const ParsedTable& table, std::string_view file_name) {
  auto it = table.header.find("body_checksum_fnv1a64");
  if (it == table.header.end()) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) +
                                                    ": no `; gaugeloop body_checksum_fnv1a64:` header line; "
                                                    "not a table gaugeloop wrote");
  }
  const std::string lines =
      "lines " + std::to_string(table.ctabdef_line + 1) + ".." + std::to_string(table.ctabend_line - 1);
  if (it->second != table.body_checksum) {
    return make_error(ErrorCode::kRefused, std::string(file_name) + ": the curve table (" + lines +
                                               ") was edited by hand: its checksum is " + table.body_checksum +
                                               ", the header says " + it->second +
                                               "; compare it with the pushed table (nc diff) before pushing over it");
  }
  auto pc = table.header.find("point_count");
  if (pc != table.header.end() && pc->second != std::to_string(table.points.size())) {
    return make_error(ErrorCode::kRefused, std::string(file_name) + ": the header says " + pc->second +
                                               " points, the table (" + lines + ") has " +
                                               std::to_string(table.points.size()) + "; edited by hand");
  }
  return {};
}

Status compare_table_points(const ParsedTable& table, const std::vector<CurvePoint>& expected,
                            std::string_view file_name, const CurveTableFormat& format) {
  const int xd = format.x_decimals();
  const size_t n = std::min(table.points.size(), expected.size());
  for (size_t i = 0; i < n; ++i) {
    const CurvePoint& a = table.points[i];
    const CurvePoint& b = expected[i];
    // Compare as written: the decimals the table carries, X on the control's grid. format_fixed
    // never writes a signed zero, so -0.0000 and 0.0000 compare equal.
    const std::string bx = format_fixed(format.round_x_mm(b.x_mm), xd);
    const int ad = format.coefficient_decimals();
    auto coefficients = [&](const CurvePoint& p) {
      return format_fixed(format.round_coefficient_mm(p.a2_mm), ad) + "," +
             format_fixed(format.round_coefficient_mm(p.a3_mm), ad);
    };
    if (format_fixed(a.c_deg, format.c_decimals) != format_fixed(b.c_deg, format.c_decimals) ||
        format_fixed(a.x_mm, xd) != bx || coefficients(a) != coefficients(b)) {
      return make_error(ErrorCode::kRefused,
                        std::string(file_name) + ":" + std::to_string(table.point_lines[i]) + ": point " +
                            std::to_string(i) + " reads C" + format_fixed(a.c_deg, format.c_decimals) + " " +
                            table.following_axis + format_fixed(a.x_mm, xd) + ", the pushed table has C" +
                            format_fixed(b.c_deg, format.c_decimals) + " " + table.following_axis + bx +
                            (coefficients(a) != coefficients(b)
                                 ? " (a2,a3 read " + coefficients(a) + ", pushed " + coefficients(b) + ")"
                                 : std::string()) +
                            "; edited by hand");
    }
  }
  if (table.points.size() != expected.size()) {
    return make_error(ErrorCode::kRefused, std::string(file_name) + ": the table has " +
                                               std::to_string(table.points.size()) + " points, the pushed one " +
                                               std::to_string(expected.size()) + "; edited by hand");
  }
  return {};
}

}  // namespace gaugeloop
