// The Prometheus text of the run database's series.
#include "service/metrics_text.h"

#include <climits>
#include <cstdint>
#include <ctime>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <tuple>
#include <vector>

#include "core/utc_time.h"

namespace gaugeloop {
namespace {

// Every list read in full asks for this many rows.
constexpr int kAll = INT_MAX;

std::string number(double v) {
  nlohmann::json j = v;
  return j.dump();  // shortest text that reads back exactly
}

std::string label_value(const std::string& v) { return prometheus_label_value(v); }

}  // namespace

std::string prometheus_label_value(const std::string& v) {
  std::string out;
  for (const char c : v) {
    if (c == '\\' || c == '"') {
      out += '\\';
      out += c;
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

Status append_database_metrics(const RunStore& store, std::string& out) {
  RunQuery rq;
  rq.limit = kAll;
  Result<std::vector<RunSummary>> runs = store.list_runs(rq);  // newest first
  if (!runs) return runs.error();
  EventQuery eq;
  eq.limit = kAll;
  Result<std::vector<StoredEvent>> events = store.list_events(eq);
  if (!events) return events.error();
  PendingQuery pq;
  pq.limit = kAll;
  pq.status = PendingStatus::kPending;
  Result<std::vector<PendingTable>> pending = store.list_pending(pq);
  if (!pending) return pending.error();

  std::map<std::string, std::int64_t> by_status{{"measured", 0}, {"pushed", 0}};
  // The newest run of each machine, part and lobe (the list is newest first).
  std::map<std::tuple<std::string, std::string, int>, const RunSummary*> last;
  for (const RunSummary& r : *runs) {
    ++by_status[r.status];
    last.emplace(std::make_tuple(r.machine, r.part, r.lobe), &r);
  }
  std::map<std::string, std::int64_t> by_kind{{"fault", 0}, {"refusal", 0}, {"info", 0}};
  for (const StoredEvent& e : *events) ++by_kind[std::string(event_kind_name(e.event.kind))];

  std::string s;
  s += "# HELP gaugeloop_runs_stored Runs in the database, by status.\n# TYPE gaugeloop_runs_stored gauge\n";
  for (const auto& [st, n] : by_status) {
    s += "gaugeloop_runs_stored{status=\"" + label_value(st) + "\"} " + std::to_string(n) + "\n";
  }
  s += "# HELP gaugeloop_events_stored Faults, refusals and service steps (info) in the database, by kind.\n"
       "# TYPE gaugeloop_events_stored gauge\n";
  for (const auto& [kind, n] : by_kind) {
    s += "gaugeloop_events_stored{kind=\"" + label_value(kind) + "\"} " + std::to_string(n) + "\n";
  }
  s += "# HELP gaugeloop_pending_tables NC tables waiting for approval.\n# TYPE gaugeloop_pending_tables gauge\n";
  s += "gaugeloop_pending_tables " + std::to_string(pending->size()) + "\n";
  const auto labels = [](const RunSummary& r) {
    return "{machine=\"" + label_value(r.machine) + "\",part=\"" + label_value(r.part) + "\",lobe=\"" +
           std::to_string(r.lobe) + "\"}";
  };
  s += "# HELP gaugeloop_last_run_max_abs_error_um Largest lift error of the newest run of each lobe (um, cam "
       "frame).\n# TYPE gaugeloop_last_run_max_abs_error_um gauge\n";
  for (const auto& [key, r] : last)
    s += "gaugeloop_last_run_max_abs_error_um" + labels(*r) + " " + number(r->max_abs_error_um) + "\n";
  s += "# HELP gaugeloop_last_run_id Id of the newest run of each lobe.\n# TYPE gaugeloop_last_run_id gauge\n";
  for (const auto& [key, r] : last) s += "gaugeloop_last_run_id" + labels(*r) + " " + std::to_string(r->id) + "\n";
  s += "# HELP gaugeloop_last_run_started_timestamp_seconds When the newest run of each lobe started.\n"
       "# TYPE gaugeloop_last_run_started_timestamp_seconds gauge\n";
  for (const auto& [key, r] : last) {
    if (const std::optional<std::time_t> t = epoch_of_utc(r->started_utc)) {
      s += "gaugeloop_last_run_started_timestamp_seconds" + labels(*r) + " " + std::to_string(*t) + "\n";
    }
  }
  out += s;
  return {};
}
}  // namespace gaugeloop
