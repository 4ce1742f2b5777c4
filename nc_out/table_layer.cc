// The correction layer: the design table read back, the layer's path and the sum's guards.
#include "nc_out/table_layer.h"

#include <utility>

#include "nc_out/nc_text.h"

namespace gaugeloop {

Result<DesignTable> read_design_table(std::string_view text, std::string_view file_name, int number) {
  Result<ParsedTable> parsed = parse_table_program(text, file_name);
  if (!parsed) return parsed.error();
  auto refuse = [&](const std::string& why) {
    return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": " + why +
                                                    "; the design table of a correction layer is X from C, "
                                                    "CTABDEF(X,C," +
                                                    std::to_string(number) +
                                                    ",1), as `gaugeloop nc new` writes it from the drawing");
  };
  if (nc_text::upper(parsed->following_axis) != "X" || nc_text::upper(parsed->leading_axis) != "C") {
    return refuse("CTABDEF (line " + std::to_string(parsed->ctabdef_line) + ") couples " + parsed->following_axis +
                  " to " + parsed->leading_axis);
  }
  if (parsed->table_number != number) {
    return refuse("CTABDEF (line " + std::to_string(parsed->ctabdef_line) + ") defines table " +
                  std::to_string(parsed->table_number) + ", not the design table " + std::to_string(number));
  }
  if (parsed->periodicity != 1) return refuse("the table is not periodic (CTABDEF's 4th argument is not 1)");
  if (Status c = verify_table_checksum(*parsed, file_name); !c) {
    Error e = c.error();
    e.message +=
        "; the design table is the approved one and the layer is written against it: write it again "
        "from the drawing (`gaugeloop nc new --replace`) or restore it";
    return e;
  }
  Result<TableInterpolant> nc = TableInterpolant::of(parsed->points, parsed->interpolation);
  if (!nc) return make_error(ErrorCode::kInvalidInput, std::string(file_name) + ": " + nc.error().message);
  return DesignTable{std::move(*parsed), std::move(*nc)};
}

namespace {

// On the rows of `rows`: their values (or zeros, without `keep_rows`) plus `sign` times what the
// NC makes of `table` there, with the derivatives alike.
SampledPath plus_table(const SampledPath& rows, bool keep_rows, const TableInterpolant& table, double sign) {
  SampledPath out;
  out.c_step_deg = rows.c_step_deg;
  const std::size_t n = rows.size();
  out.x_mm.assign(n, 0.0);
  out.dx_dc_mm_per_deg.assign(n, 0.0);
  out.d2x_dc2_mm_per_deg2.assign(n, 0.0);
  std::size_t segment = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const TableInterpolant::Value v = table.at(rows.c_deg(k), segment);
    out.x_mm[k] = (keep_rows ? rows.x_mm[k] : 0.0) + sign * v.x_mm;
    out.dx_dc_mm_per_deg[k] = (keep_rows ? rows.dx_dc_mm_per_deg[k] : 0.0) + sign * v.dx_dc_mm_per_deg;
    out.d2x_dc2_mm_per_deg2[k] = (keep_rows ? rows.d2x_dc2_mm_per_deg2[k] : 0.0) + sign * v.d2x_dc2_mm_per_deg2;
  }
  return out;
}

}  // namespace

Result<SampledPath> layer_path(const SampledPath& whole, const TableInterpolant& design) {
  if (Status s = check_sampled_path_shape(whole); !s) return s.error();
  return plus_table(whole, true, design, -1.0);
}

Status check_layered_guards(const CurveTable& layer, const TableInterpolant& design, const SampledPath& whole,
                            const AxisLimits& limits) {
  if (Status s = check_sampled_path_shape(whole); !s) return s;
  Result<TableInterpolant> l = TableInterpolant::of(layer.points, layer.interpolation);
  if (!l) return l.error();
  const SampledPath sum = plus_table(plus_table(whole, false, *l, 1.0), true, design, 1.0);
  if (Status g = check_path_guards(sum, limits); !g) {
    Error e = g.error();
    e.message = "design table + correction layer as the control adds them: " + e.message;
    return e;
  }
  return {};
}

Result<LayerOf> layer_of(const ParsedTable& table, std::string_view file_name) {
  LayerOf out;
  const auto number = table.header.find("design_table_number");
  const auto program = table.header.find("design_program");
  if (number == table.header.end() && program == table.header.end()) return out;
  std::optional<int> n = number == table.header.end() ? std::nullopt : nc_text::parse_int(number->second);
  if (!n || *n <= 0 || program == table.header.end() || program->second.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      std::string(file_name) +
                          ": the header names a correction layer's design table without both its program "
                          "(design_program) and its number (design_table_number); the layer cannot be summed");
  }
  out.design_program = program->second;
  out.design_table_number = *n;
  return out;
}

}  // namespace gaugeloop
