// The HTTP API on cpp-httplib: routes, query and body parsing, the token, errors as JSON, and
// the Prometheus metrics.
#include "service/http_api.h"

#include <httplib.h>
#include <spdlog/spdlog.h>
#include <stdlib.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <exception>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <regex>
#include <set>
#include <thread>
#include <tuple>
#include <utility>
#include <vector>

#include "core/guarded_thread.h"
#include "core/idle_pool.h"
#include "core/text_file.h"
#include "core/utc_time.h"
#include "job/layer_files.h"
#include "plant/central_history_pool.h"
#include "report/cam_report.h"
#include "report/gear_report.h"
#include "report/program_preview.h"
#include "report/run_json.h"
#include "report/svg_plot.h"
#include "service/metrics_text.h"
#include "service/web_assets.h"
#include "storage/run_store.h"

namespace gaugeloop {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Every list the API reads in full (program names) asks for this many rows.
constexpr int kAll = INT_MAX;
constexpr int kMaxLimit = 100000;
// A trend's window unless `limit` says otherwise: about three weeks of a lobe measured every
// half hour, drawn readably, and read in a few milliseconds at any size of the history.
constexpr int kTrendDefaultRuns = 1000;
constexpr int kMaxLobe = 1000;  // as `runs list --lobe`
constexpr std::size_t kMaxBodyBytes = 64 * 1024;
const char* const kDocs = "see docs/http_api.md";

// ---- Answers ----

// Bodies are indented for people reading them with curl. Text from the database or the request
// that is not UTF-8 is replaced, never a reason to fail.
void send_json(httplib::Response& res, int status, const json& body) {
  res.status = status;
  res.set_content(body.dump(2, ' ', false, json::error_handler_t::replace) + "\n", "application/json");
}

void send_error(httplib::Response& res, int status, const std::string& message) {
  send_json(res, status, json{{"error", message}});
}

int http_status_for(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidInput:
      return 400;
    case ErrorCode::kNotFound:
      return 404;
    case ErrorCode::kRefused:
      return 409;
    case ErrorCode::kStorage:
    case ErrorCode::kIo:
      return 503;
    case ErrorCode::kGaugeUnreachable:
    case ErrorCode::kGaugeTimeout:
    case ErrorCode::kGaugeProtocol:
    case ErrorCode::kIncompleteRun:
      return 502;
    case ErrorCode::kInternal:
      return 500;
  }
  return 500;
}

void send_error(httplib::Response& res, const Error& e) { send_error(res, http_status_for(e.code), e.message); }

// Turns the answer already set into one after which the connection ends: for answers given
// without reading the request's whole body. httplib 0.11 keeps a connection open whatever the
// answer's Connection header says, and would read the unread body as the next request, a line
// at a time with no bound on the line. A content provider that reports failure once it has
// written the whole answer is the one way 0.11 offers to end the connection after an answer;
// `Connection: close` tells the client.
void close_after_answer(const httplib::Request& req, httplib::Response& res) {
  if (req.get_header_value("Connection") != "close") res.set_header("Connection", "close");
  auto text = std::make_shared<const std::string>(std::move(res.body));
  res.body.clear();
  std::string type = res.get_header_value("Content-Type");
  if (text->empty()) {
    // set_content_provider needs a length: an empty answer is one newline.
    text = std::make_shared<const std::string>("\n");
    type = "text/plain";
  }
  res.set_content_provider(text->size(), type, [text](std::size_t offset, std::size_t length, httplib::DataSink& sink) {
    sink.write(text->data() + offset, length);
    return false;  // ends the connection after the answer
  });
}

Error bad_request(std::string message) { return make_error(ErrorCode::kInvalidInput, std::move(message)); }

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
Result<RunQuery> run_query(const Query& q, int default_limit) {
  RunQuery out;
  out.part = q.text("part");
  out.machine = q.text("machine");
  Result<int> lobe = q.integer("lobe", 0, 1, kMaxLobe);
  if (!lobe) return lobe.error();
  out.lobe = *lobe;
  Result<int> limit = q.integer("limit", default_limit, 1, kMaxLimit);
  if (!limit) return limit.error();
  out.limit = *limit;
  Result<std::string> since = q.time("since", false);
  if (!since) return since.error();
  out.since_utc = *since;
  Result<std::string> until = q.time("until", true);
  if (!until) return until.error();
  out.until_utc = *until;
  return out;
}

// A positive id from a path segment, e.g. the 12 of /api/runs/12.
Result<std::int64_t> path_id(const std::string& text, const std::string& what) {
  std::int64_t id = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), id);
  const bool whole = !text.empty() && end == text.data() + text.size();
  if (whole && ec == std::errc() && id >= 1) return id;
  // A number, but 0, negative or beyond 64 bits.
  if (whole) return bad_request(what + " " + text + " is out of range; ids are whole numbers from 1");
  return bad_request(what + " '" + text + "' is not a number; ids are whole numbers from 1");
}

// ---- Request bodies ----

// The body of a write: a JSON object with only the fields its endpoint knows.
Result<json> body_object(const std::string& text, const std::vector<std::string>& known, const char* example) {
  const std::string hint = std::string("; send a JSON object such as ") + example;
  if (text.empty()) return bad_request("the request body is empty" + hint);
  json body;
  try {
    body = json::parse(text);
  } catch (const json::parse_error& e) {
    // what(): "[json.exception.parse_error.101] parse error at line 1, column 2: ..."
    std::string why = e.what();
    if (const std::size_t at = why.find("] "); at != std::string::npos) why = why.substr(at + 2);
    return bad_request("the request body is not JSON: " + why + hint);
  }
  if (!body.is_object())
    return bad_request(std::string("the request body must be a JSON object, not ") + body.type_name() + hint);
  for (const auto& [key, value] : body.items()) {
    if (std::find(known.begin(), known.end(), key) == known.end()) {
      std::string list;
      for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
      return bad_request("unknown field `" + key + "` in the request body; it takes " + list);
    }
  }
  return body;
}

// A string field: kInvalidInput if of another type, or if required and missing or empty.
Result<std::string> string_field(const json& body, const std::string& name, bool required) {
  const auto it = body.find(name);
  if (it == body.end() || it->is_null()) {
    if (required) return bad_request("the request body needs `" + name + "` (a string)");
    return std::string();
  }
  if (!it->is_string()) return bad_request("`" + name + "` must be a string, not " + std::string(it->type_name()));
  std::string v = it->get<std::string>();
  if (required && v.empty()) return bad_request("`" + name + "` must not be empty");
  return v;
}

// A required integer field in [min, max].
Result<int> int_field(const json& body, const std::string& name, int min, int max) {
  const auto it = body.find(name);
  if (it == body.end() || it->is_null()) return bad_request("the request body needs `" + name + "` (a whole number)");
  const bool whole =
      it->is_number_integer() || (it->is_number_float() && std::floor(it->get<double>()) == it->get<double>());
  if (!whole || it->get<double>() < min || it->get<double>() > max) {
    return bad_request("`" + name + "` must be a whole number from " + std::to_string(min) + " to " +
                       std::to_string(max) + ", not " + it->dump(-1, ' ', false, json::error_handler_t::replace));
  }
  return static_cast<int>(it->get<double>());
}

// An optional boolean field: false when missing or null.
Result<bool> bool_field(const json& body, const std::string& name) {
  const auto it = body.find(name);
  if (it == body.end() || it->is_null()) return false;
  if (!it->is_boolean())
    return bad_request("`" + name + "` must be true or false, not " + std::string(it->type_name()));
  return it->get<bool>();
}

