// A strict subset of Mustache: variables only, unknown names refused with their line.
#include "nc_out/nc_template.h"

#include <algorithm>

namespace gaugeloop {

Result<std::string> render_nc_template(std::string_view text, std::string_view template_name,
                                       const std::map<std::string, std::string>& values) {
  std::string out;
  out.reserve(text.size());
  size_t pos = 0;
  while (pos < text.size()) {
    const size_t open = text.find("{{", pos);
    if (open == std::string_view::npos) {
      out.append(text.substr(pos));
      break;
    }
    out.append(text.substr(pos, open - pos));
    const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(open), '\n'));
    const size_t close = text.find("}}", open + 2);
    const size_t next_nl = text.find('\n', open);
    if (close == std::string_view::npos || (next_nl != std::string_view::npos && close > next_nl)) {
      return make_error(ErrorCode::kInvalidInput, std::string(template_name) + ":" + std::to_string(line) +
                                                      ": `{{` is not closed by `}}` on the same line");
    }
    std::string_view name = text.substr(open + 2, close - open - 2);
    while (!name.empty() && name.front() == ' ') name.remove_prefix(1);
    while (!name.empty() && name.back() == ' ') name.remove_suffix(1);
    auto it = values.find(std::string(name));
    if (it == values.end()) {
      std::string known;
      for (const auto& [k, v] : values) known += (known.empty() ? "" : ", ") + k;
      return make_error(ErrorCode::kInvalidInput, std::string(template_name) + ":" + std::to_string(line) +
                                                      ": unknown placeholder {{" + std::string(name) +
                                                      "}}; known placeholders: " + known);
    }
    out.append(it->second);
    pos = close + 2;
  }
  return out;
}

}  // namespace gaugeloop
