// The gear's stroke program and the gearbox's coupling lines.
#include "nc_out/stroke_program.h"

#include <algorithm>
#include <cmath>

#include "core/number_text.h"
#include "nc_out/curve_table.h"
#include "nc_out/nc_text.h"
#include "nc_out/table_program.h"

namespace gaugeloop {
namespace {

using nc_text::code_of;
using nc_text::lines_of;
using nc_text::parse_number;
using nc_text::trim;
using nc_text::upper;
using nc_text::words_of;

// A grid of `increments` per unit, as the control's for X (curve_table.h): the same rounding and
// decimals for Z (per mm) and SIM1 (per degree).
CurveTableFormat grid(double increments) {
  CurveTableFormat f;
  f.x_increments_per_mm = increments;
  return f;
}

}  // namespace

int StrokeProgramFormat::z_decimals() const { return grid(z_increments_per_mm).x_decimals(); }
int StrokeProgramFormat::sim_decimals() const { return grid(sim_increments_per_deg).x_decimals(); }
double StrokeProgramFormat::round_z_mm(double z) const { return grid(z_increments_per_mm).round_x_mm(z); }
double StrokeProgramFormat::round_sim_deg(double sim) const { return grid(sim_increments_per_deg).round_x_mm(sim); }

std::string render_gearbox_coupling(const GearboxFactors& f) {
  return "EGDEF(C,B,1,Z,1,Y,1,SIM1,1)\nEGON(C,\"FINE\",B," + std::to_string(f.b_numerator) + "," +
         std::to_string(f.b_denominator) + ",Z," + format_fixed(f.z_deg_per_mm, 12) + ",1,Y," +
         format_fixed(f.y_deg_per_mm, 12) + ",1,SIM1,1,1)";
}

namespace {
constexpr std::string_view kStrokeKind = "gear stroke";
}  // namespace

bool is_stroke_program(std::string_view text) {
  for (const std::string_view line : lines_of(text)) {
    std::map<std::string, std::string> header;
    const std::string_view l = trim(line);
    if (!read_header_line(l, header)) {
      if (l.empty() || l.front() == ';') continue;
      return false;  // the body: a stroke program's header comes before it
    }
    if (auto it = header.find("kind"); it != header.end()) return it->second == kStrokeKind;
  }
  return false;
}

Result<std::string> render_stroke_program(std::string_view program_name,
                                          const std::map<std::string, std::string>& header,
                                          const std::vector<StrokeProgramPoint>& points, double feed_mm_per_min,
                                          const StrokeProgramFormat& format) {
  if (points.size() < 2) return make_error(ErrorCode::kInvalidInput, "a stroke needs at least 2 spline points");
  if (!(feed_mm_per_min > 0.0 && feed_mm_per_min <= 100000.0)) {
    return make_error(ErrorCode::kInvalidInput,
                      "stroke feed " + format_fixed(feed_mm_per_min, 3) + " mm/min: expected (0, 100000]");
  }
  double sim_max = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!std::isfinite(points[i].z_mm) || !std::isfinite(points[i].sim_deg)) {
      return make_error(ErrorCode::kInvalidInput, "stroke point " + std::to_string(i) + " is not finite");
    }
    if (i > 0 && !(format.round_z_mm(points[i].z_mm) > format.round_z_mm(points[i - 1].z_mm))) {
      return make_error(ErrorCode::kInvalidInput, "stroke point " + std::to_string(i) + ": Z " +
                                                      format_fixed(points[i].z_mm, 4) +
                                                      " mm does not increase on the control's grid");
    }
    sim_max = std::max(sim_max, std::abs(format.round_sim_deg(points[i].sim_deg)));
  }
  std::string body = "FGROUP(Z)";
  for (std::size_t i = 0; i < points.size(); ++i) {
    body += '\n';
    if (i == 0) body += "G1 G90 ";
    body += "Z" + format_fixed(format.round_z_mm(points[i].z_mm), format.z_decimals()) +
            " SIM1=" + format_fixed(format.round_sim_deg(points[i].sim_deg), format.sim_decimals());
    if (i == 0) body += " F" + format_fixed(feed_mm_per_min, 1);
  }
  std::string out = "; " + std::string(program_name) + ": the gear's stroke, SIM1 compensating the gearbox's axes";
  append_header_line(out, "kind", std::string(kStrokeKind));
  for (const auto& [key, value] : header) append_header_line(out, key, value);
  append_header_line(out, "point_count", std::to_string(points.size()));
  append_header_line(out, "sim_max_abs_deg", format_fixed(sim_max, format.sim_decimals()));
  append_header_line(out, "body_checksum_fnv1a64", table_body_checksum(body));
  out += "\n" + body + "\nM17\n";
  return out;
}

