// Text put into an SVG (XML) document: its markup characters escaped. Internal to report/.
#pragma once

#include <string>
#include <string_view>

namespace gaugeloop {

// `text` with &, <, > and " written as entities: safe as element text and as a quoted attribute.
inline std::string xml_escaped(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

}  // namespace gaugeloop
