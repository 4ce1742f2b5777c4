// NC program templates: the user's own program text with Mustache variables {{name}}.
//
// Syntax: Mustache (https://mustache.github.io), variables only: `{{name}}`, `{{{name}}}` and
// `{{&name}}`, spaces allowed inside the braces, names of letters, digits and '_'. Values are
// inserted verbatim (never HTML-escaped: NC text is not HTML). Sections, partials, comments
// and delimiter changes are refused: an NC program has no use for them, and a section
// quietly dropping a block is the kind of surprise a machine must not get.
// Rendering goes through libmstch (Debian's libmstch-dev); before it, our own scan checks
// every tag, because libmstch renders an unknown name as empty text.
// Thread-safe: no global state is touched.
#pragma once

#include <map>
#include <string>
#include <string_view>

#include "core/result.h"

namespace gaugeloop {

// Replaces every placeholder with values.at(name). Refuses (kInvalidInput), naming
// `template_name` and the 1-based line: a placeholder with no value (listing the known
// ones), a `{{` not closed on its line, a tag other than a variable, a bad name.
// Values that are not used are fine.
Result<std::string> render_nc_template(std::string_view text, std::string_view template_name,
                                       const std::map<std::string, std::string>& values);

}  // namespace gaugeloop