Result<ParsedStrokeProgram> parse_stroke_program(std::string_view text, std::string_view file_name) {
  const std::vector<std::string_view> lines = lines_of(text);
  auto fail = [&](std::size_t i, const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ":" + std::to_string(i + 1) + ": " + why);
  };
  ParsedStrokeProgram p;
  std::string body;
  bool in_body = false;
  bool ended = false;
  double sim = 0.0;
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string_view l = trim(lines[i]);
    if (!in_body && read_header_line(l, p.header)) continue;
    const std::vector<std::string_view> words = words_of(code_of(l));
    if (words.empty()) {
      if (in_body && !ended) body += "\n" + std::string(lines[i]);
      continue;
    }
    if (ended) return fail(i, "a block after M17");
    if (upper(words.front()) == "M17") {
      ended = true;
      continue;
    }
    body += (in_body ? "\n" : "") + std::string(lines[i]);
    in_body = true;
    std::optional<double> z;
    bool sim_given = false;
    for (std::string_view w : words) {
      const std::string u = upper(w);
      if (u == "G1" || u == "G01" || u == "G90" || u == "FGROUP(Z)") continue;
      if (u.size() > 1 && u[0] == 'F' && parse_number(u.substr(1))) continue;
      if (u.rfind("SIM1=", 0) == 0) {
        const std::optional<double> v = parse_number(w.substr(5));
        if (!v) return fail(i, "`" + std::string(w) + "`: not a number after SIM1=");
        sim = *v;
        sim_given = true;
        continue;
      }
      if (u.size() > 1 && u[0] == 'Z') {
        std::string_view v = w.substr(1);
        if (!v.empty() && v.front() == '=') v.remove_prefix(1);
        z = parse_number(v);
        if (!z) return fail(i, "`" + std::string(w) + "`: not a number after Z");
        continue;
      }
      return fail(i, "`" + std::string(w) +
                         "` in the stroke program: gaugeloop reads only Z, SIM1=, G1, G90, F, FGROUP(Z) and block "
                         "numbers");
    }
    if (!z) {
      if (sim_given) return fail(i, "a block moving SIM1 without Z: every spline point names its Z");
      continue;
    }
    if (!p.points.empty() && !(*z > p.points.back().z_mm)) {
      return fail(i, "Z " + format_fixed(*z, 4) + " does not increase");
    }
    p.points.push_back({*z, sim});
    p.point_lines.push_back(static_cast<int>(i + 1));
  }
  if (!ended) return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": no M17 at the end");
  while (!body.empty() && body.back() == '\n') body.pop_back();
  p.body_checksum = table_body_checksum(body);
  const auto sum = p.header.find("body_checksum_fnv1a64");
  if (sum == p.header.end()) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(file_name) +
                          ": no `; gaugeloop body_checksum_fnv1a64:` header line; not a stroke "
                          "program gaugeloop wrote");
  }
  if (sum->second != p.body_checksum) {
    return make_error(ErrorCode::kRefused, std::string(file_name) +
                                               ": the stroke (its blocks) was edited by hand: "
                                               "its checksum is " +
                                               p.body_checksum + ", the header says " + sum->second);
  }
  const auto count = p.header.find("point_count");
  if (count == p.header.end() || count->second != std::to_string(p.points.size())) {
    return make_error(ErrorCode::kRefused, std::string(file_name) + ": the header says " +
                                               (count == p.header.end() ? std::string("no") : count->second) +
                                               " points, the stroke has " + std::to_string(p.points.size()));
  }
  return p;
}

}  // namespace gaugeloop
