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

Result<SampledPath> layer_path(const SampledPath& whole, const TableInterpolant& design) {
  if (Status s = check_sampled_path_shape(whole); !s) return s.error();
  SampledPath out;
  out.c_step_deg = whole.c_step_deg;
  const std::size_t n = whole.size();
  out.x_mm.resize(n);
  out.dx_dc_mm_per_deg.resize(n);
  out.d2x_dc2_mm_per_deg2.resize(n);
  std::size_t segment = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const TableInterpolant::Value d = design.at(whole.c_deg(k), segment);
    out.x_mm[k] = whole.x_mm[k] - d.x_mm;
    out.dx_dc_mm_per_deg[k] = whole.dx_dc_mm_per_deg[k] - d.dx_dc_mm_per_deg;
    out.d2x_dc2_mm_per_deg2[k] = whole.d2x_dc2_mm_per_deg2[k] - d.d2x_dc2_mm_per_deg2;
  }
  return out;
}

Status check_layered_guards(const CurveTable& layer, const TableInterpolant& design, const SampledPath& whole,
                            const AxisLimits& limits) {
  if (Status s = check_sampled_path_shape(whole); !s) return s;
  Result<TableInterpolant> l = TableInterpolant::of(layer.points, layer.interpolation);
  if (!l) return l.error();
  SampledPath sum;
  sum.c_step_deg = whole.c_step_deg;
  const std::size_t n = whole.size();
  sum.x_mm.resize(n);
  sum.dx_dc_mm_per_deg.resize(n);
  sum.d2x_dc2_mm_per_deg2.resize(n);
  std::size_t design_segment = 0;
  std::size_t layer_segment = 0;
  for (std::size_t k = 0; k < n; ++k) {
    const TableInterpolant::Value d = design.at(whole.c_deg(k), design_segment);
    const TableInterpolant::Value c = l->at(whole.c_deg(k), layer_segment);
    sum.x_mm[k] = d.x_mm + c.x_mm;
    sum.dx_dc_mm_per_deg[k] = d.dx_dc_mm_per_deg + c.dx_dc_mm_per_deg;
    sum.d2x_dc2_mm_per_deg2[k] = d.d2x_dc2_mm_per_deg2 + c.d2x_dc2_mm_per_deg2;
  }
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
