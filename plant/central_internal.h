// What the central history's files (central_*.cc) share: the URL, the connection and the
// parameters of a statement. Internal to plant/: libpqxx never shows in a public header.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <pqxx/pqxx>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.h"
#include "plant/central_history.h"

namespace gaugeloop::central_internal {

// A connection to the central history, set up as every central query expects: floats printed
// exactly (extra_float_digits 3), UTF-8 text, UTC, a statement timeout of 300 s.
struct CentralConnection {
  CentralUrl url;
  std::unique_ptr<pqxx::connection> conn;
};

// Connects to `url`. kStorage naming the host, port and database and what to check when the
// server cannot be reached or refuses.
Result<CentralConnection> connect(const CentralUrl& url);

// kStorage "<operation> in the central history at <url>: <PostgreSQL's reason>" for an exception
// libpqxx threw; a lost connection says the server went away and what to do.
Error database_error(const CentralUrl& url, std::string_view operation, const std::exception& e);

// The text parameters of one statement: NULL is an empty optional. Numbers are written so
// PostgreSQL reads back exactly the double given (17 significant digits).
class Params {
 public:
  Params& text(std::string_view v);
  Params& text_or_null(std::string_view v);  // empty text: NULL
  Params& integer(std::int64_t v);
  Params& integer(std::optional<std::int64_t> v);
  Params& number(double v);
  Params& number(std::optional<double> v);
  Params& null();
  // `other`'s values after these: the parameters of one more row of a multi-row statement.
  Params& append(const Params& other);
  std::size_t size() const { return values_.size(); }
  // For exec_params / exec_prepared: NULL is a null pointer.
  std::vector<const char*> pointers() const;

 private:
  std::vector<std::optional<std::string>> values_;
};

pqxx::result exec(pqxx::transaction_base& tx, const std::string& sql, const Params& params);

// The multi-row VALUES list of `rows` rows of `width` parameters each, numbered from $1 row by
// row: "($1, $2), ($3, $4)" for 2 rows of 2.
std::string values_list(std::size_t rows, std::size_t width);

// PostgreSQL takes at most 65,535 parameters in one statement.
constexpr std::size_t kMaxParameters = 65535;

// A float8 column read back exactly (PostgreSQL prints the shortest text that reads back as
// the same double).
double number_of(const pqxx::field& f);
std::optional<double> optional_number_of(const pqxx::field& f);
std::string text_of(const pqxx::field& f);  // NULL reads as ""

}  // namespace gaugeloop::central_internal
