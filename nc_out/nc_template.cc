// Mustache variables through libmstch, behind a scan that refuses what libmstch would hide.
#include "nc_out/nc_template.h"
#include "nc_out/nc_text.h"

#include <algorithm>
#include <cctype>

#include <mstch/mstch.hpp>

namespace gaugeloop {
namespace {

using nc_text::trim;

bool is_name(std::string_view name) {
  if (name.empty() || !(std::isalpha(static_cast<unsigned char>(name.front())) || name.front() == '_')) return false;
  return std::all_of(name.begin(), name.end(),
                     [](char ch) { return std::isalnum(static_cast<unsigned char>(ch)) || ch == '_'; });
}

}  // namespace

Result<std::string> render_nc_template(std::string_view text, std::string_view template_name,
                                       const std::map<std::string, std::string>& values) {
  // Our scan: every tag checked, and the template rewritten with each variable as the
  // unescaped `{{&name}}`, so libmstch gets one tag form only.
  std::string canonical;
  canonical.reserve(text.size());
  size_t pos = 0;
  int line = 1;
  auto where = [&] { return std::string(template_name) + ":" + std::to_string(line) + ": "; };
  while (pos < text.size()) {
    const size_t open = text.find("{{", pos);
    const std::string_view literal = text.substr(pos, open == std::string_view::npos ? text.npos : open - pos);
    canonical.append(literal);
    line += static_cast<int>(std::count(literal.begin(), literal.end(), '\n'));
    if (open == std::string_view::npos) break;
    const bool triple = text.substr(open, 3) == "{{{";
    const std::string_view closing = triple ? "}}}" : "}}";
    const size_t inner = open + (triple ? 3 : 2);
    const size_t close = text.find(closing, inner);
    const size_t next_nl = text.find('\n', open);
    if (close == std::string_view::npos || (next_nl != std::string_view::npos && close > next_nl)) {
      return make_error(ErrorCode::kInvalidInput, where() + "`" + std::string(triple ? "{{{" : "{{") +
                                                      "` is not closed by `" + std::string(closing) +
                                                      "` on the same line");
    }
    std::string_view tag = trim(text.substr(inner, close - inner));
    if (!triple && !tag.empty() && tag.front() == '&') tag = trim(tag.substr(1));
    if (!triple && !tag.empty() && std::string_view("#^/>!=").find(tag.front()) != std::string_view::npos) {
      return make_error(ErrorCode::kInvalidInput, where() + "{{" + std::string(tag) +
                                                      "}} is a Mustache section, partial, comment or delimiter "
                                                      "change; NC templates take variables {{name}} only");
    }
    if (!is_name(tag)) {
      return make_error(ErrorCode::kInvalidInput,
                        where() + "`" + std::string(tag) + "` is not a placeholder name (letters, digits and '_')");
    }
    if (values.find(std::string(tag)) == values.end()) {
      std::string known;
      for (const auto& [k, v] : values) known += (known.empty() ? "" : ", ") + k;
      return make_error(ErrorCode::kInvalidInput,
                        where() + "unknown placeholder {{" + std::string(tag) + "}}; known placeholders: " + known);
    }
    canonical += "{{&";
    canonical += tag;
    canonical += "}}";
    pos = close + closing.size();
  }
  mstch::map context;
  for (const auto& [k, v] : values) context.emplace(k, v);
  return mstch::render(canonical, context);
}

}  // namespace gaugeloop