bool iequals(std::string_view a, std::string_view b) {
  return a.size() == b.size() && std::equal(a.begin(), a.end(), b.begin(), [](char x, char y) {
           return std::tolower(static_cast<unsigned char>(x)) == std::tolower(static_cast<unsigned char>(y));
         });
}

// `application/json` in any case, with or without parameters such as `; charset=utf-8`.
bool is_json_media_type(std::string_view type) {
  type = type.substr(0, type.find(';'));
  while (!type.empty() && (type.back() == ' ' || type.back() == '\t')) type.remove_suffix(1);
  while (!type.empty() && (type.front() == ' ' || type.front() == '\t')) type.remove_prefix(1);
  return iequals(type, "application/json");
}

// Equal in time that depends only on the length of `expected`, so the answer's timing does not
// tell how much of a guessed token was right.
bool same_secret(std::string_view given, std::string_view expected) {
  unsigned char diff = given.size() == expected.size() ? 0 : 1;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const char g = i < given.size() ? given[i] : '\0';
    diff = static_cast<unsigned char>(diff | (static_cast<unsigned char>(g) ^ static_cast<unsigned char>(expected[i])));
  }
  return diff == 0;
}

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

// Program names a client gives, against the NC files the history knows: "CAM_INTAKE_L1",
// "CAM_INTAKE_L1.SPF", or the file's path as recorded.
bool names_file(const std::string& program, const std::string& nc_file) {
  if (program == nc_file) return true;
  std::string name = program;
  if (name.size() > 4 && (name.ends_with(".SPF") || name.ends_with(".spf"))) name.resize(name.size() - 4);
  return fs::path(nc_file).stem().string() == name;
}

std::string program_list(const std::set<std::string>& files) {
  std::string list;
  for (const std::string& f : files) list += (list.empty() ? "" : ", ") + fs::path(f).stem().string();
  return list;
}

// The NC files tables were pushed to (and, with `pending`, those with pending tables).
Result<std::set<std::string>> known_files(const RunStore& store, bool pending) {
  std::set<std::string> files;
  PushQuery pq;
  pq.limit = kAll;
  Result<std::vector<NcPush>> pushes = store.list_pushes(pq);
  if (!pushes) return pushes.error();
  for (const NcPush& p : *pushes) files.insert(p.nc_file);
  if (pending) {
    PendingQuery q;
    q.limit = kAll;
    Result<std::vector<PendingTable>> tables = store.list_pending(q);
    if (!tables) return tables.error();
    for (const PendingTable& t : *tables) files.insert(t.nc_file);
  }
  return files;
}

// The one NC file `program` names; empty `program`: the only file there is.
Result<std::string> resolve_program(const RunStore& store, const std::string& program, bool pending) {
  Result<std::set<std::string>> files = known_files(store, pending);
  if (!files) return files.error();
  if (program.empty()) {
    if (files->size() == 1) return *files->begin();
    if (files->empty()) {
      return make_error(ErrorCode::kNotFound,
                        "no table was pushed yet; the first measurement writes one (POST /api/measure)");
    }
    return bad_request("tables were pushed to several programs (" + program_list(*files) +
                       "): name one with ?program=NAME");
  }
  std::set<std::string> named;
  for (const std::string& f : *files) {
    if (names_file(program, f)) named.insert(f);
  }
  if (named.size() == 1) return *named.begin();
  if (named.empty()) {
    return make_error(ErrorCode::kNotFound, "no table of program '" + program + "' is recorded; " +
                                                (files->empty() ? std::string("no table was pushed yet")
                                                                : "the programs are " + program_list(*files)));
  }
  std::string paths;
  for (const std::string& f : named) paths += (paths.empty() ? "" : ", ") + f;
  return bad_request("program '" + program + "' names several NC files (" + paths +
                     "); give the path as ?program=PATH");
}

// ---- Pictures and files ----

// A directory of its own under the system's temporary directory, removed with everything in it
// when this ends: the report and trend writers write files, and two requests must not share one.
class ScratchDir {
 public:
  static Result<ScratchDir> make() {
    std::error_code ec;
    std::string pattern = (fs::temp_directory_path(ec) / "gaugeloop-http-XXXXXX").string();
    if (ec || ::mkdtemp(pattern.data()) == nullptr) {
      return make_error(ErrorCode::kIo, "cannot make a temporary directory for the file (" + pattern +
                                            "); check that TMPDIR names a writable directory");
    }
    return ScratchDir(fs::path(pattern));
  }
  ScratchDir(ScratchDir&& other) noexcept : path_(std::exchange(other.path_, fs::path())) {}
  ScratchDir& operator=(ScratchDir&&) = delete;
  ~ScratchDir() {
    std::error_code ec;
    if (!path_.empty()) fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  explicit ScratchDir(fs::path path) : path_(std::move(path)) {}
  fs::path path_;
};

}  // namespace

// ---- The server ----

struct HttpApi::Impl {
  Impl(HttpSettings s, fs::path db, HttpWrites w, HttpStatus st, std::unique_ptr<httplib::Server> srv)
      : settings(std::move(s)),
        stores(std::move(db)),
        central(settings.history_url.empty() ? nullptr : std::make_unique<CentralHistoryPool>(settings.history_url)),
        writes(std::move(w)),
        status(std::move(st)),
        server(std::move(srv)) {}

  using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;
  // A write: the request and its body, read whole.
  using WriteHandler = std::function<void(const httplib::Request&, const std::string& body, httplib::Response&)>;

  // Registers a read behind the one boundary that turns any exception into a 500.
  void route(const std::string& pattern, Handler handler) {
    routes.emplace_back("GET", std::regex(pattern));
    server->Get(pattern, [handler = std::move(handler)](const httplib::Request& req, httplib::Response& res) {
      try {
        handler(req, res);
      } catch (...) {
        internal_error(req, res, std::current_exception());
      }
    });
  }

  // Registers a write, behind the same boundary. Its body is read here as it arrives and never
  // beyond kMaxBodyBytes, whatever its transfer encoding: httplib's own limit holds only for a
  // body with a Content-Length. before_body has checked the token and the headers.
  void route_write(const std::string& pattern, WriteHandler handler) {
    routes.emplace_back("POST", std::regex(pattern));
    server->Post(pattern, [handler = std::move(handler)](const httplib::Request& req, httplib::Response& res,
                                                         const httplib::ContentReader& read) {
      try {
        std::string body;
        bool too_large = false;
        const bool whole = read([&](const char* data, std::size_t size) {
          too_large = size > kMaxBodyBytes - body.size();
          if (!too_large) body.append(data, size);
          return !too_large;
        });
        if (!whole) {
          send_error(res, too_large ? 413 : 400,
                     too_large ? too_large_message()
                               : "the request body ended before its announced length, or a chunk of it is malformed; "
                                 "send the JSON whole");
          return close_after_answer(req, res);
        }
        handler(req, body, res);
      } catch (...) {
        internal_error(req, res, std::current_exception());
      }
    });
  }

  static std::string too_large_message() {
    return "the request body is larger than " + std::to_string(kMaxBodyBytes / 1024) +
           " KiB; the API's bodies are small JSON objects (" + kDocs + ")";
  }

