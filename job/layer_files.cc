// A correction layer's design table beside it.
#include "job/layer_files.h"

#include "core/text_file.h"
#include "nc_out/main_program.h"
#include "nc_out/table_layer.h"
#include "nc_out/table_program.h"

namespace gaugeloop {

std::filesystem::path design_program_path(const std::filesystem::path& nc_file) {
  return nc_file.parent_path() / (design_program_name(nc_file.stem().string()) + ".SPF");
}

Result<std::optional<LayerOnControl>> layer_on_control(std::string_view program_text,
                                                       const std::filesystem::path& nc_file) {
  Result<ParsedTable> table = parse_table_program(program_text, nc_file.string());
  if (!table) return table.error();
  Result<LayerOf> layer = layer_of(*table, nc_file.string());
  if (!layer) return layer.error();
  if (layer->design_program.empty()) return std::optional<LayerOnControl>{};
  LayerOnControl out;
  out.design_file = nc_file.parent_path() / (layer->design_program + ".SPF");
  out.design_table_number = layer->design_table_number;
  Result<std::string> text = read_regular_file(out.design_file, "design table");
  if (!text) {
    out.problem = text.error().message;
    return std::optional<LayerOnControl>{std::move(out)};
  }
  if (Result<DesignTable> d = read_design_table(*text, out.design_file.string(), out.design_table_number); !d) {
    out.problem = d.error().message;
    return std::optional<LayerOnControl>{std::move(out)};
  }
  out.design_text = std::move(*text);
  return std::optional<LayerOnControl>{std::move(out)};
}

}  // namespace gaugeloop
