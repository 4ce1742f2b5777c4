// The Prometheus text /metrics answers with: the series read from the run database, the
// build's identity, and the escaping every label value needs. docs/http_api.md, "/metrics".
#pragma once

#include <atomic>
#include <string>

#include "core/result.h"
#include "storage/run_store.h"

namespace gaugeloop {

// A label value escaped as the Prometheus text format asks (backslash, quote, newline).
std::string prometheus_label_value(const std::string& value);

// The series of one database snapshot (RunStore::metrics_snapshot), appended to `out`.
// Names are in base units: the newest run's largest error is in metres.
void append_store_metrics(const StoreMetrics& m, std::string& out);

// The series read from the run database, appended to `out` only if every query succeeded.
// The cost of a scrape does not grow with the history (RunStore::metrics_snapshot).
Status append_database_metrics(const RunStore& store, std::string& out);

// gaugeloop_build_info{version="..."} 1: which gaugeloop answers.
void append_build_info(std::string& out);

// gaugeloop_database_up: 1 if this scrape read the database, else 0.
void append_database_up(bool up, std::string& out);

// How the run database answered a scrape.
enum class DatabaseState {
  kMissing,  // no file yet: normal before the first run
  kUp,       // read
  kFailed,   // there, but could not be read
};

// Remembers how the database answered the last scrape, so that a Prometheus server scraping
// every few seconds does not fill the log: a read error is logged when it starts and its end
// when it ends, never once per scrape. A missing file is never logged. Thread-safe: scrapes
// run on the HTTP server's worker threads.
class DatabaseStateLog {
 public:
  // Logs a warning naming `error` on a change to kFailed, and an info line on a change from
  // kFailed to another state. Returns true if it logged.
  bool note(DatabaseState state, const std::string& error = {});

 private:
  std::atomic<int> last_{static_cast<int>(DatabaseState::kMissing)};
};

}  // namespace gaugeloop
