// The service's HTTP API: the run history, the tables on the control and Prometheus metrics
// for anyone on the network it is bound to; measurement triggers, approvals and rollbacks for
// those holding the token. Endpoints, parameters and errors: docs/http_api.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "config/service_config.h"
#include "core/result.h"
#include "report/program_preview.h"
#include "report/shaft.h"
#include "service/http_front.h"

namespace gaugeloop {

// Writes the service provides. Each returns the JSON body of a 200 answer, or an Error whose
// code chooses the status (docs/http_api.md, "Errors"): kInvalidInput 400, kNotFound 404,
// kRefused 409 (e.g. a measurement already running, a table no longer pending), kStorage and
// kIo 503, a gauge error 502, anything else 500. An empty hook answers 501.
// Thread: called on the API's worker threads, possibly several at once; only after the token
// was checked and the body parsed (part, program and by not empty; lobe and version >= 1;
// serial and operator empty or checked by check_run_identity; part_temperature_c empty or
// checked and rounded by checked_part_temperature_c).
struct HttpWrites {
  std::function<Result<nlohmann::json>(const std::string& part, int lobe, const std::string& note,
                                       const std::string& serial, const std::string& operator_name,
                                       std::optional<double> part_temperature_c)>
      trigger_measure;
  std::function<Result<nlohmann::json>(std::int64_t pending_id, const std::string& by, const std::string& note)>
      approve;
  // Service::reject: it takes the push slot, so a rejection never lands between an approval's
  // check and its write.
  std::function<Result<nlohmann::json>(std::int64_t pending_id, const std::string& by, const std::string& note)> reject;
  // `program` as the client gave it: a program name (CAM_INTAKE_L1) or an NC file path.
  std::function<Result<nlohmann::json>(const std::string& program, int table_version, const std::string& by)> rollback;
  // The first program of a configured part (POST /api/nc/new), as `gaugeloop nc new`:
  // `replace` writes it over a program with a history.
  std::function<Result<nlohmann::json>(const std::string& part, int lobe, const std::string& by, bool replace)>
      new_program;
};

// A new program's preview before anything is written: the JSON GET /api/nc/new answers, and
// the page GET /api/nc/new/plot.svg draws.
struct NewProgramPreview {
  nlohmann::json body;
  ProgramPreviewPage page;
};

// What the service adds to /api/health and /metrics. Same threads as HttpWrites.
struct HttpStatus {
  // An object merged into /api/health, e.g. {"state": "idle", "config": "/etc/gaugeloop.toml"}.
  std::function<nlohmann::json()> health;
  // Prometheus text lines (with their # HELP and # TYPE) appended to /metrics, e.g. the
  // counters the service keeps.
  std::function<std::string()> extra_metrics;
  // The camshafts the service knows (shaft files: lobes and their nominal angles), for
  // /api/shaft: a serial's newest run of each lobe and its index error. Empty hook, or none
  // returned: /api/shaft answers 404 and the pages list a serial's lobes without index errors.
  std::function<std::vector<ShaftLayout>()> shafts;
  // The preview of a configured part's first program (GET /api/nc/new, no token: nothing is
  // written). Empty hook: 501.
  std::function<Result<NewProgramPreview>(const std::string& part, int lobe)> program_preview;
};

// cpp-httplib's server on a thread of its own (and its worker threads): HTTPS when the settings
// name tls_cert and tls_key, else plain HTTP. Every request reads the run database at db_path
// through a RunStore of its own (connections are pooled), so the API never blocks the service
// writing runs; a missing database answers 503. A request body is held only by a write, only
// after the token was checked, and never beyond 64 KiB, whatever its transfer encoding.
// Lifetime: the hooks are called until stop() returns; stop them after, not before.
// Thread: start, port and stop from one thread.
class HttpApi {
 public:
  // Binds host:port and starts serving before it returns. kIo naming the address when it
  // cannot bind (in use, or not an address of this machine); kInvalidInput naming the files
  // when only one of tls_cert and tls_key is set, or they cannot be read or loaded as a PEM
  // certificate and its (unencrypted) key.
  // Plain HTTP goes through the front (service/http_front.h, `front`: its limits), which
  // listens on host:port and hands complete request heads to the server on loopback; HTTPS is
  // served by the server itself.
  static Result<std::unique_ptr<HttpApi>> start(const HttpSettings& settings, std::filesystem::path db_path,
                                                HttpWrites writes, HttpStatus status, HttpFrontLimits front = {});

  HttpApi(const HttpApi&) = delete;
  HttpApi& operator=(const HttpApi&) = delete;
  ~HttpApi();  // stop()

  int port() const;  // the port bound, also when settings.port was 0

  // The token writes need from now on (empty: read-only), e.g. re-read on SIGHUP. Any thread.
  void set_token(std::string token);
  // True while the listener accepts connections (for the watchdog). Any thread.
  bool alive() const;

  // Stops accepting, lets requests in progress finish, and joins the threads. Idempotent.
  void stop();

 private:
  struct Impl;
  explicit HttpApi(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace gaugeloop
