// Small text helpers the NC program readers and writers share: NC words are
// case-insensitive, and files from a Windows share may end their lines with "\r\n".
#pragma once

#include <cctype>
#include <charconv>
#include <cmath>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace gaugeloop::nc_text {

inline std::string upper(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return out;
}

// `s` without leading and trailing white space.
inline std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

// A decimal number, with an optional '+'; empty for anything else or a number not finite.
inline std::optional<double> parse_number(std::string_view s) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  double v = 0.0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

// A decimal integer, blanks around it allowed; empty for anything else.
inline std::optional<int> parse_int(std::string_view s) {
  s = trim(s);
  int v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size()) return std::nullopt;
  return v;
}

// `v` rounded to `decimals` places, never -0 (which a control would print as "-0.000").
inline double round_to(double v, int decimals) {
  const double q = std::pow(10.0, decimals);
  const double r = std::round(v * q) / q;
  return r == 0.0 ? 0.0 : r;
}

// The lines of `text` without their "\n" or a trailing "\r"; no empty line after a final "\n".
inline std::vector<std::string_view> lines_of(std::string_view text) {
  std::vector<std::string_view> out;
  while (!text.empty()) {
    const size_t nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    out.push_back(line);
    if (nl == std::string_view::npos) break;
    text = text.substr(nl + 1);
  }
  return out;
}

// The code of a block: before any ';' comment, trimmed.
inline std::string_view code_of(std::string_view line) {
  const size_t semi = line.find(';');
  return trim(semi == std::string_view::npos ? line : line.substr(0, semi));
}

// The words of a block's code, split on blanks; a block number N<digits> at the front is dropped.
inline std::vector<std::string_view> words_of(std::string_view code) {
  std::vector<std::string_view> words;
  size_t pos = 0;
  while (pos < code.size()) {
    while (pos < code.size() && (code[pos] == ' ' || code[pos] == '\t')) ++pos;
    size_t end = pos;
    while (end < code.size() && code[end] != ' ' && code[end] != '\t') ++end;
    if (end > pos) words.push_back(code.substr(pos, end - pos));
    pos = end;
  }
  if (!words.empty()) {
    const std::string_view first = words.front();
    const bool block_number = first.size() > 1 && (first[0] == 'N' || first[0] == 'n') &&
                              first.find_first_not_of("0123456789", 1) == std::string_view::npos;
    if (block_number) words.erase(words.begin());
  }
  return words;
}

}  // namespace gaugeloop::nc_text
