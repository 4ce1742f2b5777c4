// The HTTP API's server (HttpApi::Impl): its routes' handlers, their state and the helpers they
// share. Its members are defined by subject: routing, answers, the service's own pages and
// metrics in http_api.cc; runs, trends, events and shafts in http_api_runs.cc; curve tables and
// new programs in http_api_nc.cc. Internal to the service's HTTP API.
#pragma once

#include <httplib.h>

#include <atomic>
#include <exception>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <regex>
#include <set>
#include <string>
#include <thread>
#include <type_traits>
#include <utility>
#include <vector>

#include "plant/central_history_pool.h"
#include "service/http_api.h"
#include "service/http_support.h"
#include "service/metrics_text.h"
#include "storage/run_store.h"

namespace gaugeloop {

struct HttpApi::Impl {
  using StorePool = http_detail::StorePool;
  using json = nlohmann::json;

  Impl(HttpSettings s, std::filesystem::path db, HttpWrites w, HttpStatus st, std::unique_ptr<httplib::Server> srv)
      : settings(std::move(s)),
        stores(std::move(db)),
        central(settings.history_url.empty() ? nullptr : std::make_unique<CentralHistoryPool>(settings.history_url)),
        writes(std::move(w)),
        status(std::move(st)),
        server(std::move(srv)) {}

  using Handler = std::function<void(const httplib::Request&, httplib::Response&)>;
  // A write: the request and its body, read whole.
  using WriteHandler = std::function<void(const httplib::Request&, const std::string& body, httplib::Response&)>;

  // ---- Routing and answers (http_api.cc) ----

  // Registers a read behind the one boundary that turns any exception into a 500.
  void route(const std::string& pattern, Handler handler);

  // Registers a write, behind the same boundary. Its body is read here as it arrives and never
  // beyond kMaxBodyBytes, whatever its transfer encoding: httplib's own limit holds only for a
  // body with a Content-Length. before_body has checked the token and the headers.
  void route_write(const std::string& pattern, WriteHandler handler);

  static std::string too_large_message();

  // Whether `method` (HEAD as GET) has a route matching `path`.
  bool has_route(const std::string& method, const std::string& path) const;

  // Runs once the request's head is read and before any of its body: httplib reads the body of
  // a POST, PUT, PATCH or DELETE whole before routing it (a chunked one, or one without a
  // length, with no bound), and leaves a GET's body unread to be parsed as the next request. So
  // a request with a body where none is taken is answered here; a write's token is checked
  // before a byte of its body is read, then its framing, length and type. Every answer given
  // here ends the connection, the body unread.
  httplib::Server::HandlerResponse before_body(const httplib::Request& req, httplib::Response& res) const;

  static void internal_error(const httplib::Request& req, httplib::Response& res, std::exception_ptr ep);

  // Every answer of 400 or more without a body (no route, a request httplib refused) gets one.
  void fill_error(const httplib::Request& req, httplib::Response& res) const;

  // 405 naming the method the path takes, or 404.
  void answer_no_route(const httplib::Request& req, httplib::Response& res) const;

  // ---- Service, pages and metrics (http_api.cc) ----

  // Takes no parameters and ignores any: a monitor's cache-busting `?t=...` must not turn
  // "the service answers" into a 400.
  void health(const httplib::Request&, httplib::Response& res);

  // The pages' files, built into the binary (service/web). /ui/ is the app (index.html).
  void page_asset(const httplib::Request& req, httplib::Response& res);

  static void redirect_to_pages(const httplib::Request&, httplib::Response& res);

  void metrics(const httplib::Request& req, httplib::Response& res);

  // ---- Writes: the token and the answer (http_api.cc) ----

  // The token check every write passes first, before its body is read (before_body). False:
  // the answer is already set.
  bool authorized(const httplib::Request& req, httplib::Response& res) const;

  // GET /api/token: the check a write's token passes, and nothing written. 200 for the token
  // configured; 401 or 403 as a write would be answered. The pages check a token as it is entered.
  void check_token(const httplib::Request& req, httplib::Response& res) const;

