// The central history's URL, connection and statement parameters.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>

#include "core/utf8.h"
#include "plant/central_internal.h"

namespace gaugeloop {

namespace {

constexpr std::string_view kUrlForm =
    "postgresql://USER@HOST:PORT/DATABASE, e.g. postgresql://gaugeloop@central:5432/plant";

Error bad_url(std::string_view url, const std::string& what) {
  return make_error(ErrorCode::kInvalidInput,
                    "central history URL '" + std::string(url) + "': " + what + "; write " + std::string(kUrlForm));
}

bool all_digits(std::string_view s) {
  if (s.empty()) return false;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
  }
  return true;
}

}  // namespace

Result<CentralUrl> parse_central_url(std::string_view url) {
  std::string_view rest;
  for (std::string_view scheme : {"postgresql://", "postgres://"}) {
    if (url.substr(0, scheme.size()) == scheme) rest = url.substr(scheme.size());
  }
  if (rest.data() == nullptr) {
    const std::size_t colon = url.find("://");
    return bad_url(url, colon == std::string_view::npos
                            ? "it is not a URL (a run database file is given with --data-dir or --config)"
                            : "the scheme '" + std::string(url.substr(0, colon)) + "' is not postgresql");
  }
  for (char c : url) {
    if (static_cast<unsigned char>(c) < 0x20 || c == ' ')
      return bad_url(url, "it holds a space or a control character");
  }
  CentralUrl out;
  out.url = std::string(url);
  out.port = "5432";
  const std::size_t query_at = rest.find('?');
  const std::string_view query = query_at == std::string_view::npos ? std::string_view() : rest.substr(query_at + 1);
  const std::string_view before_query = rest.substr(0, query_at);
  const std::size_t slash = before_query.find('/');
  const std::string_view authority = before_query.substr(0, slash);
  out.database = slash == std::string_view::npos ? std::string() : std::string(before_query.substr(slash + 1));
  if (out.database.empty()) return bad_url(url, "the database name after the host is missing");
  if (out.database.find('/') != std::string::npos) {
    return bad_url(url, "the database name '" + out.database + "' holds a '/'");
  }
  const std::size_t at = authority.rfind('@');
  std::string_view host_port = at == std::string_view::npos ? authority : authority.substr(at + 1);
  out.shown = std::string(url);
  if (at != std::string_view::npos) {
    const std::string_view userinfo = authority.substr(0, at);
    const std::size_t colon = userinfo.find(':');
    if (colon != std::string_view::npos) {
      // Never print a password: the URL as shown keeps everything but it.
      const std::size_t start = (url.size() - rest.size()) + colon + 1;
      out.shown = std::string(url.substr(0, start)) + "***" + std::string(url.substr(start + (at - colon - 1)));
      out.has_password = true;
    }
  }
  if (!query.empty()) {  // nor one given as ?password=...
    std::string shown_query;
    for (std::size_t from = 0; from <= query.size();) {
      const std::size_t amp = std::min(query.find('&', from), query.size());
      std::string_view pair = query.substr(from, amp - from);
      if (pair.substr(0, 9) == "password=") {
        pair = "password=***";
        out.has_password = true;
      }
      shown_query += (from == 0 ? "" : "&") + std::string(pair);
      from = amp + 1;
    }
    out.shown = out.shown.substr(0, out.shown.find('?') + 1) + shown_query;
  }
  if (!host_port.empty() && host_port.front() == '[') {
    const std::size_t close = host_port.find(']');
    if (close == std::string_view::npos) return bad_url(out.shown, "the IPv6 host has no closing ']'");
    out.host = std::string(host_port.substr(1, close - 1));
    host_port = host_port.substr(close + 1);
    if (!host_port.empty() && host_port.front() != ':') {
      return bad_url(out.shown, "'" + std::string(host_port) + "' after the host is not :PORT");
    }
  } else {
    const std::size_t colon = host_port.find(':');
    out.host = std::string(host_port.substr(0, colon));
    host_port = colon == std::string_view::npos ? std::string_view() : host_port.substr(colon);
  }
  if (!host_port.empty()) {
    const std::string_view port = host_port.substr(1);
    const long value = all_digits(port) && port.size() <= 5 ? std::strtol(std::string(port).c_str(), nullptr, 10) : 0;
    if (value < 1 || value > 65535) return bad_url(out.shown, "the port '" + std::string(port) + "' is not 1 to 65535");
    out.port = std::string(port);
  }
  // A server that does not answer (a firewall dropping packets) fails the connection in 10 s
  // instead of libpq's default of waiting for the operating system's TCP timeout.
  if (query.find("connect_timeout=") == std::string_view::npos) {
    out.url += query_at == std::string_view::npos ? "?connect_timeout=10" : "&connect_timeout=10";
  }
  return out;
}