  // Whether `method` (HEAD as GET) has a route matching `path`.
  bool has_route(const std::string& method, const std::string& path) const {
    const std::string m = method == "HEAD" ? "GET" : method;
    return std::any_of(routes.begin(), routes.end(),
                       [&](const auto& r) { return r.first == m && std::regex_match(path, r.second); });
  }

  // Runs once the request's head is read and before any of its body: httplib reads the body of
  // a POST, PUT, PATCH or DELETE whole before routing it (a chunked one, or one without a
  // length, with no bound), and leaves a GET's body unread to be parsed as the next request. So
  // a request with a body where none is taken is answered here; a write's token is checked
  // before a byte of its body is read, then its framing, length and type. Every answer given
  // here ends the connection, the body unread.
  httplib::Server::HandlerResponse before_body(const httplib::Request& req, httplib::Response& res) const {
    using httplib::Server;
    const auto answered = [&] {
      close_after_answer(req, res);
      return Server::HandlerResponse::Handled;
    };
    const auto refuse = [&](int code, const std::string& message) {
      send_error(res, code, message);
      return answered();
    };
    const bool chunked = req.has_header("Transfer-Encoding");
    const bool sized = req.has_header("Content-Length");
    const std::string length = req.get_header_value("Content-Length");
    if (!(req.method == "POST" && has_route("POST", req.path))) {
      const bool body_method = req.method == "POST" || req.method == "PUT" || req.method == "PATCH" ||
                               req.method == "DELETE" || req.method == "PRI";
      if (!body_method && !chunked && !(sized && length != "0")) return Server::HandlerResponse::Unhandled;
      if (!has_route(req.method, req.path)) {
        answer_no_route(req, res);
        return answered();
      }
      return refuse(400, req.method + " " + req.path + " takes no request body; give its parameters in the query (" +
                             kDocs + ")");
    }
    if (!authorized(req, res)) return answered();
    if (chunked && sized) {
      return refuse(400, "the request has both Transfer-Encoding and Content-Length; send one of them");
    }
    if (chunked && !iequals(req.get_header_value("Transfer-Encoding"), "chunked")) {
      return refuse(501, "Transfer-Encoding '" + req.get_header_value("Transfer-Encoding") +
                             "' is not supported; send the body with a Content-Length (or chunked)");
    }
    if (!chunked && !sized) {
      return refuse(411, "POST " + req.path +
                             " needs a Content-Length header (or Transfer-Encoding: chunked) to say where its body "
                             "ends; send the JSON body with its length, as curl -d does");
    }
    if (sized) {
      std::uint64_t bytes = 0;
      const auto [end, ec] = std::from_chars(length.data(), length.data() + length.size(), bytes);
      if (ec == std::errc::result_out_of_range || (ec == std::errc() && bytes > kMaxBodyBytes)) {
        return refuse(413, too_large_message());
      }
      if (ec != std::errc() || end != length.data() + length.size()) {
        return refuse(400, "Content-Length '" + length + "' is not a number of bytes");
      }
    }
    if (const std::string coding = req.get_header_value("Content-Encoding");
        !coding.empty() && !iequals(coding, "identity")) {
      return refuse(415, "Content-Encoding '" + coding + "' is not taken; send the JSON body uncompressed");
    }
    if (!is_json_media_type(req.get_header_value("Content-Type"))) {
      const std::string type = req.get_header_value("Content-Type");
      return refuse(415, (type.empty() ? std::string("the request has no Content-Type")
                                       : "Content-Type '" + type + "' is not JSON") +
                             "; send the body as JSON with the header `Content-Type: application/json`");
    }
    return Server::HandlerResponse::Unhandled;
  }

  static void internal_error(const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
    std::string what = "unknown exception";
    try {
      if (ep) std::rethrow_exception(ep);
    } catch (const std::exception& e) {
      what = e.what();
    } catch (...) {
    }
    spdlog::error("http: {} {} failed: {}", req.method, req.path, what);
    send_error(res, 500,
               "internal error answering " + req.method + " " + req.path + ": " + what +
                   "; this is a bug in gaugeloop, please report it with the service log");
  }

  // Every answer of 400 or more without a body (no route, a request httplib refused) gets one.
  void fill_error(const httplib::Request& req, httplib::Response& res) const {
    if (!res.body.empty() || res.has_header("Content-Type")) return;  // ours, maybe as a content provider
    if (res.status == 404) return answer_no_route(req, res);
    if (res.status == 413) return send_error(res, 413, too_large_message());
    send_error(res, res.status, "the request was malformed (HTTP status " + std::to_string(res.status) + ")");
  }

  // 405 naming the method the path takes, or 404.
  void answer_no_route(const httplib::Request& req, httplib::Response& res) const {
    std::string allowed;
    for (const auto& [method, pattern] : routes) {
      if (method != req.method && std::regex_match(req.path, pattern)) allowed = method;
    }
    if (!allowed.empty()) {
      res.set_header("Allow", allowed);
      send_error(res, 405, req.method + " is not allowed on " + req.path + "; use " + allowed + " (" + kDocs + ")");
      return;
    }
    send_error(res, 404,
               "no such endpoint: " + req.method + " " + req.path + "; the API is under /api/ and " +
                   "/metrics, the pages at /ui/ (" + kDocs + ")");
  }

  // ---- Reads ----

  // Takes no parameters and ignores any: a monitor's cache-busting `?t=...` must not turn
  // "the service answers" into a 400.
  void health(const httplib::Request&, httplib::Response& res) {
    json out = json::object();
    if (status.health) {
      json service = status.health();
      if (service.is_object()) out.update(service);
    }
    out["version"] = GAUGELOOP_VERSION;
    out["time_utc"] = format_utc(std::time(nullptr));
    json db{{"path", stores.path().string()}};
    Result<StorePool::Lease> store = stores.acquire();
    db["available"] = store.ok();
    if (!store) db["error"] = store.error().message;
    out["database"] = db;
    out["writes"] = current_token().empty() ? "disabled (no token configured)" : "enabled with the token";
    // The shafts /api/shaft knows, so a client asks for a record only when there can be one.
    json shafts = json::array();
    if (status.shafts) {
      for (const ShaftLayout& l : status.shafts()) shafts.push_back(l.name);
    }
    out["shafts"] = shafts;
    send_json(res, 200, out);
  }

  void list_runs(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q =
        Query::of(req, {"part", "lobe", "machine", "serial", "since", "until", "status", "verdict", "limit"});
    if (!q) return send_error(res, q.error());
    Result<RunQuery> rq = run_query(*q, 50);
    if (!rq) return send_error(res, rq.error());
    rq->serial = q->text("serial");  // matched exactly
    Result<std::string> st = q->choice("status", {"measured", "pushed"});
    if (!st) return send_error(res, st.error());
    rq->status = *st;
    Result<std::string> verdict = q->choice("verdict", {"in", "out", "not_judged"});
    if (!verdict) return send_error(res, verdict.error());
    if (!verdict->empty()) rq->verdict = verdict_from_name(*verdict);
    with_history(res, [&](const RunHistory& history) { return history.list_runs(*rq); });
  }

