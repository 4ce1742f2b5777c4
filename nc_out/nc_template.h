// NC program templates: the user's own program text with {{name}} placeholders.
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// Replaces every `{{name}}` (Mustache variable syntax, spaces inside the braces allowed)
// with values.at(name), verbatim. Refuses, naming `template_name` and the 1-based line, a
// placeholder with no value and an unclosed `{{`. Nothing else in the text is touched.
Result<std::string> render_nc_template(std::string_view text, std::string_view template_name,
                                       const std::map<std::string, std::string>& values);

}  // namespace gaugeloop
