// The HTTP API on cpp-httplib: the routes, the boundary every request passes (its head before
// its body, errors as JSON, the token), the service's health, pages and Prometheus metrics, and
// the server's start and stop. The handlers of runs and of curve tables are in
// http_api_runs.cc and http_api_nc.cc.
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
#include "core/utc_time.h"
#include "plant/central_history_pool.h"
#include "report/run_json.h"
#include "service/http_api_impl.h"
#include "service/metrics_text.h"
#include "service/web_assets.h"
#include "storage/run_store.h"

namespace gaugeloop {

using namespace http_detail;

void HttpApi::Impl::route(const std::string& pattern, Handler handler) {
  routes.emplace_back("GET", std::regex(pattern));
  server->Get(pattern, [handler = std::move(handler)](const httplib::Request& req, httplib::Response& res) {
    try {
      handler(req, res);
    } catch (...) {
      internal_error(req, res, std::current_exception());
    }
  });
}

void HttpApi::Impl::route_write(const std::string& pattern, WriteHandler handler) {
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

std::string HttpApi::Impl::too_large_message() {
  return "the request body is larger than " + std::to_string(kMaxBodyBytes / 1024) +
         " KiB; the API's bodies are small JSON objects (" + kDocs + ")";
}

bool HttpApi::Impl::has_route(const std::string& method, const std::string& path) const {
  const std::string m = method == "HEAD" ? "GET" : method;
  return std::any_of(routes.begin(), routes.end(),
                     [&](const auto& r) { return r.first == m && std::regex_match(path, r.second); });
}

httplib::Server::HandlerResponse HttpApi::Impl::before_body(const httplib::Request& req, httplib::Response& res) const {
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
    return refuse(
        400, req.method + " " + req.path + " takes no request body; give its parameters in the query (" + kDocs + ")");
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

void HttpApi::Impl::internal_error(const httplib::Request& req, httplib::Response& res, std::exception_ptr ep) {
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

void HttpApi::Impl::fill_error(const httplib::Request& req, httplib::Response& res) const {
  if (!res.body.empty() || res.has_header("Content-Type")) return;  // ours, maybe as a content provider
  if (res.status == 404) return answer_no_route(req, res);
  if (res.status == 413) return send_error(res, 413, too_large_message());
  send_error(res, res.status, "the request was malformed (HTTP status " + std::to_string(res.status) + ")");
}

void HttpApi::Impl::answer_no_route(const httplib::Request& req, httplib::Response& res) const {
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

void HttpApi::Impl::health(const httplib::Request&, httplib::Response& res) {
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

void HttpApi::Impl::page_asset(const httplib::Request& req, httplib::Response& res) {
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

void HttpApi::Impl::redirect_to_pages(const httplib::Request&, httplib::Response& res) {
  res.status = 302;
  res.set_header("Location", "/ui/");
  res.set_content("the pages are at /ui/\n", "text/plain; charset=utf-8");
}

void HttpApi::Impl::metrics(const httplib::Request& req, httplib::Response& res) {
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

bool HttpApi::Impl::authorized(const httplib::Request& req, httplib::Response& res) const {
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

void HttpApi::Impl::check_token(const httplib::Request& req, httplib::Response& res) const {
  Result<Query> q = Query::of(req, {});
  if (!q) return send_error(res, q.error());
  if (!authorized(req, res)) return;
  send_json(res, 200, json{{"token", "accepted"}});
}

void HttpApi::Impl::answer(httplib::Response& res, const Result<json>& out) {
  if (!out) return send_error(res, out.error());
  send_json(res, 200, *out);
}

void HttpApi::Impl::with_store(httplib::Response& res, const std::function<Result<json>(RunStore&)>& read) {
  Result<StorePool::Lease> store = stores.acquire();
  if (!store) return send_error(res, store.error());
  Result<json> out = read(**store);
  if (!out) return fail_with_store(res, *store, out.error());
  send_json(res, 200, *out);
}

void HttpApi::Impl::with_history(httplib::Response& res,
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

Result<std::set<std::string>> HttpApi::Impl::runs_here(const std::vector<RunSummary>& runs) {
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

void HttpApi::Impl::fail_with_store(httplib::Response& res, StorePool::Lease& store, const Error& e) {
  if (e.code == ErrorCode::kStorage) store.discard();
  send_error(res, e);
}

std::string HttpApi::Impl::current_token() const {
  std::lock_guard lock(token_mutex);
  return token;
}

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
  s.route("/api/token", [&s](R q, W a) { s.check_token(q, a); });
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
