// Numbers as text: std::to_chars, which no locale changes.
#include "core/number_text.h"

#include <array>
#include <charconv>
#include <cmath>

namespace gaugeloop {

std::string format_fixed(double value, int decimals) {
  if (std::isnan(value)) return "nan";
  if (std::isinf(value)) return value > 0 ? "inf" : "-inf";
  std::array<char, 400> buf{};  // the widest double in fixed notation is 309 digits + decimals
  const auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), value, std::chars_format::fixed,
                                       decimals < 0 ? 0 : (decimals > 60 ? 60 : decimals));
  if (ec != std::errc()) return "nan";
  std::string s(buf.data(), end);
  // A value that rounds to zero prints as "0.0", not "-0.0".
  if (s.front() == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
  return s;
}

std::string format_signed_fixed(double value, int decimals) {
  std::string s = format_fixed(value, decimals);
  if (s.front() != '-' && s != "nan") s.insert(s.begin(), '+');
  return s;
}

}  // namespace gaugeloop
