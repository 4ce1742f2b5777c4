// TomlReader: typed key access with messages that say where and what is allowed.
#include "config/toml_reader.h"

#include <algorithm>

#include <cmath>
#include <sstream>

namespace gaugeloop {

Result<toml::table> parse_toml(std::string_view text, std::string_view source_name) {
  try {
    return toml::parse(text, source_name);
  } catch (const toml::parse_error& e) {
    return make_error(ErrorCode::kInvalidInput, std::string(source_name) + ":" + std::to_string(e.source().begin.line) +
                                                    ": " + std::string(e.description()));
  }
}

TomlReader::TomlReader(const toml::table& table, std::string_view source, std::string prefix)
    : table_(table), source_(source), prefix_(std::move(prefix)) {}

std::string TomlReader::where(std::string_view key) const {
  const toml::node* n = table_.get(key);
  const auto line = n != nullptr ? n->source().begin.line : 0;
  return source_ + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": key `" + prefix_ + std::string(key) +
         "`";
}

Error TomlReader::at_key(std::string_view key, const Error& e) const {
  Error out = e;
  out.message = where(key) + ": " + e.message;
  return out;
}

void TomlReader::allow_only(std::initializer_list<std::string_view> known) {
  for (const auto& [key, node] : table_) {
    bool ok = false;
    for (std::string_view k : known) ok = ok || k == key.str();
    if (ok) continue;
    std::string list;
    for (std::string_view k : known) list += (list.empty() ? "" : ", ") + std::string(k);
    fail(where(key.str()) + ": unknown key; known keys: " + list);
  }
}

void TomlReader::fail(std::string message) {
  if (!error) error = make_error(ErrorCode::kInvalidInput, std::move(message));
}

void TomlReader::missing(std::string_view key) {
  fail(source_ + ": key `" + prefix_ + std::string(key) + "` is missing; it is required");
}

std::string TomlReader::text(std::string_view key, std::optional<std::string> fallback) {
  const toml::node* n = table_.get(key);
  if (n == nullptr) {
    if (!fallback) missing(key);
    return fallback.value_or("");
  }
  if (auto v = n->value<std::string>()) return *v;
  fail(where(key) + ": expected a string in quotes");
  return {};
}

std::string TomlReader::label(std::string_view key, std::string_view what) {
  std::string v = text(key, "");
  const bool printable =
      std::all_of(v.begin(), v.end(), [](char c) { return static_cast<unsigned char>(c) >= 0x20 && c != 0x7f; });
  if (v.size() > 40 || !printable) {
    fail(where(key) + ": up to 40 printable characters (no tabs or line breaks), " + std::string(what));
  }
  return v;
}

const toml::table* TomlReader::subtable(std::string_view key) {
  const toml::node* n = table_.get(key);
  if (n == nullptr) return nullptr;
  if (!n->is_table()) {
    fail(where(key) + ": expected a table ([" + prefix_ + std::string(key) + "])");
    return nullptr;
  }
  return n->as_table();
}

bool TomlReader::flag(std::string_view key, bool fallback) {
  const toml::node* n = table_.get(key);
  if (n == nullptr) return fallback;
  if (auto v = n->value<bool>(); v && n->is_boolean()) return *v;
  fail(where(key) + ": expected true or false (no quotes)");
  return fallback;
}

double TomlReader::number(std::string_view key, std::optional<double> fallback, double min, double max, bool open_min) {
  const toml::node* n = table_.get(key);
  if (n == nullptr) {
    if (!fallback) missing(key);
    return fallback.value_or(0.0);
  }
  auto v = n->value<double>();  // integers convert too
  if (!v || !std::isfinite(*v)) {
    fail(where(key) + ": expected a number");
    return 0.0;
  }
  if ((open_min ? *v <= min : *v < min) || *v > max) {
    std::ostringstream os;
    os << where(key) << ": " << *v << " is out of range; allowed " << (open_min ? "(" : "[") << min << ", " << max
       << "]";
    fail(os.str());
  }
  return *v;
}

long long TomlReader::integer(std::string_view key, std::optional<long long> fallback, long long min, long long max) {
  const toml::node* n = table_.get(key);
  if (n == nullptr) {
    if (!fallback) missing(key);
    return fallback.value_or(0);
  }
  auto v = n->value_exact<int64_t>();
  if (!v) {
    fail(where(key) + ": expected a whole number (hex like 0x0001 is fine)");
    return 0;
  }
  if (*v < min || *v > max) {
    fail(where(key) + ": " + std::to_string(*v) + " is out of range; allowed [" + std::to_string(min) + ", " +
         std::to_string(max) + "]");
  }
  return *v;
}

std::string TomlReader::choice(std::string_view key, std::optional<std::string> fallback,
                               std::initializer_list<std::string_view> choices) {
  return choice(key, std::move(fallback), std::vector<std::string>(choices.begin(), choices.end()));
}

std::string TomlReader::choice(std::string_view key, std::optional<std::string> fallback,
                               const std::vector<std::string>& choices) {
  const std::string v = text(key, std::move(fallback));
  if (error) return v;
  for (const std::string& c : choices) {
    if (c == v) return v;
  }
  std::string list;
  for (const std::string& c : choices) list += (list.empty() ? "" : ", ") + c;
  fail(where(key) + ": `" + v + "` is not one of " + list);
  return v;
}

}  // namespace gaugeloop