  void list_gear_runs(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"part", "machine", "serial", "since", "until", "verdict", "limit"});
    if (!q) return send_error(res, q.error());
    Result<RunQuery> rq = run_query(*q, 50);
    if (!rq) return send_error(res, rq.error());
    GearRunQuery gq;
    gq.part = rq->part;
    gq.machine = rq->machine;
    gq.serial = q->text("serial");
    gq.limit = rq->limit;
    gq.since_utc = rq->since_utc;
    gq.until_utc = rq->until_utc;
    Result<std::string> verdict = q->choice("verdict", {"in", "out", "not_judged"});
    if (!verdict) return send_error(res, verdict.error());
    if (!verdict->empty()) gq.verdict = verdict_from_name(*verdict);
    with_store(res, [&](RunStore& store) -> Result<json> {
      Result<std::vector<StoredGearRun>> runs = store.list_gear_runs(gq);
      if (!runs) return runs.error();
      json out = json::array();
      for (const StoredGearRun& g : *runs) out.push_back(gear_run_json(g, false));
      return out;
    });
  }

  void gear_run_report(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {});
    if (!q) return send_error(res, q.error());
    Result<std::int64_t> id = path_id(req.matches[1], "gear run id");
    if (!id) return send_error(res, id.error());
    Result<StorePool::Lease> store = stores.acquire();
    if (!store) return send_error(res, store.error());
    Result<StoredGearRun> run = (*store)->load_gear_run(*id);
    if (!run) return fail_with_store(res, *store, run.error());
    const std::string name = "gear_run" + std::to_string(*id) + ".pdf";
    Result<std::string> pdf = file_written_by([&](const fs::path& out) { return write_gear_report(*run, out); }, name);
    if (!pdf) return send_error(res, pdf.error());
    res.status = 200;
    res.set_header("Content-Disposition", "inline; filename=\"" + name + "\"");
    res.set_content(std::move(*pdf), "application/pdf");
  }

  void show_gear_run(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {});
    if (!q) return send_error(res, q.error());
    Result<std::int64_t> id = path_id(req.matches[1], "gear run id");
    if (!id) return send_error(res, id.error());
    with_store(res, [&](RunStore& store) -> Result<json> {
      Result<StoredGearRun> run = store.load_gear_run(*id);
      if (!run && run.error().code == ErrorCode::kNotFound) {
        return make_error(ErrorCode::kNotFound, run.error().message + "; GET /api/gear-runs lists the ids");
      }
      if (!run) return run.error();
      return gear_run_json(*run, true);
    });
  }

  Result<StoredRun> load_run(RunStore& store, const std::string& id_text) {
    Result<std::int64_t> id = path_id(id_text, "run id");
    if (!id) return id.error();
    Result<StoredRun> run = store.load_run(*id);
    if (!run && run.error().code == ErrorCode::kNotFound) {
      return make_error(ErrorCode::kNotFound, run.error().message + "; GET /api/runs lists the ids");
    }
    return run;
  }

  void show_run(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {});
    if (!q) return send_error(res, q.error());
    with_store(res, [&](RunStore& store) -> Result<json> {
      Result<StoredRun> run = load_run(store, req.matches[1]);
      if (!run) return run.error();
      return run_detail_json(*run);
    });
  }

  void export_run(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"comments"});
    if (!q) return send_error(res, q.error());
    Result<bool> comments = q->flag("comments");
    if (!comments) return send_error(res, comments.error());
    Result<StorePool::Lease> store = stores.acquire();
    if (!store) return send_error(res, store.error());
    Result<StoredRun> run = load_run(**store, req.matches[1]);
    if (!run) return fail_with_store(res, *store, run.error());
    res.status = 200;
    res.set_header("Content-Disposition", "inline; filename=\"run" + std::to_string(run->summary.id) + ".csv\"");
    res.set_content(run_csv(*run, *comments), "text/csv; charset=utf-8");
  }

  void trend(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"part", "lobe", "machine", "since", "until", "limit"});
    if (!q) return send_error(res, q.error());
    Result<RunQuery> rq = run_query(*q, kTrendDefaultRuns);
    if (!rq) return send_error(res, rq.error());
    if (rq->part.empty() || rq->lobe == 0) {
      return send_error(res, 400, "a trend is of one lobe: give both `part` and `lobe`, e.g. ?part=intake_flat&lobe=1");
    }
    with_history(res, [&](const RunHistory& history) { return history.trend(*rq); });
  }

  void events(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"kind", "machine", "part", "since", "until", "limit"});
    if (!q) return send_error(res, q.error());
    EventQuery eq;
    Result<std::string> kind = q->choice("kind", {"fault", "refusal", "info"});
    if (!kind) return send_error(res, kind.error());
    if (*kind == "fault") eq.kind = EventKind::kFault;
    if (*kind == "refusal") eq.kind = EventKind::kRefusal;
    if (*kind == "info") eq.kind = EventKind::kInfo;
    eq.machine = q->text("machine");
    eq.part = q->text("part");
    Result<int> limit = q->integer("limit", 50, 1, kMaxLimit);
    if (!limit) return send_error(res, limit.error());
    eq.limit = *limit;
    Result<std::string> since = q->time("since", false);
    if (!since) return send_error(res, since.error());
    eq.since_utc = *since;
    Result<std::string> until = q->time("until", true);
    if (!until) return send_error(res, until.error());
    eq.until_utc = *until;
    with_store(res, [&](RunStore& store) -> Result<json> {
      Result<std::vector<StoredEvent>> events = store.list_events(eq);
      if (!events) return events.error();
      json out = json::array();
      for (const StoredEvent& e : *events) out.push_back(event_json(e));
      return out;
    });
  }

  void nc_table(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"program", "version"});
    if (!q) return send_error(res, q.error());
    // Any version the history holds (for a diff of two); without `version`, the one in force.
    Result<int> version = q->integer("version", 0, 1, INT_MAX);
    if (!version) return send_error(res, version.error());
    with_store(res, [&](RunStore& store) -> Result<json> {
      Result<std::string> file = resolve_program(store, q->text("program"), false);
      if (!file) return file.error();
      std::optional<NcPush> push;
      if (*version > 0) {
        Result<NcPush> one = store.load_push(*file, *version);
        if (!one) {
          if (one.error().code != ErrorCode::kNotFound) return one.error();
          return make_error(ErrorCode::kNotFound, one.error().message + "; GET /api/nc/history lists the versions");
        }
        push = std::move(*one);
      } else {
        Result<std::optional<NcPush>> last = store.last_push(*file);
        if (!last) return last.error();
        push = std::move(*last);
      }
      if (!push) return make_error(ErrorCode::kNotFound, "no table was pushed to " + *file);
      json out = nc_push_json(*push);
      out["program"] = fs::path(*file).stem().string();
      out["program_text"] = push->program_text ? json(*push->program_text) : json(nullptr);
      // A correction layer: the design table the control adds it to, as it holds it now.
      out["layer"] = nullptr;
      if (push->program_text) {
        Result<std::optional<LayerOnControl>> layer = layer_on_control(*push->program_text, *file);
        if (layer && *layer) {
          const LayerOnControl& l = **layer;
          out["layer"] = {{"design_program", fs::path(l.design_file).stem().string()},
                          {"design_table_number", l.design_table_number},
                          {"design_text", l.problem.empty() ? json(l.design_text) : json(nullptr)},
                          {"design_problem", l.problem.empty() ? json(nullptr) : json(l.problem)}};
        }
      }
      return out;
    });
  }

  void nc_history(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"program", "limit"});
    if (!q) return send_error(res, q.error());
    Result<int> limit = q->integer("limit", 50, 1, kMaxLimit);
    if (!limit) return send_error(res, limit.error());
    with_store(res, [&](RunStore& store) -> Result<json> {
      PushQuery pq;
      pq.limit = *limit;
      if (const std::string program = q->text("program"); !program.empty()) {
        Result<std::string> file = resolve_program(store, program, false);
        if (!file) return file.error();
        pq.nc_file = *file;
      }
      Result<std::vector<NcPush>> pushes = store.list_pushes(pq);
      if (!pushes) return pushes.error();
      json out = json::array();
      for (const NcPush& p : *pushes) out.push_back(nc_push_json(p));
      return out;
    });
  }

  void nc_pending(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"program", "all", "limit"});
    if (!q) return send_error(res, q.error());
    Result<int> limit = q->integer("limit", 50, 1, kMaxLimit);
    if (!limit) return send_error(res, limit.error());
    Result<bool> all = q->flag("all");
    if (!all) return send_error(res, all.error());
    with_store(res, [&](RunStore& store) -> Result<json> {
      PendingQuery pq;
      pq.limit = *limit;
      if (!*all) pq.status = PendingStatus::kPending;
      if (const std::string program = q->text("program"); !program.empty()) {
        Result<std::string> file = resolve_program(store, program, true);
        if (!file) return file.error();
        pq.nc_file = *file;
      }
      Result<std::vector<PendingTable>> tables = store.list_pending(pq);
      if (!tables) return tables.error();
      json out = json::array();
      for (const PendingTable& t : *tables) out.push_back(pending_table_json(t));
      return out;
    });
  }

  // One pending table with its program text, for a look at it (and a diff) before deciding.
  void pending_table(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {});
    if (!q) return send_error(res, q.error());
    with_store(res, [&](RunStore& store) -> Result<json> {
      Result<std::int64_t> id = path_id(req.matches[1], "pending table id");
      if (!id) return id.error();
      Result<PendingTable> table = store.load_pending(*id);
      if (!table) {
        if (table.error().code != ErrorCode::kNotFound) return table.error();
        return make_error(ErrorCode::kNotFound, table.error().message + "; GET /api/nc/pending?all=true lists the ids");
      }
      json out = pending_table_json(*table);
      out["program"] = fs::path(table->nc_file).stem().string();
      out["program_text"] = table->program_text;
      return out;
    });
  }

  // The shaft record of a serial, as `gaugeloop runs shaft --json`, against the shaft the
  // service knows that `shaft` names; without it, the one shaft, or the one the serial has
  // runs of.
  void shaft(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"serial", "shaft"});
    if (!q) return send_error(res, q.error());
    const std::string serial = q->text("serial");
    if (serial.empty())
      return send_error(res, 400, "a shaft record is of one shaft: give its serial, e.g. ?serial=CS-0042");
    const std::vector<ShaftLayout> layouts = status.shafts ? status.shafts() : std::vector<ShaftLayout>{};
    if (layouts.empty()) {
      return send_error(res, 404,
                        "this service knows no shaft file, so it gives no index errors; GET /api/runs?serial=" +
                            serial + " lists the lobes measured, `gaugeloop runs shaft --shaft FILE` gives the record");
    }
    std::string names;
    for (const ShaftLayout& l : layouts) names += (names.empty() ? "" : ", ") + l.name;
    std::vector<const ShaftLayout*> named;
    for (const ShaftLayout& l : layouts) {
      if (q->text("shaft").empty() || l.name == q->text("shaft")) named.push_back(&l);
    }
    if (named.empty()) {
      return send_error(res, 404, "no shaft '" + q->text("shaft") + "' is known; the shafts are " + names);
    }
    with_store(res, [&](RunStore& store) -> Result<json> {
      std::vector<ShaftRecord> measured;
      for (const ShaftLayout* layout : named) {
        Result<ShaftRecord> record = load_shaft_record(store, *layout, serial);
        if (!record) return record.error();
        if (named.size() == 1) return shaft_record_json(*record);  // the one asked for, measured or not
        if (std::any_of(record->lobes.begin(), record->lobes.end(),
                        [](const ShaftLobeRecord& l) { return l.run.has_value(); })) {
          measured.push_back(std::move(*record));
        }
      }
      if (measured.size() == 1) return shaft_record_json(measured.front());
      if (measured.empty()) {
        return make_error(ErrorCode::kNotFound,
                          "no lobe of the shafts " + names + " was measured with serial " + serial);
      }
      std::string which;
      for (const ShaftRecord& r : measured) which += (which.empty() ? "" : ", ") + r.layout.name;
      return bad_request("serial " + serial + " has runs on several shafts (" + which + "): name one with ?shaft=NAME");
    });
  }

  // ---- Pictures and documents ----

  // The run the path names, for an answer made of it alone (no query parameters); nullopt when
  // the error was sent.
  std::optional<StoredRun> path_run(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {});
    if (!q) {
      send_error(res, q.error());
      return std::nullopt;
    }
    Result<StorePool::Lease> store = stores.acquire();
    if (!store) {
      send_error(res, store.error());
      return std::nullopt;
    }
    Result<StoredRun> run = load_run(**store, req.matches[1]);
    if (!run) {
      fail_with_store(res, *store, run.error());
      return std::nullopt;
    }
    return std::move(*run);
  }

  void run_plot(const httplib::Request& req, httplib::Response& res) {
    const std::optional<StoredRun> run = path_run(req, res);
    if (!run) return;
    res.status = 200;
    res.set_content(render_error_plot_svg(run_error_plot(*run)), "image/svg+xml");
  }

  // The cam report as `runs report` writes it, written to a file of its own and served from it.
  void run_report(const httplib::Request& req, httplib::Response& res) {
    const std::optional<StoredRun> run = path_run(req, res);
    if (!run) return;
    const std::string name = "run" + std::to_string(run->summary.id) + ".pdf";
    Result<std::string> pdf = file_written_by([&](const fs::path& out) { return write_cam_report(*run, out); }, name);
    if (!pdf) return send_error(res, pdf.error());
    res.status = 200;
    res.set_header("Content-Disposition", "inline; filename=\"" + name + "\"");
    res.set_content(std::move(*pdf), "application/pdf");
  }

  // One characteristic of a lobe over its runs, with its limits: the trend plot of
  // `runs trend --plot`, as SVG.
  void trend_plot(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {"part", "lobe", "machine", "since", "until", "limit", "key"});
    if (!q) return send_error(res, q.error());
    Result<RunQuery> rq = run_query(*q, kTrendDefaultRuns);
    if (!rq) return send_error(res, rq.error());
    if (rq->part.empty() || rq->lobe == 0) {
      return send_error(
          res, 400,
          "a trend is of one lobe: give both `part` and `lobe`, e.g. ?part=intake_flat&lobe=1&key=lift_error");
    }
    const std::string key = q->text("key").empty() ? std::string("lift_error") : q->text("key");
    Result<std::vector<RunCharacteristics>> runs =
        read_history([&](const RunHistory& history) { return history.characteristics(*rq); });
    if (!runs) return send_error(res, runs.error());
    if (runs->empty()) {
      return send_error(res, 404,
                        "no runs of " + rq->part + " lobe " + std::to_string(rq->lobe) +
                            " match; GET /api/runs lists which parts and lobes have runs");
    }
    Result<std::string> svg =
        file_written_by([&](const fs::path& out) { return write_trend_plot(*runs, key, out); }, "trend.svg");
    if (!svg) return send_error(res, svg.error());
    res.status = 200;
    res.set_content(std::move(*svg), "image/svg+xml");
  }

  // What `write` puts in a file named `name` (its extension chooses the format), read back.
  static Result<std::string> file_written_by(const std::function<Status(const fs::path&)>& write,
                                             const std::string& name) {
    Result<ScratchDir> dir = ScratchDir::make();
    if (!dir) return dir.error();
    const fs::path out = dir->path() / name;
    if (Status s = write(out); !s) return s.error();
    return read_regular_file(out, "the file written for the answer");
  }

  // ---- Pages ----

  // The pages' files, built into the binary (service/web). /ui/ is the app (index.html).
  void page_asset(const httplib::Request& req, httplib::Response& res) {
    const std::string name = req.matches[1].str().empty() ? std::string("index.html") : req.matches[1].str();
    const WebAsset* asset = find_web_asset(name);
    if (asset == nullptr) {
      return send_error(
          res, 404,
          "no such page file: " + req.path + "; the pages start at /ui/ (the run history), see " + std::string(kDocs));
    }
    res.status = 200;
    // Checked again on every load, so the pages of an updated service show at once.
    res.set_header("Cache-Control", "no-cache");
    // Only this service's own script runs, whatever text a run or a table brings into a page;
    // inline styles stay allowed for the plots' SVG.
    res.set_header("Content-Security-Policy",
                   "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data:; "
                   "frame-ancestors 'none'; base-uri 'none'; form-action 'self'");
    res.set_header("X-Content-Type-Options", "nosniff");
    res.set_content(std::string(asset->body), std::string(asset->content_type));
  }

  static void redirect_to_pages(const httplib::Request&, httplib::Response& res) {
    res.status = 302;
    res.set_header("Location", "/ui/");
    res.set_content("the pages are at /ui/\n", "text/plain; charset=utf-8");
  }

  void metrics(const httplib::Request& req, httplib::Response& res) {
    Result<Query> q = Query::of(req, {});
    if (!q) return send_error(res, q.error());
    std::string text;
    Result<StorePool::Lease> store = stores.acquire();
    Status read = store ? append_database_metrics(**store, text) : Status(store.error());
    if (read) {
      database_log.note(DatabaseState::kUp);
    } else {
      if (store) store->discard();
      // No file before the first run is normal: gaugeloop_database_up 0 says so, the log does not.
      std::error_code ec;
      const bool missing = !fs::exists(stores.path(), ec) && !ec;
      database_log.note(missing ? DatabaseState::kMissing : DatabaseState::kFailed, read.error().message);
    }
    append_database_up(read.ok(), text);
    append_build_info(text);
    if (status.extra_metrics) {
      std::string extra = status.extra_metrics();
      if (!extra.empty() && extra.back() != '\n') extra += '\n';
      text += extra;
    }
    res.status = 200;
    res.set_content(text, "text/plain; version=0.0.4; charset=utf-8");
  }

  // ---- Writes ----

  // The token check every write passes first, before its body is read (before_body). False:
  // the answer is already set.
  bool authorized(const httplib::Request& req, httplib::Response& res) const {
    const std::string expected = current_token();
    if (expected.empty()) {
      send_error(res, 403,
                 "the API is read-only: no token is configured; set one in the service's [http] config to allow "
                 "writes");
      return false;
    }
    const std::string header = req.get_header_value("Authorization");
    constexpr std::string_view kScheme = "Bearer ";
    const bool bearer =
        header.size() >= kScheme.size() && iequals(std::string_view(header).substr(0, kScheme.size()), kScheme);
    if (!bearer || !same_secret(std::string_view(header).substr(kScheme.size()), expected)) {
      res.set_header("WWW-Authenticate", "Bearer realm=\"gaugeloop\"");
      send_error(res, 401,
                 header.empty() ? "this write needs the header `Authorization: Bearer <token>`"
                 : !bearer      ? "the Authorization header must be `Bearer <token>`"
                                : "the token is not the one configured");
      return false;
    }
    return true;
  }

  static void answer(httplib::Response& res, const Result<json>& out) {
    if (!out) return send_error(res, out.error());
    send_json(res, 200, *out);
  }

  void measure(const httplib::Request&, const std::string& text, httplib::Response& res) {
    if (!writes.trigger_measure) return send_error(res, 501, "this service does not take measurement triggers");
    Result<json> body = body_object(text, {"part", "lobe", "note", "serial", "operator"},
                                    R"({"part": "intake_flat", "lobe": 1, "serial": "A123", "operator": "anna"})");
    if (!body) return send_error(res, body.error());
    Result<std::string> part = string_field(*body, "part", true);
    if (!part) return send_error(res, part.error());
    Result<int> lobe = int_field(*body, "lobe", 1, kMaxLobe);
    if (!lobe) return send_error(res, lobe.error());
    Result<std::string> note = string_field(*body, "note", false);
    if (!note) return send_error(res, note.error());
    // Empty or null: not given. Checked here so a bad one is a 400 before the run is queued.
    Result<std::string> serial = string_field(*body, "serial", false);
    if (!serial) return send_error(res, serial.error());
    if (Status s = check_run_identity("`serial`", *serial); !s) return send_error(res, s.error());
    Result<std::string> operator_name = string_field(*body, "operator", false);
    if (!operator_name) return send_error(res, operator_name.error());
    if (Status s = check_run_identity("`operator`", *operator_name); !s) return send_error(res, s.error());
    answer(res, writes.trigger_measure(*part, *lobe, *note, *serial, *operator_name));
  }

  // Approve and reject take the same body; `hook` decides, and its errors are answered as they are.
  using Decision = decltype(HttpWrites::approve);
  void decide(const httplib::Request& req, const std::string& text, httplib::Response& res, const Decision& hook,
              const char* not_offered, const char* example) {
    if (!hook) return send_error(res, 501, not_offered);
    Result<std::int64_t> id = path_id(req.matches[1], "pending table id");
    if (!id) return send_error(res, id.error());
    Result<json> body = body_object(text, {"by", "note"}, example);
    if (!body) return send_error(res, body.error());
    Result<std::string> by = string_field(*body, "by", true);
    if (!by) return send_error(res, by.error());
    Result<std::string> note = string_field(*body, "note", false);
    if (!note) return send_error(res, note.error());
    answer(res, hook(*id, *by, *note));
  }

  void approve(const httplib::Request& req, const std::string& text, httplib::Response& res) {
    decide(req, text, res, writes.approve, "this service does not approve tables",
           R"({"by": "anna", "note": "checked the lobe"})");
  }

  void reject(const httplib::Request& req, const std::string& text, httplib::Response& res) {
    decide(req, text, res, writes.reject, "this service does not reject tables",
           R"({"by": "anna", "note": "flank error from a worn wheel"})");
  }

  void rollback(const httplib::Request&, const std::string& text, httplib::Response& res) {
    if (!writes.rollback) return send_error(res, 501, "this service does not roll tables back");
    Result<json> body =
        body_object(text, {"program", "version", "by"}, R"({"program": "CAM_INTAKE_L1", "version": 3, "by": "anna"})");
    if (!body) return send_error(res, body.error());
    Result<std::string> program = string_field(*body, "program", true);
    if (!program) return send_error(res, program.error());
    Result<int> version = int_field(*body, "version", 1, INT_MAX);
    if (!version) return send_error(res, version.error());
    Result<std::string> by = string_field(*body, "by", true);
    if (!by) return send_error(res, by.error());
    answer(res, writes.rollback(*program, *version, *by));
  }

  // ---- New programs ----

  // The part and lobe a preview is of, from ?part=&lobe=.
  Result<std::pair<std::string, int>> preview_query(const httplib::Request& req) const {
    Result<Query> q = Query::of(req, {"part", "lobe"});
    if (!q) return q.error();
    Result<int> lobe = q->integer("lobe", 0, 1, kMaxLobe);
    if (!lobe) return lobe.error();
    if (q->text("part").empty() || *lobe == 0) {
      return bad_request(
          "a new program is of one configured part: give `part` and `lobe`, e.g. "
          "?part=intake_flat&lobe=1 (GET /api/health lists the parts)");
    }
    return std::make_pair(q->text("part"), *lobe);
  }

  Result<NewProgramPreview> program_preview(const httplib::Request& req) const {
    Result<std::pair<std::string, int>> q = preview_query(req);
    if (!q) return q.error();
    return status.program_preview(q->first, q->second);
  }

  void new_program_preview(const httplib::Request& req, httplib::Response& res) {
    if (!status.program_preview) return send_error(res, 501, "this service does not preview new programs");
    Result<NewProgramPreview> p = program_preview(req);
    if (!p) return send_error(res, p.error());
    send_json(res, 200, p->body);
  }

  void new_program_plot(const httplib::Request& req, httplib::Response& res) {
    if (!status.program_preview) return send_error(res, 501, "this service does not preview new programs");
    Result<NewProgramPreview> p = program_preview(req);
    if (!p) return send_error(res, p.error());
    Result<std::string> svg =
        file_written_by([&](const fs::path& out) { return write_program_preview(p->page, out); }, "preview.svg");
    if (!svg) return send_error(res, svg.error());
    res.status = 200;
    res.set_content(std::move(*svg), "image/svg+xml");
  }

  void new_program(const httplib::Request&, const std::string& text, httplib::Response& res) {
    if (!writes.new_program) return send_error(res, 501, "this service does not write new programs");
    Result<json> body = body_object(text, {"part", "lobe", "by", "replace"},
                                    R"({"part": "intake_flat", "lobe": 1, "by": "anna", "replace": false})");
    if (!body) return send_error(res, body.error());
    Result<std::string> part = string_field(*body, "part", true);
    if (!part) return send_error(res, part.error());
    Result<int> lobe = int_field(*body, "lobe", 1, kMaxLobe);
    if (!lobe) return send_error(res, lobe.error());
    Result<std::string> by = string_field(*body, "by", true);
    if (!by) return send_error(res, by.error());
    Result<bool> replace = bool_field(*body, "replace");
    if (!replace) return send_error(res, replace.error());
    answer(res, writes.new_program(*part, *lobe, *by, *replace));
  }

  // ---- Helpers ----

  // Answers with what `read` builds from a pooled store, or with its error.
  void with_store(httplib::Response& res, const std::function<Result<json>(RunStore&)>& read) {
    Result<StorePool::Lease> store = stores.acquire();
    if (!store) return send_error(res, store.error());
    Result<json> out = read(**store);
    if (!out) return fail_with_store(res, *store, out.error());
    send_json(res, 200, *out);
  }

  // Answers with the runs `read` lists from the history the lists read ([http] history): the
  // service's file, or the central history. Each row says whether its run is in the file
  // (`here`): a run of another grinder has its page, export and report on that grinder.
  void with_history(httplib::Response& res,
                    const std::function<Result<std::vector<RunSummary>>(const RunHistory&)>& read) {
    Result<std::vector<RunSummary>> runs = read_history(read);
    if (!runs) return send_error(res, runs.error());
    Result<std::set<std::string>> here = runs_here(*runs);
    if (!here) return send_error(res, here.error());
    json out = json::array();
    for (const RunSummary& r : *runs) {
      json row = run_summary_json(r);
      row["here"] = here->count(r.uuid) > 0;
      out.push_back(std::move(row));
    }
    send_json(res, 200, out);
  }

  // What `read` reads from the history the lists read; a connection that failed is closed.
  template <typename Read>
  auto read_history(const Read& read) -> std::invoke_result_t<const Read&, const RunHistory&> {
    if (!central) {
      Result<StorePool::Lease> store = stores.acquire();
      if (!store) return store.error();
      auto out = read(static_cast<const RunHistory&>(**store));
      if (!out && out.error().code == ErrorCode::kStorage) store->discard();
      return out;
    }
    Result<CentralHistoryPool::Lease> history = central->acquire();
    if (!history) return history.error();
    auto out = read(static_cast<const RunHistory&>(**history));
    if (!out && out.error().code == ErrorCode::kStorage) history->discard();
    return out;
  }

  // The UUIDs of `runs` whose runs are in the service's file: all of them when the lists read
  // the file; none before its first run.
  Result<std::set<std::string>> runs_here(const std::vector<RunSummary>& runs) {
    std::vector<std::string> uuids;
    for (const RunSummary& r : runs) uuids.push_back(r.uuid);
    if (!central) return std::set<std::string>(uuids.begin(), uuids.end());
    std::error_code ec;
    if (!fs::exists(stores.path(), ec)) return std::set<std::string>();
    Result<StorePool::Lease> store = stores.acquire();
    if (!store) return store.error();
    Result<std::set<std::string>> here = (*store)->runs_here(uuids);
    if (!here && here.error().code == ErrorCode::kStorage) store->discard();
    return here;
  }

  static void fail_with_store(httplib::Response& res, StorePool::Lease& store, const Error& e) {
    if (e.code == ErrorCode::kStorage) store.discard();
    send_error(res, e);
  }

  std::string current_token() const {
    std::lock_guard lock(token_mutex);
    return token;
  }

  const HttpSettings settings;
  mutable std::mutex token_mutex;
  std::string token = settings.token;  // guarded by token_mutex; set_token replaces it
  StorePool stores;
  // [http] history = "central": the plant's history the run lists and trends read; else none.
  const std::unique_ptr<CentralHistoryPool> central;
  DatabaseStateLog database_log;  // how /metrics last found the database
  const HttpWrites writes;
  const HttpStatus status;
  std::vector<std::pair<std::string, std::regex>> routes;  // for 405: the method a path takes
  // An httplib::SSLServer with [http] tls_cert and tls_key: one set of routes either way.
  const std::unique_ptr<httplib::Server> server;
  int port = 0;
  std::thread listener;
  std::atomic<bool> listener_done{false};
  std::unique_ptr<HttpFront> front;  // plain HTTP: the connections' front door
};

