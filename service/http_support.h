// What the HTTP API's routes share (service/http_api*.cc): the answers (JSON, errors), query
// and body parsing, the run database's connections and the files an answer is written to.
// Internal to the service's HTTP API.
#pragma once

#include <httplib.h>

#include <algorithm>
#include <charconv>
#include <climits>
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "core/idle_pool.h"
#include "core/result.h"
#include "report/run_json.h"
#include "storage/run_store.h"

namespace gaugeloop::http_detail {

namespace fs = std::filesystem;
using nlohmann::json;

// Every list the API reads in full (program names) asks for this many rows.
inline constexpr int kAll = INT_MAX;
inline constexpr int kMaxLimit = 100000;
// A trend's window unless `limit` says otherwise: about three weeks of a lobe measured every
// half hour, drawn readably, and read in a few milliseconds at any size of the history.
inline constexpr int kTrendDefaultRuns = 200;
inline constexpr int kMaxLobe = 1000;  // as `runs list --lobe`
inline constexpr std::size_t kMaxBodyBytes = 64 * 1024;
inline constexpr const char* kDocs = "see docs/http_api.md";

// ---- Answers ----

// Bodies are indented for people reading them with curl. Text from the database or the request
// that is not UTF-8 is replaced, never a reason to fail.
void send_json(httplib::Response& res, int status, const json& body);

void send_error(httplib::Response& res, int status, const std::string& message);

int http_status_for(ErrorCode code);

void send_error(httplib::Response& res, const Error& e);

// Turns the answer already set into one after which the connection ends: for answers given
// without reading the request's whole body. httplib 0.11 keeps a connection open whatever the
// answer's Connection header says, and would read the unread body as the next request, a line
// at a time with no bound on the line. A content provider that reports failure once it has
// written the whole answer is the one way 0.11 offers to end the connection after an answer;
// `Connection: close` tells the client.
void close_after_answer(const httplib::Request& req, httplib::Response& res);

Error bad_request(std::string message);

// ---- Query parameters ----

// The query of a GET request, checked against the parameters its endpoint knows: a misspelt
// filter must not silently widen the answer.
class Query {
 public:
  static Result<Query> of(const httplib::Request& req, std::vector<std::string> known) {
    std::set<std::string> seen;
    for (const auto& [name, value] : req.params) {
      if (std::find(known.begin(), known.end(), name) == known.end()) {
        std::string list;
        for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
        return bad_request("unknown query parameter `" + name + "` for " + req.path + "; it takes " +
                           (list.empty() ? std::string("none") : list) + " (" + kDocs + ")");
      }
      if (!seen.insert(name).second) return bad_request("query parameter `" + name + "` is given twice; give it once");
    }
    return Query(req);
  }

  std::string text(const std::string& name) const { return req_->get_param_value(name); }

  // An integer in [min, max], or `absent` when the parameter is not given.
  Result<int> integer(const std::string& name, int absent, int min, int max) const {
    if (!req_->has_param(name)) return absent;
    const std::string v = text(name);
    int out = 0;
    const auto [end, ec] = std::from_chars(v.data(), v.data() + v.size(), out);
    if (ec != std::errc() || end != v.data() + v.size() || v.empty() || out < min || out > max) {
      return bad_request("query parameter `" + name + "` must be a whole number from " + std::to_string(min) + " to " +
                         std::to_string(max) + ", not '" + v + "'");
    }
    return out;
  }

  Result<bool> flag(const std::string& name) const {
    const std::string v = text(name);
    if (v.empty() || v == "false" || v == "0") return false;
    if (v == "true" || v == "1") return true;
    return bad_request("query parameter `" + name + "` must be true or false, not '" + v + "'");
  }

  // A UTC time bound as `--since`/`--until` take it; see time_bound.
  Result<std::string> time(const std::string& name, bool until) const {
    return time_bound(text(name), until, "query parameter `" + name + "`:");
  }

  // One of `allowed`, or empty when not given.
  Result<std::string> choice(const std::string& name, const std::vector<std::string>& allowed) const {
    const std::string v = text(name);
    if (v.empty() || std::find(allowed.begin(), allowed.end(), v) != allowed.end()) return v;
    std::string list;
    for (const std::string& a : allowed) list += (list.empty() ? "" : " or ") + a;
    return bad_request("query parameter `" + name + "` must be " + list + ", not '" + v + "'");
  }

 private:
  explicit Query(const httplib::Request& req) : req_(&req) {}
  const httplib::Request* req_;
};

// The filters `runs list` and `runs trend` share.
Result<RunQuery> run_query(const Query& q, int default_limit);

// A positive id from a path segment, e.g. the 12 of /api/runs/12.
Result<std::int64_t> path_id(const std::string& text, const std::string& what);

// ---- Request bodies ----

// The body of a write: a JSON object with only the fields its endpoint knows.
Result<json> body_object(const std::string& text, const std::vector<std::string>& known, const char* example);

// A string field: kInvalidInput if of another type, or if required and missing or empty.
Result<std::string> string_field(const json& body, const std::string& name, bool required);

// A required integer field in [min, max].
Result<int> int_field(const json& body, const std::string& name, int min, int max);

// An optional boolean field: false when missing or null.
Result<bool> bool_field(const json& body, const std::string& name);

// An optional number field: empty when missing or null; kInvalidInput naming it for another type.
Result<std::optional<double>> number_field(const json& body, const std::string& name);

bool iequals(std::string_view a, std::string_view b);

// `application/json` in any case, with or without parameters such as `; charset=utf-8`.
bool is_json_media_type(std::string_view type);

// Equal in time that depends only on the length of `expected`, so the answer's timing does not
// tell how much of a guessed token was right.
bool same_secret(std::string_view given, std::string_view expected);

// ---- Run database connections ----

// Idle RunStores on the database, handed to one request at a time: a connection is used by one
// thread at a time, and requests reuse connections instead of opening (and checking the schema)
// each time.
class StorePool {
 public:
  using Lease = IdlePool<RunStore>::Lease;

  explicit StorePool(fs::path db) : db_(std::move(db)) {}

  // kStorage when there is no database yet or it cannot be opened (503).
  Result<Lease> acquire() {
    // RunStore::open would create an empty database: the API only reads what the service wrote.
    std::error_code ec;
    if (!fs::exists(db_, ec)) {
      return make_error(ErrorCode::kStorage, "no run database at " + db_.string() +
                                                 " yet; it is created by the first measurement (POST /api/measure, "
                                                 "the PLC, or `gaugeloop measure`)");
    }
    return pool_.acquire([this]() -> Result<RunStore> {
      Result<RunStore> store = RunStore::open(db_);
      if (!store) return make_error(ErrorCode::kStorage, store.error().message);
      return store;
    });
  }

  const fs::path& path() const { return db_; }

 private:
  const fs::path db_;
  IdlePool<RunStore> pool_;
};

// ---- Files ----

// What `write` puts in a file named `name` (its extension chooses the format), read back.
Result<std::string> file_written_by(const std::function<Status(const fs::path&)>& write, const std::string& name);

}  // namespace gaugeloop::http_detail
