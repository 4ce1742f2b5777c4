// Reading one TOML table with the file, line and key in every message (part and gauge files).
#pragma once

#include <toml++/toml.h>

#include <initializer_list>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"

namespace gaugeloop {

// Parses TOML text; a syntax error names the source and line.
Result<toml::table> parse_toml(std::string_view text, std::string_view source_name);

// Reads keys of one table. The first problem is kept in `error` and later reads return
// defaults, so a caller reads every key and then checks `error` once.
class TomlReader {
 public:
  // `prefix` names the table in messages, e.g. "map.reading."; empty for the top level.
  TomlReader(const toml::table& table, std::string_view source, std::string prefix = {});

  // "file:line: key `name`" (the line where the key is, if it is there).
  std::string where(std::string_view key) const;
  // `e` with where(key) in front of its message.
  Error at_key(std::string_view key, const Error& e) const;

  bool has(std::string_view key) const { return table_.contains(key); }
  // Refuses keys not in `known`, listing the known ones.
  void allow_only(std::initializer_list<std::string_view> known);

  std::string text(std::string_view key, std::optional<std::string> fallback);
  // An optional label printed on reports ("" when absent): at most 40 printable characters,
  // no tabs or line breaks; else fails saying so and what the label is (`what`).
  std::string label(std::string_view key, std::string_view what);
  // The table under `key` ([key]); nullptr if absent, or (failing) if not a table.
  const toml::table* subtable(std::string_view key);
  // A TOML boolean, true or false.
  bool flag(std::string_view key, bool fallback);
  // A number in [min, max] ((min, max] when open_min); integers convert.
  double number(std::string_view key, std::optional<double> fallback, double min, double max, bool open_min = false);
  // A whole number in [min, max].
  long long integer(std::string_view key, std::optional<long long> fallback, long long min, long long max);
  // One of `choices`, as written.
  std::string choice(std::string_view key, std::optional<std::string> fallback,
                     std::initializer_list<std::string_view> choices);
  std::string choice(std::string_view key, std::optional<std::string> fallback,
                     const std::vector<std::string>& choices);

  void fail(std::string message);
  std::optional<Error> error;

 private:
  void missing(std::string_view key);

  const toml::table& table_;
  std::string source_;
  std::string prefix_;
};

}  // namespace gaugeloop