HttpApi::HttpApi(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}

HttpApi::~HttpApi() { stop(); }

int HttpApi::port() const { return impl_->port; }

void HttpApi::set_token(std::string token) {
  std::lock_guard lock(impl_->token_mutex);
  impl_->token = std::move(token);
}

bool HttpApi::alive() const {
  return impl_->server->is_running() && !impl_->listener_done && (!impl_->front || impl_->front->alive());
}

namespace {

// Plain HTTP, or HTTPS when the settings name a certificate and key. kInvalidInput naming the
// files when they cannot be read or are not a PEM certificate and its key.
Result<std::unique_ptr<httplib::Server>> make_server(const HttpSettings& settings) {
  if (settings.tls_cert.empty() && settings.tls_key.empty()) return std::make_unique<httplib::Server>();
  if (settings.tls_cert.empty() || settings.tls_key.empty()) {
    return make_error(ErrorCode::kInvalidInput,
                      "[http] tls_cert and tls_key go together: give both for HTTPS, or neither for plain HTTP");
  }
  for (const auto& [key, file] : {std::pair{"tls_cert", settings.tls_cert}, std::pair{"tls_key", settings.tls_key}}) {
    if (!std::ifstream(file)) {
      return make_error(ErrorCode::kInvalidInput, std::string("cannot read the [http] ") + key + " file " +
                                                      file.string() +
                                                      ": check that it exists and that the service's user may read it");
    }
  }
  auto server = std::make_unique<httplib::SSLServer>(settings.tls_cert.c_str(), settings.tls_key.c_str());
  if (!server->is_valid()) {
    return make_error(ErrorCode::kInvalidInput,
                      "cannot serve HTTPS with the certificate " + settings.tls_cert.string() + " and the key " +
                          settings.tls_key.string() +
                          ": both must be PEM files, the key unencrypted and the one of the certificate "
                          "([http] tls_cert, tls_key)");
  }
  return std::unique_ptr<httplib::Server>(std::move(server));
}

}  // namespace