namespace central_internal {

namespace {

// libpq's messages end in a newline and may run over several lines; one line is enough.
std::string one_line(std::string text) {
  for (char& c : text) {
    if (c == '\n' || c == '\r' || c == '\t') c = ' ';
  }
  while (!text.empty() && text.back() == ' ') text.pop_back();
  return text;
}

std::string where(const CentralUrl& url) {
  return (url.host.empty() ? std::string("the local socket") : "host " + url.host) + " port " + url.port +
         " (database " + url.database + ")";
}

}  // namespace

Result<CentralConnection> connect(const CentralUrl& url) {
  CentralConnection c;
  c.url = url;
  try {
    c.conn = std::make_unique<pqxx::connection>(url.url);
    // Exact floats whatever the server's setting; the grinder's text is UTF-8; UTC, so no time
    // ever depends on the server.
    pqxx::nontransaction setup(*c.conn);
    setup.exec(
        "SET extra_float_digits = 3; SET client_encoding = 'UTF8'; SET TIME ZONE 'UTC'; SET statement_timeout = "
        "'300s'");
  } catch (const pqxx::broken_connection& e) {
    return make_error(ErrorCode::kStorage,
                      "cannot reach the central history at " + where(url) + ": " + one_line(e.what()) +
                          "; check that PostgreSQL runs there and accepts connections from this machine "
                          "(listen_addresses, pg_hba.conf) and that the URL " +
                          url.shown + " is right");
  } catch (const std::exception& e) {
    return make_error(ErrorCode::kStorage, "cannot open the central history at " + where(url) + ": " +
                                               one_line(e.what()) + "; check the URL " + url.shown);
  }
  return c;
}

Error database_error(const CentralUrl& url, std::string_view operation, const std::exception& e) {
  if (dynamic_cast<const pqxx::in_doubt_error*>(&e) != nullptr) {
    // The commit was sent but its answer never came: the batch and its progress are there
    // together or not at all, so running again is safe either way.
    return make_error(ErrorCode::kStorage, "cannot " + std::string(operation) + ": the connection to the central " +
                                               "history at " + where(url) + " was lost while committing (" +
                                               one_line(e.what()) + "), so whether that step was kept is not " +
                                               "known; run it again once the server is back: nothing is copied twice");
  }
  if (dynamic_cast<const pqxx::broken_connection*>(&e) != nullptr) {
    return make_error(ErrorCode::kStorage, "cannot " + std::string(operation) + ": the connection to the central " +
                                               "history at " + where(url) + " was lost (" + one_line(e.what()) +
                                               "); nothing of the unfinished step was kept: run it again once the " +
                                               "server is back");
  }
  return make_error(ErrorCode::kStorage, "cannot " + std::string(operation) + " in the central history at " +
                                             url.shown + ": " + one_line(e.what()));
}

Params& Params::text(std::string_view v) {
  // PostgreSQL refuses text that is not UTF-8, and would refuse the record at every sync: a
  // note typed in another encoding goes in with U+FFFD for its stray bytes instead.
  values_.emplace_back(with_valid_utf8(v));
  return *this;
}

Params& Params::text_or_null(std::string_view v) {
  if (v.empty()) return null();
  return text(v);
}

Params& Params::integer(std::int64_t v) {
  values_.emplace_back(std::to_string(v));
  return *this;
}

Params& Params::integer(std::optional<std::int64_t> v) {
  if (!v) return null();
  return integer(*v);
}

Params& Params::number(double v) {
  // The shortest text that reads back as the same double, whatever the locale.
  char buf[40];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, v);
  values_.emplace_back(std::string(buf, r.ptr));
  return *this;
}

Params& Params::number(std::optional<double> v) {
  if (!v) return null();
  return number(*v);
}

Params& Params::null() {
  values_.emplace_back(std::nullopt);
  return *this;
}

Params& Params::append(const Params& other) {
  values_.insert(values_.end(), other.values_.begin(), other.values_.end());
  return *this;
}

std::string values_list(std::size_t rows, std::size_t width) {
  std::string out;
  out.reserve(rows * width * 6);
  std::size_t n = 0;
  for (std::size_t r = 0; r < rows; ++r) {
    out += r == 0 ? "(" : ", (";
    for (std::size_t c = 0; c < width; ++c) {
      out += (c == 0 ? "$" : ", $") + std::to_string(++n);
    }
    out += ")";
  }
  return out;
}

std::vector<const char*> Params::pointers() const {
  std::vector<const char*> out;
  out.reserve(values_.size());
  for (const std::optional<std::string>& v : values_) out.push_back(v ? v->c_str() : nullptr);
  return out;
}

pqxx::result exec(pqxx::transaction_base& tx, const std::string& sql, const Params& params) {
  const std::vector<const char*> p = params.pointers();
  return tx.exec_params(sql, pqxx::prepare::make_dynamic_params(p));
}

double number_of(const pqxx::field& f) {
  const char* text = f.c_str();
  const std::string_view s(text);
  double v = 0.0;
  if (s == "NaN") return std::nan("");
  if (s == "Infinity" || s == "-Infinity") return s[0] == '-' ? -HUGE_VAL : HUGE_VAL;
  std::from_chars(s.data(), s.data() + s.size(), v);
  return v;
}

std::optional<double> optional_number_of(const pqxx::field& f) {
  if (f.is_null()) return std::nullopt;
  return number_of(f);
}

std::string text_of(const pqxx::field& f) { return f.is_null() ? std::string() : std::string(f.c_str()); }

}  // namespace central_internal
}  // namespace gaugeloop
