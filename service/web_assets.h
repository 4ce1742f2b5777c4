// The pages' files (service/web/: index.html, app.js, style.css), built into the binary by
// service/web/embed.cmake: the grinder's PC has no network, so the service serves every byte
// of its pages itself.
#pragma once

#include <string_view>

namespace gaugeloop {

struct WebAsset {
  std::string_view name;          // the file name, e.g. "app.js"
  std::string_view content_type;  // e.g. "text/javascript; charset=utf-8"
  std::string_view body;
};

// The file of that name, or nullptr.
const WebAsset* find_web_asset(std::string_view name);

}  // namespace gaugeloop
