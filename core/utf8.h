// UTF-8 as the product reads it: strictly (no overlong forms, no surrogates, nothing above
// U+10FFFF), and where text a person typed must go on anyway (a note into the central
// history), with each byte that is not UTF-8 replaced by U+FFFD.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace gaugeloop {

// The length (1 to 4) of the valid UTF-8 sequence starting at text[i], with its code point in
// `code_point`; 0 if the bytes there are not one.
std::size_t utf8_sequence_at(std::string_view text, std::size_t i, char32_t& code_point);

// `text` with every byte that does not start a valid sequence replaced by U+FFFD (EF BF BD).
std::string with_valid_utf8(std::string_view text);

}  // namespace gaugeloop