  static void answer(httplib::Response& res, const Result<json>& out);

  // ---- Helpers (http_api.cc) ----

  // Answers with what `read` builds from a pooled store, or with its error.
  void with_store(httplib::Response& res, const std::function<Result<json>(RunStore&)>& read);

  // Answers with the runs `read` lists from the history the lists read ([http] history): the
  // service's file, or the central history. Each row says whether its run is in the file
  // (`here`): a run of another grinder has its page, export and report on that grinder.
  void with_history(httplib::Response& res,
                    const std::function<Result<std::vector<RunSummary>>(const RunHistory&)>& read);

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
  Result<std::set<std::string>> runs_here(const std::vector<RunSummary>& runs);

  static void fail_with_store(httplib::Response& res, StorePool::Lease& store, const Error& e);

  std::string current_token() const;

  // ---- Runs, trends, events, shafts and their pictures (http_api_runs.cc) ----

  void list_runs(const httplib::Request& req, httplib::Response& res);

  void list_gear_runs(const httplib::Request& req, httplib::Response& res);

  void gear_run_report(const httplib::Request& req, httplib::Response& res);

  void show_gear_run(const httplib::Request& req, httplib::Response& res);

  Result<StoredRun> load_run(RunStore& store, const std::string& id_text);

  void show_run(const httplib::Request& req, httplib::Response& res);

  void export_run(const httplib::Request& req, httplib::Response& res);

  void trend(const httplib::Request& req, httplib::Response& res);

  void events(const httplib::Request& req, httplib::Response& res);

  // The shaft record of a serial, as `gaugeloop runs shaft --json`, against the shaft the
  // service knows that `shaft` names; without it, the one shaft, or the one the serial has
  // runs of.
  void shaft(const httplib::Request& req, httplib::Response& res);

  // The run the path names, for an answer made of it alone (no query parameters); nullopt when
  // the error was sent.
  // The run the path names; `known`: the query parameters the endpoint takes (others are 400).
  std::optional<StoredRun> path_run(const httplib::Request& req, httplib::Response& res,
                                    std::vector<std::string> known = {});

  void run_plot(const httplib::Request& req, httplib::Response& res);

  // The cam report as `runs report` writes it, written to a file of its own and served from it.
  void run_report(const httplib::Request& req, httplib::Response& res);

  // One characteristic of a lobe over its runs, with its limits: the trend plot of
  // `runs trend --plot`, as SVG.
  void trend_plot(const httplib::Request& req, httplib::Response& res);

  void measure(const httplib::Request&, const std::string& text, httplib::Response& res);

  // ---- Curve tables: history, pending, decisions, new programs (http_api_nc.cc) ----

  void nc_table(const httplib::Request& req, httplib::Response& res);

  void nc_history(const httplib::Request& req, httplib::Response& res);

  void nc_pending(const httplib::Request& req, httplib::Response& res);

  // One pending table with its program text, for a look at it (and a diff) before deciding.
  void pending_table(const httplib::Request& req, httplib::Response& res);

  // Approve and reject take the same body; `hook` decides, and its errors are answered as they are.
  using Decision = decltype(HttpWrites::approve);
  void decide(const httplib::Request& req, const std::string& text, httplib::Response& res, const Decision& hook,
              const char* not_offered, const char* example);

  void approve(const httplib::Request& req, const std::string& text, httplib::Response& res);

  void reject(const httplib::Request& req, const std::string& text, httplib::Response& res);

  void rollback(const httplib::Request&, const std::string& text, httplib::Response& res);

  // The part and lobe a preview is of, from ?part=&lobe=.
  Result<std::pair<std::string, int>> preview_query(const httplib::Request& req) const;

  Result<NewProgramPreview> program_preview(const httplib::Request& req) const;

  void new_program_preview(const httplib::Request& req, httplib::Response& res);

  void new_program_plot(const httplib::Request& req, httplib::Response& res);

  void new_program(const httplib::Request&, const std::string& text, httplib::Response& res);

  // ---- State ----

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

}  // namespace gaugeloop