Result<std::unique_ptr<HttpApi>> HttpApi::start(const HttpSettings& settings, std::filesystem::path db_path,
                                                HttpWrites writes, HttpStatus status, HttpFrontLimits front) {
  if (settings.port < 0 || settings.port > 65535) {
    return make_error(ErrorCode::kInvalidInput,
                      "HTTP port " + std::to_string(settings.port) + " is not a port; use 1 to 65535, or 0 for any");
  }
  Result<std::unique_ptr<httplib::Server>> server = make_server(settings);
  if (!server) return server.error();
  auto impl =
      std::make_unique<Impl>(settings, std::move(db_path), std::move(writes), std::move(status), std::move(*server));
  Impl& s = *impl;
  using R = const httplib::Request&;
  using W = httplib::Response&;
  using B = const std::string&;
  s.route("/api/health", [&s](R q, W a) { s.health(q, a); });
  s.route("/api/runs", [&s](R q, W a) { s.list_runs(q, a); });
  s.route("/api/runs/([^/]+)", [&s](R q, W a) { s.show_run(q, a); });
  s.route("/api/runs/([^/]+)/export", [&s](R q, W a) { s.export_run(q, a); });
  s.route("/api/gear-runs", [&s](R q, W a) { s.list_gear_runs(q, a); });
  s.route("/api/gear-runs/([^/]+)", [&s](R q, W a) { s.show_gear_run(q, a); });
  s.route("/api/gear-runs/([^/]+)/report.pdf", [&s](R q, W a) { s.gear_run_report(q, a); });
  s.route("/api/trend", [&s](R q, W a) { s.trend(q, a); });
  s.route("/api/events", [&s](R q, W a) { s.events(q, a); });
  s.route("/api/nc/table", [&s](R q, W a) { s.nc_table(q, a); });
  s.route("/api/nc/history", [&s](R q, W a) { s.nc_history(q, a); });
  s.route("/api/nc/pending", [&s](R q, W a) { s.nc_pending(q, a); });
  s.route("/api/nc/pending/([^/]+)", [&s](R q, W a) { s.pending_table(q, a); });
  s.route("/api/runs/([^/]+)/plot.svg", [&s](R q, W a) { s.run_plot(q, a); });
  s.route("/api/runs/([^/]+)/report.pdf", [&s](R q, W a) { s.run_report(q, a); });
  s.route("/api/trend.svg", [&s](R q, W a) { s.trend_plot(q, a); });
  s.route("/api/nc/new", [&s](R q, W a) { s.new_program_preview(q, a); });
  s.route("/api/nc/new/plot.svg", [&s](R q, W a) { s.new_program_plot(q, a); });
  s.route("/api/shaft", [&s](R q, W a) { s.shaft(q, a); });
  s.route("/metrics", [&s](R q, W a) { s.metrics(q, a); });
  s.route("/", &Impl::redirect_to_pages);
  s.route("/ui", &Impl::redirect_to_pages);
  s.route("/ui/([^/]*)", [&s](R q, W a) { s.page_asset(q, a); });
  s.route_write("/api/measure", [&s](R q, B b, W a) { s.measure(q, b, a); });
  s.route_write("/api/nc/approve/([^/]+)", [&s](R q, B b, W a) { s.approve(q, b, a); });
  s.route_write("/api/nc/rollback", [&s](R q, B b, W a) { s.rollback(q, b, a); });
  s.route_write("/api/nc/reject/([^/]+)", [&s](R q, B b, W a) { s.reject(q, b, a); });
  s.route_write("/api/nc/new", [&s](R q, B b, W a) { s.new_program(q, b, a); });
  s.server->set_pre_routing_handler([&s](R q, W a) { return s.before_body(q, a); });
  s.server->set_error_handler([&s](R q, W a) { s.fill_error(q, a); });
  s.server->set_exception_handler([](R q, W a, std::exception_ptr ep) { Impl::internal_error(q, a, std::move(ep)); });
  s.server->set_payload_max_length(kMaxBodyBytes);
  // httplib's default also sets SO_REUSEPORT, which lets a second service bind the same port and
  // take half the requests. SO_REUSEADDR alone still allows a restart while old connections
  // linger in TIME_WAIT.
  s.server->set_socket_options([](socket_t sock) {
    const int yes = 1;
    ::setsockopt(sock, SOL_SOCKET, SO_REUSEADDR, &yes, sizeof yes);
  });
  s.server->set_logger([](R q, const httplib::Response& a) {
    // Behind the front the peer is the front: the client is its X-Forwarded-For.
    const std::string from = q.has_header("X-Forwarded-For") ? q.get_header_value("X-Forwarded-For") : q.remote_addr;
    spdlog::debug("http: {} {} from {} -> {}", q.method, q.path, from, a.status);
  });

  // Plain HTTP: the server on loopback behind the front, which takes the address asked for.
  const bool behind_front = settings.tls_cert.empty();
  const std::string server_host = behind_front ? std::string("127.0.0.1") : settings.host;
  const int server_port = behind_front ? 0 : settings.port;
  const int port = server_port == 0 ? s.server->bind_to_any_port(server_host)
                                    : (s.server->bind_to_port(server_host, server_port) ? server_port : -1);
  if (port < 0) {
    return make_error(ErrorCode::kIo, "cannot serve HTTP on " + server_host + ":" + std::to_string(server_port) +
                                          ": the port is in use or the host is not an address of this machine; "
                                          "change [http] host or port");
  }
  s.port = port;
  if (behind_front) {
    Result<std::unique_ptr<HttpFront>> f = HttpFront::start(settings.host, settings.port, port, front);
    if (!f) return f.error();
    s.front = std::move(*f);
    s.port = s.front->port();
  }
  s.listener = start_guarded_thread(
      "HTTP listener",
      [&s] {
        s.server->listen_after_bind();
        s.listener_done = true;
      },
      [&s](std::string_view name, std::string_view what) {
        spdlog::error("the {} thread was ended by an exception: {}; the HTTP API no longer answers", name, what);
        s.listener_done = true;
      });
  // stop() before the listener runs would be lost (httplib only stops a running server), so
  // start() returns once it runs (or, should it fail at once, has ended).
  while (!s.server->is_running() && !s.listener_done) std::this_thread::yield();
  return std::unique_ptr<HttpApi>(new HttpApi(std::move(impl)));
}

void HttpApi::stop() {
  if (!impl_ || !impl_->listener.joinable()) return;
  if (impl_->front) impl_->front->stop();
  impl_->server->stop();
  impl_->listener.join();
}

}  // namespace gaugeloop
